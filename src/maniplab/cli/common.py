"""Pieces shared by the sub-commands."""

from __future__ import annotations

import argparse
from typing import NoReturn

EXIT_BAD_INPUT = 2
"""Bad input: a spec error, a malformed argument, a refused request."""

EXIT_MISSED = 3
"""The job ran, but its result is wrong: a move that missed its tolerances, a run that failed
its health check."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage dump), exit status 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def spec_argument(parser: argparse.ArgumentParser) -> None:
    """The positional SPEC argument: a spec file or a built-in name."""
    parser.add_argument("spec", metavar="SPEC",
                        help="a spec file (YAML) or the name of a built-in spec "
                             "(see 'maniplab info --list')")
