"""Pieces shared by the sub-commands."""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from maniplab.errors import ManiplabError

EXIT_BAD_INPUT = 2
"""Bad input: a spec error, a malformed argument, a refused request."""

EXIT_MISSED = 3
"""The job ran, but its result is wrong: a move that missed its tolerances, a run that failed
its health check."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage dump), exit status 2, and no abbreviated options
    (``--set`` must never be taken for ``--settle``)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

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


def positive_seconds(text: str) -> float:
    """argparse type: a finite time of more than 0 s (a recording interval, a step)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number of seconds") from None
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text}")
    return value


SAMPLE_DT_HELP = ("record one sample every S seconds (a multiple of the step; default: every "
                  "step, at most 1000 samples/s): a run stores samples × bytes per sample, so "
                  "a long run can record less")
"""The help of ``--sample-dt`` (every command that records a run has it)."""


def output_file(text: str) -> Path:
    """argparse type of -o FILE: refused at once when it names a device, fifo or folder (nothing
    is computed for an output that cannot be written)."""
    from maniplab.atomic import check_target

    try:
        check_target(text)
    except (ManiplabError, OSError) as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return Path(text)


def output_folder(text: str) -> Path:
    """argparse type of -o DIR: refused at once when it exists and is not a folder."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: exists and is not a folder")
    return path


def spec_argument(parser: argparse.ArgumentParser) -> None:
    """The positional SPEC argument: a spec file or a built-in name; and ``--plugin``."""
    parser.add_argument("spec", metavar="SPEC",
                        help="a spec file (YAML) or the name of a built-in spec "
                             "(see 'maniplab info --list')")
    plugin_option(parser)


def set_option(parser: argparse.ArgumentParser, help_text: str = "") -> None:
    """``--set PATH=VALUE``, repeatable: overrides of the spec (read by :func:`spec_with_sets`)."""
    parser.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                        help=help_text or "PATH=VALUE override of the spec, repeatable, e.g. "
                                          "end_effector.mass=4000")


def spec_with_sets(args: argparse.Namespace) -> Any:
    """The spec of ``args.spec`` with its ``--set`` overrides (a ManipulatorSpec)."""
    from maniplab.builtin import resolve_spec
    from maniplab.sim.grammar import parse_assignment

    spec = resolve_spec(args.spec)
    overrides = dict(parse_assignment(text) for text in args.set)
    return spec.with_overrides(overrides) if overrides else spec


def plugin_option(parser: argparse.ArgumentParser) -> None:
    """``--plugin MODULE`` (repeatable): import an actuator plugin module on purpose, so that a
    spec may name its classes as ``module:Class``; a spec alone never imports anything."""
    parser.add_argument("--plugin", action=_LoadPlugin, metavar="MODULE",
                        help="import this actuator plugin module, so that specs may name its "
                             "classes ('type: MODULE:Class'), repeatable; also "
                             "MANIPLAB_PLUGINS=MODULE,... (a spec never imports code itself)")


class _LoadPlugin(argparse.Action):
    """Imports the module as the option is parsed; a failure is a one-line usage error."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: str | Sequence[Any] | None, option_string: str | None = None) -> None:
        from maniplab.actuators.registry import PluginLookupError, load_plugins

        try:
            load_plugins(str(values))
        except PluginLookupError as exc:
            parser.error(f"{option_string}: {exc}")
        setattr(namespace, self.dest, [*(getattr(namespace, self.dest, None) or []), values])
