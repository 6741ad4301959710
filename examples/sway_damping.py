"""A move of an arm whose tool hangs on passive joints, with and without sway damping: each
passive joint's deviation from the pose the tool hangs in, over time, in one figure, and the
residual sway and settling time of each run.

    python examples/sway_damping.py crane.yaml --start=0,-0.3,1.2,0,0 --goal 1.2,-0.3,1.2 \\
        --duration 3 -o sway.png

The move goes from the actuated joints' ``--start`` to the suspension point's position at the
actuated joints' ``--goal`` (the passive joints' values are ignored: the tool starts hanging).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import maniplab as ml
from maniplab.atomic import atomic_path
from maniplab.control.move import run_move
from maniplab.control.point_to_point import parse_numbers
from maniplab.control.suspended import hanging, passive_joints, suspended


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("spec", help="spec file or built-in name")
    parser.add_argument("--start", required=True, help="joint positions, rad or m")
    parser.add_argument("--goal", required=True, help="the actuated joints' goal, rad or m")
    parser.add_argument("--duration", type=float, default=3.0, help="the move's, s (default 3)")
    parser.add_argument("--settle", type=float, default=6.0, help="s after the move (default 6)")
    parser.add_argument("-o", "--output", type=Path, default=Path("out/sway.png"))
    args = parser.parse_args(argv)
    spec = ml.resolve_spec(args.spec)
    passive = passive_joints(spec)
    if not passive:
        print(f"{spec.name} has no passive joints: nothing hangs, nothing sways", file=sys.stderr)
        return 2
    arm = suspended(spec)
    start = parse_numbers(args.start, "--start", (spec.n,))
    goal = parse_numbers(args.goal, "--goal", (arm.n,))
    target = ml.AnalyticModel(arm).fk(goal)[:3, 3]
    figure, axes = plt.subplots(len(passive), 1, figsize=(7, 1.8 + 1.6 * len(passive)),
                                sharex=True, layout="constrained", squeeze=False)
    for damped in (False, True):
        result = run_move(spec, list(target), start=list(start), duration=args.duration,
                          settle=args.settle, sway_damping=damped)
        run, name = result.run, "with sway damping" if damped else "without"
        rest = hanging_poses(spec, run.q[::20], passive)
        for ax, k, column in zip(axes[:, 0], passive, rest.T, strict=True):
            ax.plot(run.t[::20], np.degrees(run.q[::20, k] - column), label=name)
            ax.set_ylabel(f"{spec.joint_names[k]} [deg]")
        end = result.plan.move.t0 + result.plan.move.duration
        for ax in axes[:, 0]:
            ax.axvline(end, color="C1" if damped else "C0", lw=0.8, ls=":")
        sways = ", ".join(f"{s.joint} {math.degrees(s.amplitude):.2f}° "
                          f"(settled {'never' if math.isinf(s.settling) else f'{s.settling:.2f} s'})"
                          for s in result.sway)
        print(f"{name}: move {result.plan.move.duration:.2f} s, final error "
              f"{result.metrics.final_error_mm:.2f} mm; residual sway {sways}")
    axes[0, 0].legend()
    axes[-1, 0].set_xlabel("time [s] (dotted: each move's end)")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.output) as path:
        figure.savefig(path, dpi=100)
    print(f"wrote {args.output}")
    return 0


def hanging_poses(spec: ml.ManipulatorSpec, q: np.ndarray, passive: list[int]) -> np.ndarray:
    """The passive joints' hanging pose at each of the poses q (K, n): (K, len(passive)), each
    search started from the last one's answer."""
    out, last = [], None
    for pose in q:
        last = hanging(spec, pose, guess=last)[passive]
        out.append(last)
    return np.array(out)


if __name__ == "__main__":
    sys.exit(main())
