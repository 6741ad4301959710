"""``maniplab control``: a point-to-point move under the cascade controller."""

from __future__ import annotations

import argparse
from pathlib import Path

from maniplab.cli.common import spec_argument


def add(sub: argparse._SubParsersAction) -> None:
    """Register the sub-command(s) of this module."""
    control = sub.add_parser(
        "control", help="run a point-to-point move under the cascade controller, print the table",
        description="Move the end-effector to TARGET with a minimum-jerk reference under the "
                    "feedback-linearised cascade controller (or the PID-only baseline), from "
                    "rest with the pressures holding the arm; print the tracking table as JSON "
                    "and write the run (.npz), the table (.json) and a plot (.png) to DIR.")
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
    control.add_argument("--settle", type=float, default=1.0, metavar="S",
                         help="time simulated after the move, s (default: 1)")
    control.add_argument("-o", "--output", type=Path, default=Path("out/control"), metavar="DIR",
                         help="folder for control.npz, control.json, control.png "
                              "(default: out/control)")
    control.set_defaults(func=_cmd_control)


def _cmd_control(args: argparse.Namespace) -> int:
    import json
    import sys

    import maniplab as ml
    from maniplab.atomic import write_text
    from maniplab.control.metrics import tracking_metrics
    from maniplab.control.point_to_point import ControlError, parse_numbers, plan_move
    from maniplab.viz.plots import save_figure
    from maniplab.viz.tracking import tracking_figure

    spec = ml.resolve_spec(args.spec)
    target = parse_numbers(args.target, "--target", (3, 6))
    start = parse_numbers(args.start, "--start", (spec.n,)) if args.start else None
    if not args.settle >= 0.0:
        raise ControlError(f"--settle must be >= 0 s, got {args.settle!r}")
    model = ml.AnalyticModel(spec)
    plan = plan_move(spec, target, start=start, duration=args.duration, model=model,
                     fit_mode=args.fit)
    move, task, q0 = plan.move, plan.task, plan.q_start
    note = plan.note()
    if note:
        print(f"maniplab control: {note}", file=sys.stderr)
    controller = ml.CascadeController(spec, move, mode=args.mode, task=task, model=model)
    label = f"{args.mode}, {task} task"
    run = ml.simulate(spec, controller=controller, duration=move.t0 + move.duration + args.settle,
                      initial={"q": q0, "dP": "gravity"}, label=label)
    metrics = tracking_metrics(run, move, label=label, model=model)
    table = json.dumps(metrics.to_dict(), indent=2)
    args.output.mkdir(parents=True, exist_ok=True)
    run.save(args.output / "control.npz")
    write_text(args.output / "control.json", table + "\n")
    save_figure(tracking_figure([run], move), args.output / "control.png")
    print(table)
    return 0
