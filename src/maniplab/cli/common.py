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


def positive_int(text: str) -> int:
    """argparse type: an integer of at least 1 (workers, counts)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is not at least 1")
    return value


def spec_argument(parser: argparse.ArgumentParser) -> None:
    """The positional SPEC argument: a spec file or a built-in name."""
    parser.add_argument("spec", metavar="SPEC",
                        help="a spec file (YAML) or the name of a built-in spec "
                             "(see 'maniplab info --list')")
