"""MkDocs hook: the command-line reference page, generated at build time from maniplab's parsers.

The page ``reference/cli.md`` is the ``--help`` text of ``maniplab`` and of each of its
sub-commands, as ``maniplab.cli.build_parser()`` formats it (``format_help()``): it cannot drift
from the code, and nothing is copied by hand.
"""

from __future__ import annotations

import argparse
import os

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.structure.files import File, Files

PAGE = "reference/cli.md"
WIDTH = "82"  # columns argparse wraps the help text to (the width of a page), whatever the terminal


def _subparsers(parser: argparse.ArgumentParser) -> argparse._SubParsersAction:
    for action in parser._actions:  # argparse keeps its sub-parsers only here
        if isinstance(action, argparse._SubParsersAction):
            return action
    raise LookupError("the maniplab parser has no sub-commands")


def _help(parser: argparse.ArgumentParser) -> str:
    saved = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = WIDTH
    try:
        return parser.format_help().rstrip()
    finally:
        if saved is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = saved


def cli_reference() -> str:
    """The Markdown of the command-line reference."""
    from maniplab.cli import build_parser

    parser = build_parser()
    action = _subparsers(parser)
    subs = dict(action.choices)
    summary = {choice.dest: choice.help or "" for choice in action._choices_actions}
    lines = [
        "# Command line",
        "",
        ("The help of the `maniplab` command and of each of its sub-commands, as `--help` prints "
         "it. This page is generated when the site is built, from the parsers in `maniplab.cli`."),
        "",
        ("Every command accepts a spec file or a built-in name (`erector`, `planar2`, `crane3`) "
         "wherever it takes SPEC, and answers bad input with one line on stderr and exit status 2 "
         "(never a traceback). The [user guide](../guide/spec.md) explains what the commands do."),
        "",
        "| command | what it does |",
        "|---|---|",
        *(f"| [`maniplab {name}`](#maniplab-{name}) | {summary.get(name, '')} |" for name in subs),
        "",
        "## `maniplab`",
        "",
        "```text",
        _help(parser),
        "```",
        "",
    ]
    for name, sub in subs.items():
        lines += [f"## `maniplab {name}` {{#maniplab-{name}}}", "", "```text", _help(sub), "```", ""]
    return "\n".join(lines)


def on_files(files: Files, config: MkDocsConfig) -> Files:
    """Add the generated page to the site's files."""
    files.append(File.generated(config, PAGE, content=cli_reference()))
    return files
