"""The ``maniplab`` console script's entry point, kept outside the maniplab package.

Importing maniplab takes a moment, and on first use much longer: ``import mujoco`` then builds
maniplab's native plugins. A Ctrl-C in that window would end in a traceback if the entry point
were inside the package being imported; from here it is answered as during a command: one line,
status 130.
"""

from __future__ import annotations

import sys

EXIT_INTERRUPTED = 130
"""Status of a job ended by Ctrl-C (as a shell reports a SIGINT)."""


def main() -> int:
    """Import the command line and run it; Ctrl-C while importing is one line, status 130."""
    try:
        from maniplab.cli import main as run
    except KeyboardInterrupt:
        print("maniplab: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return run()
