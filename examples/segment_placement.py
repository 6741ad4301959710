"""Segment placement on the erector with the full cascade (feedback linearisation).

The erector (hydraulics, hybrid friction, joint limits, 4 t segment) picks the segment off the
feeder, turns it about the tunnel axis to its ring position and pushes it home, controlled in
pose (position and orientation); then the acceptance move: 1 m in 4 s, position controlled.
Prints the table and writes it with comparison plots and the runs to the output folder.

    python examples/segment_placement.py -o out/examples
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


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(__doc__.splitlines()[0], argv)
    spec = ml.builtin_spec("erector")
    model = ml.AnalyticModel(spec)
    path = placement_path(model, short=args.short)
    placement = run_case(spec, path, PICK_Q0, label="cascade, pose task", task="pose",
                         model=model)
    report("segment_placement", "Erector segment placement, full cascade", [placement], path,
           args.output)
    move = acceptance_move(model, short=args.short)
    moved = run_case(spec, move, MOVE_Q0, label="cascade", task="position", model=model)
    report("move_cascade", "Erector, Cartesian move, full cascade", [moved], move, args.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
