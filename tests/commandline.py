"""Running the ``maniplab`` command inside the test process."""

from __future__ import annotations

import pytest

from maniplab.cli import main


def run_cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    """Run ``maniplab argv``: the exit status, stdout and stderr (argparse's refusals exit with
    SystemExit, turned into their status here)."""
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err
