"""RunSet: listing, filtering by parameter, lazy loading, the table of differing parameters."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import maniplab as ml
from maniplab.sim import Run, store
from maniplab.sim.params import differing, labels
from maniplab.sim.runset import Failure, RunSet


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    base = ml.builtin_spec("erector")
    t = np.linspace(0.0, 1.0, 5)
    for mass in (3000.0, 5000.0):
        for leakage in (1e-12, 1e-11):
            spec = base.with_overrides({"end_effector.mass": mass,
                                        "joints.q2.actuator.leakage": leakage})
            Run(t, {"q": np.zeros((5, 6))}, spec).save(tmp_path / f"m{mass:g}_l{leakage:g}.npz")
    (tmp_path / "notes.txt").write_text("not a run")
    return tmp_path


def test_lists_the_runs_of_a_folder(folder: Path) -> None:
    runs = RunSet(folder)
    assert len(runs) == 4
    assert runs.differing() == ["joints.q2.actuator.leakage", "end_effector.mass"]


def test_filter_by_parameter(folder: Path) -> None:
    runs = RunSet(folder)
    heavy = runs.filter(end_effector__mass=5000.0)
    assert sorted(p.name for p in heavy.paths) == ["m5000_l1e-11.npz", "m5000_l1e-12.npz"]
    leaky = runs.filter(lambda p: p["joints.q2.actuator.leakage"] > 5e-12)
    assert all(r.spec.joint("q2").actuator.leakage == 1e-11 for r in leaky)
    assert len(runs.filter(end_effector__mass=1.0)) == 0


def test_listing_reads_headers_only(folder: Path, monkeypatch) -> None:
    loads = []
    real = store.load
    monkeypatch.setattr(store, "load", lambda path, cls: loads.append(path) or real(path, cls))
    runs = RunSet(folder)
    runs.table()
    runs.filter(end_effector__mass=3000.0)
    assert loads == []
    assert runs[1].spec.end_effector.mass in (3000.0, 5000.0)
    assert len(loads) == 1


def test_table_names_the_differing_parameters_and_failures(folder: Path) -> None:
    failure = Failure({"end_effector.mass": 9e9}, "unstable at t=0.01 s")
    table = RunSet(sorted(folder.glob("*.npz")), failures=[failure]).table().splitlines()
    assert table[0].split() == ["file", "q2", "leakage", "payload"]
    assert table[2].split() == ["m3000_l1e-11.npz", "1e-11", "3000"]
    assert table[-1] == "FAILED payload=9e+09: unstable at t=0.01 s"


def test_labels_name_only_what_differs() -> None:
    sets = [{"a": 1.0, "b": 2.0}, {"a": 1.0, "b": 3.0}]
    assert differing(sets) == ["b"]
    assert labels(sets) == ["b=2", "b=3"]
    assert labels([{"a": 1.0}, {"a": 1.0}], ["x", "y"]) == ["x", "y"]
