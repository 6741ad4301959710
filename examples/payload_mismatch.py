"""The cascade with the payload mass mis-estimated by ±30% in the controller, on the erector.

The plant carries the spec's 4 t segment; the controller's model (G1's M, C, G) believes
2.8 t or 5.2 t. Runs the acceptance move and the segment placement with the correct estimate
and both wrong ones. Prints the table and writes it with comparison plots.

    python examples/payload_mismatch.py -o out/examples
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from _validation import (
    MOVE_Q0,
    PICK_Q0,
    acceptance_move,
    parse_args,
    placement_path,
    report,
    run_case,
)

import maniplab as ml

FACTORS = (1.0, 0.7, 1.3)


def label(factor: float, mass: float) -> str:
    if factor == 1.0:
        return f"payload known ({mass / 1e3:g} t)"
    return f"payload {factor - 1:+.0%} ({factor * mass / 1e3:g} t believed)"


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(__doc__.splitlines()[0], argv)
    spec = ml.builtin_spec("erector")
    model = ml.AnalyticModel(spec)
    mass = spec.end_effector.mass
    move = acceptance_move(model, short=args.short)
    cases = [run_case(spec, move, MOVE_Q0, label=label(f, mass), task="position",
                      payload_factor=f, model=model) for f in FACTORS]
    report("move_payload_mismatch", "Erector, Cartesian move: payload mis-estimated", cases, move,
           args.output)
    path = placement_path(model, short=args.short)
    placed = [run_case(spec, path, PICK_Q0, label=label(f, mass), task="pose", payload_factor=f,
                       model=model) for f in FACTORS]
    report("placement_payload_mismatch", "Erector segment placement: payload mis-estimated",
           placed, path, args.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
