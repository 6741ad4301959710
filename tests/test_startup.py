"""Start-up stays fast (issue 36): `import maniplab`, `maniplab --version` and `--help` load none
of the heavy libraries; the public names load them when first used. Counted in modules, not
timed (benchmarks/bench_startup.py times it)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

HEAVY = ("mujoco", "scipy", "sympy", "symengine", "viser", "matplotlib", "control", "pydantic",
         "maniplab.sim", "maniplab.model", "maniplab.actuators")


def loaded_after(code: str) -> set[str]:
    """The modules a fresh interpreter has loaded after running ``code``."""
    probe = f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, timeout=120).stdout
    return set(json.loads(out.strip().splitlines()[-1]))


@pytest.mark.parametrize("code", [
    "import maniplab",
    "from maniplab.cli import build_parser; build_parser()",
    ("import contextlib, io\nfrom maniplab.cli import main\n"
    "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
    "    main(['--version'])"),
])
def test_start_up_loads_nothing_heavy(code: str) -> None:
    loaded = loaded_after(code)
    heavy = sorted(m for m in loaded if m.split(".")[0] in HEAVY or m in HEAVY
                   or any(m.startswith(h + ".") for h in HEAVY if "." in h))
    assert not heavy, heavy


def test_public_names_load_on_first_use() -> None:
    loaded = loaded_after("import maniplab as ml\nml.simulate\nml.Run\nml.__version__")
    assert {"mujoco", "maniplab.sim.simulate"} <= loaded
    assert "viser" not in loaded  # the GUI's library only for the GUI


def test_every_public_name_resolves() -> None:
    import maniplab as ml

    for name in ml.__all__:
        assert getattr(ml, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        ml.nothing  # noqa: B018
