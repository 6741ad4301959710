"""Test-suite settings: on CI (CI=true) hypothesis draws a fixed sequence of examples, so a run
there is reproducible; locally it keeps exploring new ones."""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

# The tests' actuator plugins (tests/plugins), named on purpose as a user names theirs: a spec
# alone never imports a module. The environment also reaches the CLI's and sweeps' child processes.
os.environ.setdefault("MANIPLAB_PLUGINS", "plugins.dcmotor")
