"""``maniplab control``: a point-to-point move under the cascade controller."""

from __future__ import annotations

import argparse
from pathlib import Path

from maniplab.cli.common import (
    EXIT_MISSED,
    SAMPLE_DT_HELP,
    output_folder,
    positive_seconds,
    set_option,
    spec_argument,
    spec_with_sets,
)


def add(sub: argparse._SubParsersAction) -> None:
    """Register the sub-command(s) of this module."""
    control = sub.add_parser(
        "control", help="run a point-to-point move under the cascade controller, print the table",
        description="Move the end-effector to TARGET with a minimum-jerk reference under the "
                    "feedback-linearised cascade controller (or the PID-only baseline), from "
                    "rest with the pressures holding the arm (on an arm whose tool hangs on "
                    "passive joints: the point it hangs from, the tool hanging at rest at the "
                    "start, its sway after the move in the table); print the tracking table as "
                    "JSON "
                    "and write the run (.npz), the table (.json) and a plot (.png) to DIR. "
                    "The controller's gains and rate not given in the spec's control: section "
                    "are derived from the arm (see 'maniplab tune').",
        epilog="Exit status: 0 the move met its tolerances and the run is healthy; 2 bad input, "
               "or a move refused (a target out of reach, a path leaving the workspace, a move "
               "too fast with --fit refuse); 3 the move missed its tolerances or the run failed "
               "its health check (one line on stderr names the joint, the cause and the setting "
               "to change).")
    spec_argument(control)
    control.add_argument("--target", required=True, metavar="X,Y,Z[,ROLL,PITCH,YAW]",
                         help="end-effector position, m, base axes; with roll,pitch,yaw (rad, "
                              "R = Rz Ry Rx) the orientation is controlled too")
    control.add_argument("--duration", required=True, type=float, metavar="T",
                         help="duration of the move, s (the run adds 0.5 s before, --settle after)")
    control.add_argument("--fit", choices=("stretch", "refuse"), default="stretch",
                         help="a move faster than the actuators can deliver (each joint's command "
                              "within 80 %% of its limit along the path, e.g. a valve's flow at "
                              "the load there): stretch it to the shortest duration that works "
                              "and say so (default), or refuse it naming the duration that works")
    control.add_argument("--start", metavar="Q1,Q2,...",
                         help="initial joint positions, rad or m (default: all 0, within limits); "
                              "write --start=-0.2,... when the first value is negative")
    control.add_argument("--mode", choices=("cascade", "pid"), default="cascade",
                         help="cascade (feedback linearisation, default) or pid (PID only)")
    control.add_argument("--controller", metavar="MODULE:NAME",
                         help="your own controller instead of --mode: a factory NAME(spec, move) "
                              "-> controller in an importable MODULE or in a FILE.py you name "
                              "(see 'Validate your own controller' in the docs)")
    control.add_argument("--sway-damping", action="store_true",
                         help="on an arm whose tool hangs on passive joints: shape the move (a "
                              "ZVD input shaper at the tool's pendulum frequency) so that the "
                              "tool is left without residual sway; the move is one pendulum "
                              "period longer")
    control.add_argument("--settle", type=float, default=1.0, metavar="S",
                         help="time simulated after the move, s (default: 1)")
    control.add_argument("--sample-dt", type=positive_seconds, metavar="S", help=SAMPLE_DT_HELP)
    control.add_argument("--tolerance", default="2,5", metavar="FINAL,RMS",
                         help="the move's tolerances, mm: the final position error and the RMS "
                              "error over the move (default: 2,5)")
    control.add_argument("-o", "--output", type=output_folder, default=Path("out/control"), metavar="DIR",
                         help="folder for control.npz, control.json, control.png "
                              "(default: out/control)")
    set_option(control, "PATH=VALUE override of the spec, repeatable, e.g. "
                        "control.pid_only.kp=0.5 or end_effector.mass=4000")
    control.set_defaults(func=_cmd_control)


def _cmd_control(args: argparse.Namespace) -> int:
    import json
    import sys

    from maniplab.atomic import write_text
    from maniplab.control.loading import load_factory
    from maniplab.control.move import run_move
    from maniplab.control.point_to_point import ControlError, parse_numbers
    from maniplab.viz.plots import save_figure
    from maniplab.viz.tracking import tracking_figure

    spec = spec_with_sets(args)
    target = parse_numbers(args.target, "--target", (3, 6))
    final, rms = parse_numbers(args.tolerance, "--tolerance", (2,))
    start = parse_numbers(args.start, "--start", (spec.n,)) if args.start else None
    if not args.settle >= 0.0:
        raise ControlError(f"--settle must be >= 0 s, got {args.settle!r}")
    factory = load_factory(args.controller) if args.controller else None
    result = run_move(spec, target, start=start, duration=args.duration, mode=args.mode,
                      fit_mode=args.fit, settle=args.settle, sample_dt=args.sample_dt,
                      controller=factory, tolerances=(final, rms),
                      sway_damping=args.sway_damping)
    note = result.plan.note()
    if note:
        print(f"maniplab control: {note}", file=sys.stderr)
    health = result.health
    sway = {"sway": [s.to_dict() for s in result.sway]} if result.sway else {}
    table = json.dumps({**result.metrics.to_dict(), **sway, "health": health.to_dict()}, indent=2)
    args.output.mkdir(parents=True, exist_ok=True)
    result.run.save(args.output / "control.npz")
    write_text(args.output / "control.json", table + "\n")
    save_figure(tracking_figure([result.run], result.plan.move), args.output / "control.png")
    print(table)
    for line in health.lines():
        print(f"maniplab control: {line}", file=sys.stderr)
    missed = result.missed(final, rms)
    if missed:
        print(f"maniplab control: {missed}", file=sys.stderr)
        return EXIT_MISSED
    return 0
