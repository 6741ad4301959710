"""``maniplab demo``: the main job on the built-in erector."""

from __future__ import annotations

import argparse
from pathlib import Path


def add(sub: argparse._SubParsersAction) -> None:
    """Register the sub-command(s) of this module."""
    demo = sub.add_parser("demo", help="run the main job on the built-in erector",
                          description="Export the erector's MJCF and print its summary.")
    demo.add_argument("-o", "--output", type=Path, default=Path("out/demo"), metavar="DIR",
                      help="folder for the results (default: out/demo)")
    demo.set_defaults(func=_cmd_demo)


def _cmd_demo(args: argparse.Namespace) -> int:
    import maniplab as ml
    from maniplab.summary import spec_table

    spec = ml.builtin_spec("erector")
    path = args.output / "erector.xml"
    ml.mjcf_gen.write_mjcf(spec, path)
    print(spec_table(spec))
    print(f"\nMJCF model: {path}  (open it with: python -m mujoco.viewer --mjcf={path})")
    return 0
