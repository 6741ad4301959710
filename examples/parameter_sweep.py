"""A parameter sweep of the erector: payload x leakage, open loop, with the comparison figure.

The paper's designers varied the payload M_e, the leakage L_e and the viscous friction F_v to
see how they shape the response. This opens q2's valve to a constant current and compares the
position and pressure of every variant in one figure, then prints the physical trends.

    python examples/parameter_sweep.py -o out/sweep [--duration 3]
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

import maniplab as ml
from maniplab.viz.plots import compare, save_figure


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, default=Path("out/sweep"))
    parser.add_argument("--duration", type=float, default=3.0, help="simulated s per variant")
    args = parser.parse_args(argv)

    runs = ml.sweep("erector", {"end_effector.mass": [3000.0, 4000.0, 5000.0],
                                "joints.q2.actuator.leakage": [1e-12, 1e-11]},
                    out=args.output / "runs", duration=args.duration,
                    inputs={"q2": ml.signals.step(0.2, t0=0.1)}, initial={"dP": "gravity"})
    print(runs.table())
    figure = save_figure(compare(list(runs), signals=["q", "dP"], joints=["q1", "q2"]),
                         args.output / "sweep.png")
    print(f"\nfigure: {figure}")
    for run in runs:
        moving = run.t > 0.1
        print(f"{run.label:32s} mean q2 pressure {np.mean(run['dP'][moving, 1]) / 1e6:5.2f} MPa, "
              f"q2 at the end {run.q[-1, 1]:.4f} rad")
    return 0 if not runs.failures else 1


if __name__ == "__main__":
    sys.exit(main())
