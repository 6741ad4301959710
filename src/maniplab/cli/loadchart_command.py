"""``maniplab loadchart``: the largest payload the arm holds at each pose."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from maniplab.cli.common import (
    output_file,
    positive_int,
    set_option,
    spec_argument,
    spec_with_sets,
)


def add(sub: argparse._SubParsersAction) -> None:
    """Register the sub-command of this module."""
    chart = sub.add_parser(
        "loadchart", help="the largest payload the arm holds at each pose",
        description="For a grid of poses within the joint limits, the largest payload the "
                    "actuators hold at rest with the valves closed (each cylinder up to its "
                    "relief pressure, else its supply pressure; a torque source up to its "
                    "limit; friction not counted), each joint's structure carries (its "
                    "max_moment) and the machine carries without tipping (its base: mass, "
                    "centre of gravity, footprint), whichever is least, and what limits it. "
                    "Writes the chart over horizontal reach and height (.png, .svg, .pdf) or "
                    "every pose (.json).")
    spec_argument(chart)
    set_option(chart, "PATH=VALUE override of the spec, repeatable, e.g. base.mass=3000 or "
                      "joints.lift.max_moment=6e4")
    chart.add_argument("-o", "--output", type=output_file, default=Path("out/loadchart.png"),
                       metavar="FILE", help="the figure (.png, .svg, .pdf) or the poses (.json) "
                                            "(default: out/loadchart.png)")
    chart.add_argument("--points", type=positive_int, metavar="N",
                       help="grid points per joint (default: a grid of at most 20,000 poses)")
    chart.add_argument("--rating", type=float, metavar="PA",
                       help="a working pressure rating, Pa: every cylinder holds up to it "
                            "instead of its relief's setting")
    chart.add_argument("--safety", type=float, default=1.0, metavar="F",
                       help="a safety factor (>= 1) every holding range is divided by "
                            "(default: 1)")
    chart.add_argument("--stability", type=float, default=1.0, metavar="F",
                       help="a stability factor (>= 1) the payload at which the machine tips "
                            "is divided by (with a 'base' in the spec; default: 1)")
    chart.add_argument("--slope", type=float, default=0.0, metavar="DEG",
                       help="the ground's slope, degrees in [0, 90): gravity tilted towards the "
                            "base's +x for holding, structure and tipping (default: 0)")
    chart.set_defaults(func=_cmd_loadchart)


def _cmd_loadchart(args: argparse.Namespace) -> int:
    import numpy as np

    from maniplab.atomic import write_text
    from maniplab.loadchart import load_chart

    chart = load_chart(spec_with_sets(args), points=args.points, rating=args.rating,
                       safety=args.safety, stability=args.stability, slope=args.slope)
    if args.output.suffix.lower() == ".json":
        write_text(args.output, json.dumps(chart.to_dict(), indent=1) + "\n")
    else:
        from maniplab.viz.loadchart import load_chart_figure
        from maniplab.viz.plots import save_figure

        save_figure(load_chart_figure(chart), args.output)
    rated = chart.spec.end_effector.mass
    held = float(np.mean(chart.payload >= rated))
    k = int(np.argmin(chart.payload))
    print(f"wrote {args.output}: {chart.spec.name}, {len(chart.q)} poses; the rated payload "
          f"({rated:g} kg) is held at {held:.0%} of them; least {chart.payload[k]:.4g} kg at "
          f"reach {chart.reach[k]:.3g} m, height {chart.height[k]:.3g} m "
          f"(limited by {chart.describe(k) if chart.cause[k] else 'no joint'})")
    causes, counts = np.unique(chart.cause[chart.cause != ""], return_counts=True)
    if len(causes):
        print("limited by: " + ", ".join(f"{cause} at {count / len(chart.q):.0%}"
                                         for cause, count in zip(causes, counts))
              + f" of the poses ({chart.rule})")
    return 0
