"""Choosing a counterbalance valve's pilot ratio: one joint lowered through the valve at each
ratio, the holding chamber's pressure over time in one figure, and each run's lowering finding.

    python examples/lowering_oscillation.py crane.yaml boom --ratios 1,6 --command -0.15 \\
        --start=0,-0.6,1.2,0.5,0 --set joints.boom.actuator.valve.compensator_margin=1.5e6 \\
        -o lowering.png

The joint's cylinder must have a counterbalance valve (``actuator.holding``) on the chamber that
drains while lowering; the command is the valve's, in its unit, held from 0.3 s; the run starts
at rest at ``--start`` with the pressures holding the arm.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import maniplab as ml
from maniplab.atomic import atomic_path
from maniplab.control.point_to_point import parse_numbers
from maniplab.sim.grammar import parse_assignment


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("spec", help="spec file or built-in name")
    parser.add_argument("joint", help="a joint whose pinned cylinder has a counterbalance valve")
    parser.add_argument("--ratios", default="1,3,8", help="pilot ratios to try (default 1,3,8)")
    parser.add_argument("--command", type=float, required=True,
                        help="the valve command that lowers, in its unit")
    parser.add_argument("--start", help="joint positions, rad or m (default: all 0)")
    parser.add_argument("--duration", type=float, default=2.5, help="s (default 2.5)")
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                        help="a spec override, as maniplab's --set (repeatable)")
    parser.add_argument("-o", "--output", type=Path, default=Path("out/lowering.png"))
    args = parser.parse_args(argv)
    spec = ml.resolve_spec(args.spec).with_overrides(
        dict(parse_assignment(text) for text in args.set))
    joint = spec.joint(args.joint)
    holding = getattr(joint.actuator, "holding", None)
    sides = [side for side in "ab" if getattr(holding, side, None) is not None
             and getattr(holding, side).type == "counterbalance"]
    if not sides:
        print(f"joint {joint.name} has no counterbalance valve (actuator.holding)",
              file=sys.stderr)
        return 2
    start = parse_numbers(args.start, "--start", (spec.n,)) if args.start else [0.0] * spec.n
    ratios = [float(r) for r in args.ratios.split(",")]
    figure, ax = plt.subplots(figsize=(7, 3.2), layout="constrained")
    k, side = spec.joint_index(joint.name), sides[0]
    for ratio in ratios:
        run = ml.simulate(spec, duration=args.duration, initial={"q": list(start), "dP": "gravity"},
                          overrides={f"joints.{joint.name}.actuator.holding.{side}.pilot_ratio":
                                     ratio},
                          inputs={joint.name: ml.signals.step(args.command, 0.3)})
        found = [f for f in run.health.findings if f.check == "lowering"]
        print(f"{ratio:g}:1: " + (found[0].cause if found else "lowers without oscillating"))
        ax.plot(run.t, run[f"p{side.upper()}"][:, k] / 1e5, label=f"pilot ratio {ratio:g}:1")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"{joint.name}: {side.upper()} side [bar]")
    ax.legend()
    args.output.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.output) as path:
        figure.savefig(path, dpi=100)
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
