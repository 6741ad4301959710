"""OpenGL backends: which one MUJOCO_GL names, and the one-line advice when none starts."""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np
import pytest

import maniplab as ml
from maniplab.cli import main
from maniplab.sim.run import Run
from maniplab.viz import gl
from maniplab.viz.gl import RenderError


@pytest.mark.parametrize(("value", "name"), [("egl", "egl"), (" OSMesa ", "osmesa"),
                                             ("glfw", "glfw")])
def test_backend_follows_mujoco_gl_when_rendering_starts(monkeypatch: pytest.MonkeyPatch,
                                                         value: str, name: str) -> None:
    monkeypatch.setenv("MUJOCO_GL", value)
    assert gl.backend() == name


def test_an_unknown_backend_lists_the_valid_ones(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MUJOCO_GL", "vulkan")
    with pytest.raises(RenderError, match="MUJOCO_GL='vulkan' is not an OpenGL backend; expected "
                                          "one of egl, osmesa, glfw"):
        gl.backend()


def _broken_import(name: str) -> object:
    if name.startswith("mujoco."):
        raise ImportError("libEGL.so.1: cannot open shared object file:\nNo such file")
    return importlib.import_module(name)


def test_a_backend_that_cannot_start_says_what_to_install_or_set(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MUJOCO_GL", "egl")
    monkeypatch.setattr(gl, "import_module", _broken_import)
    with pytest.raises(RenderError) as info:
        gl.open_context(64, 64)
    message = str(info.value)
    assert "\n" not in message and "MUJOCO_GL=egl: libEGL.so.1: cannot open" in message
    for advice in ("apt install libegl1", "MUJOCO_GL=osmesa", "libosmesa6", "DISPLAY"):
        assert advice in message


def test_the_cli_prints_that_advice_in_one_line(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setenv("MUJOCO_GL", "egl")
    monkeypatch.setattr(gl, "import_module", _broken_import)
    path = tmp_path / "run.npz"
    t = np.linspace(0.0, 1.0, 11)
    Run(t=t, signals={"q": np.zeros((11, 2))}, spec=ml.builtin_spec("planar2")).save(path)
    assert main(["render", str(path), "-o", str(tmp_path / "a.mp4")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("maniplab render: cannot start OpenGL") and err.count("\n") == 1
    assert not (tmp_path / "a.mp4").exists()
