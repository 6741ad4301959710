"""Test-suite settings.

Hypothesis draws a fixed sequence of examples by default (profile ``fixed``: derandomized, no
example database), so ``make test``, a fresh clone and CI run the same property tests and a
failure reproduces anywhere. ``MANIPLAB_HYPOTHESIS=explore`` asks for new random examples each
run (hypothesis's default profile, with its database under ``.hypothesis/``), to hunt for
failures; keep one that turns up as an explicit ``@example``."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest
from hypothesis import settings

settings.register_profile("fixed", derandomize=True, database=None, print_blob=True)
settings.register_profile("ci", parent=settings.get_profile("fixed"))  # the former CI profile
settings.register_profile("explore", print_blob=True)
settings.load_profile("explore" if os.environ.get("MANIPLAB_HYPOTHESIS") == "explore"
                      else "fixed")

# The tests' actuator plugins (tests/plugins), named on purpose as a user names theirs: a spec
# alone never imports a module. The environment also reaches the CLI's and sweeps' child processes.
os.environ.setdefault("MANIPLAB_PLUGINS", "plugins.dcmotor")


# A skipped test hides whatever it would have found: under the suite's own settings a skip is a
# failure (the GL backend, the C compiler, the ASan runtime are all installed by `make test` or
# the machine). MANIPLAB_ALLOW_SKIPS=1 lets a machine without them run the rest.
_STRICT_SKIPS = os.environ.get("MANIPLAB_ALLOW_SKIPS") != "1"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]):  # type: ignore[no-untyped-def]
    outcome = yield
    report = outcome.get_result()
    if _STRICT_SKIPS and report.skipped and not hasattr(report, "wasxfail"):
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else report.longrepr
        report.outcome = "failed"
        report.longrepr = (f"skipped, which the suite does not allow ({reason}); install what it "
                           "needs, or set MANIPLAB_ALLOW_SKIPS=1 to run without it")


@pytest.fixture(scope="module")
def offscreen_gl() -> Iterator[None]:
    """Offscreen rendering for a video test module: MUJOCO_GL as the user set it, else egl (as the
    CLI does). A machine where no backend starts skips the module, which the suite counts as a
    failure unless MANIPLAB_ALLOW_SKIPS=1 (above): `make test` installs Mesa's EGL."""
    from maniplab.viz.gl import RenderError, open_context

    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MUJOCO_GL", os.environ.get("MUJOCO_GL") or "egl")
        try:
            open_context(16, 16).free()
        except RenderError as exc:
            pytest.skip(f"no OpenGL backend: {exc}")
        yield


# The slowest tests first (the identification fits, the sanitizer fuzz, the hostile inputs: each
# 15 to 85 s): pytest-xdist deals the first tests out to the workers in turn and the rest as they
# free up, so a long test never starts last while the other worker sits idle. Order within each
# group is kept (a stable sort).
_SLOW_FIRST = ("tests/test_identify.py::", "tests/test_sanitize.py::",
               "tests/test_hostile_inputs.py::", "tests/test_rod_friction.py::",
               "tests/test_identify_suggest.py::", "tests/test_identify_intervals.py::")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    items.sort(key=lambda item: not item.nodeid.startswith(_SLOW_FIRST))
