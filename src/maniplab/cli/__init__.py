"""The ``maniplab`` command: one sub-command per job, each in the module named for it.

Bad input (a spec error, a malformed argument, an unreadable run file) prints one line on stderr
and exits with status 2; it never shows a traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence

from maniplab.cli import (
    control_command,
    demo_command,
    fmu_command,
    gui_command,
    identify_command,
    loadchart_command,
    optimize_command,
    render_command,
    sim_commands,
    spec_commands,
    tune_command,
)
from maniplab.cli.common import EXIT_BAD_INPUT, Parser
from maniplab_entry import EXIT_INTERRUPTED

__all__ = ["EXIT_BAD_INPUT", "EXIT_INTERRUPTED", "build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``maniplab`` command."""
    import maniplab

    parser = Parser(prog="maniplab", description=(
        "Design environment for serial (hydraulic) manipulators on MuJoCo. SPEC is a YAML spec "
        "file or a built-in spec name (erector, planar2, crane3)."))
    parser.add_argument("--version", action="version", version=f"maniplab {maniplab.__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    for module in (spec_commands, sim_commands, control_command, tune_command,
                   loadchart_command, identify_command, render_command, demo_command,
                   gui_command, fmu_command, optimize_command):
        module.add(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``maniplab`` console script; returns the exit status.

    Ctrl-C anywhere in a command (its workers, threads and child processes are stopped by the
    job itself) ends it with one line on stderr and status 130, as a shell reports a SIGINT.
    """
    os.environ.setdefault("MUJOCO_GL", "egl")
    args = argparse.Namespace(command=None)
    try:
        parser = build_parser()
        _, extra = parser.parse_known_args(argv, namespace=args)
        if args.command is None:
            if extra:
                parser.error(f"unrecognized arguments: {' '.join(extra)}")
            parser.print_help()
            return EXIT_BAD_INPUT
        if extra:  # argparse would blame the top-level parser; the sub-command's help is wanted
            _subparser(parser, args.command).error(f"unrecognized arguments: {' '.join(extra)}")
        return _run(args)
    except KeyboardInterrupt:
        print(f"maniplab {args.command or ''}".rstrip() + ": interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _run(args: argparse.Namespace) -> int:
    """Run the sub-command, maniplab's warnings shown as one line on stderr each."""
    import warnings

    def one_line(message, category, filename, lineno, file=None, line=None) -> None:
        if issubclass(category, UserWarning) and category.__module__.startswith("maniplab"):
            print(f"maniplab {args.command}: warning: {message}", file=sys.stderr)
        else:
            default(message, category, filename, lineno, file, line)

    with warnings.catch_warnings():  # maniplab's warnings as one line, like its errors
        default = warnings.showwarning
        warnings.showwarning = one_line
        return _call(args)


def _call(args: argparse.Namespace) -> int:
    """``args.func(args)``; bad input becomes one line on stderr and status 2."""
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


def _subparser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    """The parser of sub-command ``command``."""
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    sub: argparse.ArgumentParser = action.choices[command]
    return sub
