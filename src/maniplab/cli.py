"""The ``maniplab`` command: one sub-command per job.

Bad input (a spec error, a malformed argument) prints one line on stderr and exits with status 2;
it never shows a traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

EXIT_BAD_INPUT = 2


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage dump), exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def _spec_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("spec", metavar="SPEC",
                        help="a spec file (YAML) or the name of a built-in spec (see 'maniplab info --list')")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``maniplab`` command."""
    from maniplab import __version__

    parser = _Parser(prog="maniplab", description=(
        "Design environment for serial (hydraulic) manipulators on MuJoCo. SPEC is a YAML spec "
        "file or a built-in spec name (erector, planar2, crane3)."))
    parser.add_argument("--version", action="version", version=f"maniplab {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    info = sub.add_parser("info", help="print a table of the arm's joints, bodies, actuators, limits",
                          description="Print a table of joints, bodies, masses, actuators and limits.")
    info.add_argument("spec", metavar="SPEC", nargs="?", help="a spec file or built-in name")
    info.add_argument("--list", action="store_true", help="list the built-in specs")
    info.set_defaults(func=_cmd_info)

    export = sub.add_parser("export", help="write the arm's MJCF model",
                            description="Write the MuJoCo model (MJCF, full float precision).")
    _spec_argument(export)
    export.add_argument("-o", "--output", required=True, type=Path, metavar="FILE",
                        help="the MJCF file to write (e.g. arm.xml)")
    export.set_defaults(func=_cmd_export)

    validate = sub.add_parser("validate", help="check a spec and that MuJoCo can build it",
                              description="Validate a spec file and compile its MuJoCo model.")
    _spec_argument(validate)
    validate.set_defaults(func=_cmd_validate)

    demo = sub.add_parser("demo", help="run the main job on the built-in erector",
                          description="Export the erector's MJCF and print its summary.")
    demo.add_argument("-o", "--output", type=Path, default=Path("out/demo"), metavar="DIR",
                      help="folder for the results (default: out/demo)")
    demo.set_defaults(func=_cmd_demo)

    model = sub.add_parser(
        "model", help="write the arm's analytic model (LaTeX, Markdown, Python or C)",
        description="Write the analytic model M, C, G, Fv: readable (latex, markdown: parameters as "
                    "symbols, cse form for large arms) or as code to drop into another project "
                    "(python: math and numpy only; c: math.h only).")
    _spec_argument(model)
    model.add_argument("-f", "--format", choices=("latex", "markdown", "python", "c"),
                       help="output format (default: from the file's suffix .tex, .md, .py, .c)")
    model.add_argument("-o", "--output", required=True, type=Path, metavar="FILE",
                       help="the file to write")
    model.add_argument("--symbolic", default="mass,length,payload", metavar="GROUPS",
                       help="parameter groups kept as symbols in latex/markdown, comma-separated, "
                            "from mass, length, com, inertia, payload, offset, gravity, friction; "
                            "'' for none (default: mass,length,payload)")
    model.set_defaults(func=_cmd_model)

    render = sub.add_parser(
        "render", help="render runs to a video (MP4 or GIF), alone, in a grid or overlaid",
        description="Render stored runs (.npz) offscreen into a video: one run, or several side "
                    "by side (--grid) or in one scene as ghosts (--overlay), captioned with the "
                    "parameters that differ. Needs no display: MUJOCO_GL defaults to egl.")
    render.add_argument("runs", metavar="RUN", nargs="+", type=Path,
                        help="run files written by Run.save (.npz)")
    render.add_argument("-o", "--output", type=Path, metavar="FILE",
                        help="the video to write, .mp4 (H.264) or .gif (default: out/<run>.mp4, "
                             "out/grid.mp4 or out/overlay.mp4)")
    layout = render.add_mutually_exclusive_group()
    layout.add_argument("--grid", action="store_true", help="one tile per run, side by side")
    layout.add_argument("--overlay", action="store_true",
                        help="all runs in one scene, the first solid, the others as ghosts")
    render.add_argument("--width", type=int, default=1280, help="pixels (default: 1280)")
    render.add_argument("--height", type=int, default=720, help="pixels (default: 720)")
    render.add_argument("--fps", type=float, default=30.0, help="frames per second (default: 30)")
    render.add_argument("--camera", default="auto",
                        help="auto (frames the whole motion; default), track (follows the arm) "
                             "or overview (fixed)")
    render.add_argument("--cols", type=int, help="tiles per row with --grid (default: largest tiles)")
    render.add_argument("--plot", metavar="SIGNAL[:COLUMN]",
                        help="a strip of one signal under the animation, e.g. q:q2, dP:q1, ee_pos:z")
    render.add_argument("--shadows", action="store_true", help="draw shadows (about 2x slower)")
    render.add_argument("--no-antialias", dest="antialias", action="store_false",
                        help="no multisampling: jagged edges, about 2x faster")
    render.add_argument("--no-trace", dest="trace", action="store_false",
                        help="do not trace the end-effector's path")
    render.add_argument("--no-text", dest="text", action="store_false",
                        help="no time stamp and no key to the joint-state colours")
    render.set_defaults(func=_cmd_render)

    control = sub.add_parser(
        "control", help="run a point-to-point move under the cascade controller, print the table",
        description="Move the end-effector to TARGET with a minimum-jerk reference under the "
                    "feedback-linearised cascade controller (or the PID-only baseline), from "
                    "rest with the pressures holding the arm; print the tracking table as JSON "
                    "and write the run (.npz), the table (.json) and a plot (.png) to DIR.")
    _spec_argument(control)
    control.add_argument("--target", required=True, metavar="X,Y,Z[,ROLL,PITCH,YAW]",
                         help="end-effector position, m, base axes; with roll,pitch,yaw (rad, "
                              "R = Rz Ry Rx) the orientation is controlled too")
    control.add_argument("--duration", required=True, type=float, metavar="T",
                         help="duration of the move, s (the run adds 0.5 s before, --settle after)")
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
    return parser


