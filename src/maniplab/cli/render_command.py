"""``maniplab render``: videos of stored runs."""

from __future__ import annotations

import argparse
from pathlib import Path

from maniplab.cli.common import output_file, plugin_option


def add(sub: argparse._SubParsersAction) -> None:
    """Register the sub-command(s) of this module."""
    render = sub.add_parser(
        "render", help="render runs to a video (MP4 or GIF), alone, in a grid or overlaid",
        description="Render stored runs (.npz) offscreen into a video: one run, or several side "
                    "by side (--grid) or in one scene as ghosts (--overlay), captioned with the "
                    "parameters that differ. Needs no display: MUJOCO_GL defaults to egl.")
    render.add_argument("runs", metavar="RUN", nargs="+", type=Path,
                        help="run files written by Run.save (.npz)")
    plugin_option(render)
    render.add_argument("-o", "--output", type=output_file, metavar="FILE",
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
    render.add_argument("--cols", type=int,
                        help="tiles per row with --grid (default: the arms shown largest)")
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
               "trace": args.trace, "text": args.text, "plot": args.plot}
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
