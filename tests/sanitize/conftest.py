"""The fuzz targets of tests/sanitize/ run only in a sanitized process (``make sanitize``,
``python tests/sanitize/run.py``, or a ``fuzz_*.py`` run as a script): elsewhere they are skipped,
since without ASan and UBSan a memory error would pass unseen or crash the test run. The normal
``pytest`` run does not collect them (their files are not ``test_*.py``);
``tests/test_sanitize.py`` runs a short fuzz in a sanitized child process instead."""

from __future__ import annotations

import pytest
from sanitized import active


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if active():
        return
    skip = pytest.mark.skip(reason="needs the sanitized library: run make sanitize or "
                                   "python tests/sanitize/run.py")
    here = str(config.rootpath / "tests" / "sanitize")
    for item in items:
        if str(item.path).startswith(here):
            item.add_marker(skip)