def _cmd_info(args: argparse.Namespace) -> int:
    import maniplab as ml
    from maniplab.summary import spec_table

    if args.list or args.spec is None:
        print("built-in specs: " + ", ".join(ml.builtin_specs()))
        return 0
    print(spec_table(ml.resolve_spec(args.spec)))
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    import maniplab as ml

    spec = ml.resolve_spec(args.spec)
    ml.mjcf_gen.write_mjcf(spec, args.output)
    print(f"wrote {args.output} ({spec.name}, {spec.n} joints)")
    return 0


def _cmd_validate(args: argparse.Namespace) -> int:
    import maniplab as ml

    spec = ml.resolve_spec(args.spec)
    model = ml.build_model(spec)
    print(f"ok: {spec.name} is valid ({spec.n} joints, {model.nbody - 1} bodies, "
          f"{model.nu} actuators)")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    import maniplab as ml
    from maniplab.summary import spec_table

    spec = ml.builtin_spec("erector")
    path = args.output / "erector.xml"
    ml.mjcf_gen.write_mjcf(spec, path)
    print(spec_table(spec))
    print(f"\nMJCF model: {path}  (open it with: python -m mujoco.viewer --mjcf={path})")
    return 0


def _cmd_model(args: argparse.Namespace) -> int:
    import maniplab as ml
    from maniplab.model.export import SUFFIXES, export_model
    from maniplab.model.parameters import GROUPS

    fmt = args.format or SUFFIXES.get(args.output.suffix.lower())
    if fmt is None:
        raise ml.ManiplabError(f"cannot tell the format from '{args.output.name}'; give --format "
                               "(latex, markdown, python or c) or a .tex, .md, .py or .c file")
    symbolic = [g.strip() for g in args.symbolic.split(",") if g.strip()]
    unknown = [g for g in symbolic if g not in GROUPS]
    if unknown:
        raise ml.ManiplabError(f"unknown parameter group '{unknown[0]}' in --symbolic; expected "
                               f"some of {', '.join(GROUPS)}")
    spec = ml.resolve_spec(args.spec)
    text = export_model(spec, fmt, symbolic)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.output.with_name(f".{args.output.name}.tmp-{os.getpid()}")
    tmp.write_text(text)
    os.replace(tmp, args.output)
    print(f"wrote {args.output} ({spec.name}, {spec.n} joints, {fmt})")
    return 0


def _cmd_render(args: argparse.Namespace) -> int:
    import maniplab as ml
    from maniplab import viz
    from maniplab.sim import Run
    from maniplab.viz.video import check_format

    if len(args.runs) > 1 and not (args.grid or args.overlay):
        raise ml.ManiplabError(f"{len(args.runs)} runs given; add --grid or --overlay to compare "
                               "them, or give one run")
    kind = "grid" if args.grid else "overlay" if args.overlay else None
    output = args.output or Path("out") / f"{kind or args.runs[0].stem}.mp4"
    check_format(output, args.width, args.height)
    runs = [Run.load(path) for path in args.runs]
    options = {"width": args.width, "height": args.height, "fps": args.fps,
               "camera": args.camera, "shadows": args.shadows, "antialias": args.antialias,
               "trace": args.trace,
               "text": args.text, "plot": args.plot}
    if kind == "grid":
        frames = viz.iter_grid(runs, cols=args.cols, **options)
    elif kind == "overlay":
        frames = viz.iter_overlay(runs, **options)
    else:
        frames = viz.iter_frames(runs[0], **options)
    count = len(frames)
    ml.write_video(frames, output, fps=args.fps)
    print(f"wrote {output} ({count} frames, {args.width}x{args.height}, {args.fps:g} fps, "
          f"{len(runs)} run{'s' if len(runs) > 1 else ''})")
    return 0


def _cmd_control(args: argparse.Namespace) -> int:
    import json

    import maniplab as ml
    from maniplab.control.metrics import tracking_metrics
    from maniplab.control.plots import save_figure, tracking_figure
    from maniplab.control.point_to_point import ControlError, parse_numbers, plan_move
    from maniplab.specfile import write_atomic

    spec = ml.resolve_spec(args.spec)
    target = parse_numbers(args.target, "--target", (3, 6))
    start = parse_numbers(args.start, "--start", (spec.n,)) if args.start else None
    if not args.settle >= 0.0:
        raise ControlError(f"--settle must be >= 0 s, got {args.settle!r}")
    model = ml.AnalyticModel(spec)
    move, task, q0 = plan_move(spec, target, start=start, duration=args.duration, model=model)
    controller = ml.CascadeController(spec, move, mode=args.mode, task=task, model=model)
    label = f"{args.mode}, {task} task"
    run = ml.simulate(spec, controller=controller, duration=move.t0 + move.duration + args.settle,
                      initial={"q": q0, "dP": "gravity"}, label=label)
    run = controller.annotate(run)
    metrics = tracking_metrics(run, move, label=label, model=model)
    table = json.dumps(metrics.to_dict(), indent=2)
    args.output.mkdir(parents=True, exist_ok=True)
    run.save(args.output / "control.npz")
    write_atomic(args.output / "control.json", table + "\n")
    save_figure(tracking_figure([run], move), args.output / "control.png")
    print(table)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``maniplab`` console script; returns the exit status."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return EXIT_BAD_INPUT
    from maniplab.errors import ManiplabError

    try:
        return args.func(args)
    except ManiplabError as exc:
        print(f"maniplab {args.command}: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:
        print(f"maniplab {args.command}: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "),
              file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"maniplab {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
