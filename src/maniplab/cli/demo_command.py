"""``maniplab demo``: the main job on the built-in erector, ending in one report."""

from __future__ import annotations

import argparse
from pathlib import Path

from maniplab.cli.common import output_folder


def add(sub: argparse._SubParsersAction) -> None:
    """Register the demo sub-command."""
    demo = sub.add_parser(
        "demo", help="design and validate the built-in erector end to end, write a report",
        description="Export the erector's MJCF, generate and export its analytic model, run "
                    "open-loop responses for three payloads and two leakages, the closed-loop "
                    "move with the cascade controller and the PID baseline, cross-validate the "
                    "MuJoCo plant against the analytic model, render the videos and write "
                    "DIR/report.html.")
    demo.add_argument("-o", "--output", type=output_folder, default=Path("out/demo"), metavar="DIR",
                      help="folder for the results (default: out/demo)")
    demo.add_argument("--quick", action="store_true",
                      help="a short version (short runs, small videos), e.g. for tests")
    demo.set_defaults(func=_cmd_demo)


def _cmd_demo(args: argparse.Namespace) -> int:
    from maniplab.demo import Demo

    Demo(args.output, quick=args.quick).run()
    return 0
