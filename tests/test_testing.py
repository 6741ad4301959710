"""maniplab.testing: the assertions, the fixtures as a pytest plugin, and the Monte-Carlo study."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest
import scipy.stats

import maniplab as ml
from maniplab.control.move import run_move
from maniplab.testing import assert_healthy, assert_tracks, monte_carlo, tracking_errors

CRANE = {"target": [5.46, 0.6, 1.4], "start": [0.0, 0.0, 0.5], "duration": 3.0, "settle": 0.3}


@pytest.fixture(scope="module")
def moves() -> dict[str, ml.control.MoveResult]:
    spec = ml.builtin_spec("crane3")
    return {mode: run_move(spec, mode=mode, **CRANE) for mode in ("cascade", "pid")}


def test_assert_tracks_agrees_with_the_metrics(moves) -> None:
    for result in moves.values():
        final, rms = tracking_errors(result.run)
        assert final == pytest.approx(result.metrics.final_error_mm, rel=1e-9)
        assert rms == pytest.approx(result.metrics.rms_error_mm, rel=1e-9)
    assert_tracks(moves["cascade"].run)
    assert_healthy(moves["cascade"].run, warnings=False)
    with pytest.raises(AssertionError, match=r"final error .* mm > 2 mm"):
        assert_tracks(moves["pid"].run)
    with pytest.raises(AssertionError, match="health failed: .*tracking|final position error"):
        assert_healthy(moves["pid"].run)


def test_a_run_without_a_reference_cannot_be_judged() -> None:
    run = ml.simulate("planar2", duration=0.05)
    with pytest.raises(AssertionError, match="no reference"):
        assert_tracks(run)


def test_monte_carlo_is_reproducible_and_each_sample_is_its_run_alone() -> None:
    payload = scipy.stats.uniform(80.0, 40.0)  # the nominal 100 kg ± 20 %
    study = monte_carlo("crane3", {"end_effector.mass": payload}, samples=3, seed=4, **CRANE)
    again = monte_carlo("crane3", {"end_effector.mass": payload}, samples=3, seed=4, **CRANE)
    assert study == again
    masses = [p["end_effector.mass"] for p in study.parameters]
    assert len(set(masses)) == 3 and all(80.0 <= m <= 120.0 for m in masses)
    spec = ml.builtin_spec("crane3")
    alone = run_move(spec, plant=spec.with_overrides({"end_effector.mass": masses[1]}),
                     sample_dt=0.01, **CRANE)
    assert study.results[1]["final_mm"] == alone.metrics.final_error_mm
    spread = study.spread()
    finals = [r["final_mm"] for r in study.results]
    assert spread["final_mm"]["max"] == max(finals) and spread["final_mm"]["min"] == min(finals)
    failed = sum(r["verdict"] == "failed" for r in study.results)
    assert "| final_mm |" in study.table() and f"3 samples, {failed} failed" in study.table()


def test_a_drawn_value_the_spec_refuses_is_one_line() -> None:
    with pytest.raises(ml.ManiplabError, match="refused"):
        monte_carlo("crane3", {"end_effector.mass": lambda rng: -1.0}, samples=1, **CRANE)


def test_the_fixtures_work_as_a_pytest_plugin(tmp_path) -> None:
    (tmp_path / "conftest.py").write_text('pytest_plugins = ["maniplab.testing"]\n')
    (tmp_path / "test_arms.py").write_text(textwrap.dedent("""
        def test_every_builtin_arm_has_joints(builtin_arm, move_runner):
            assert builtin_arm.n >= 2 and callable(move_runner)
    """))
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           str(tmp_path)], capture_output=True, text=True, timeout=300,
                          check=False, cwd=tmp_path)
    assert done.returncode == 0, done.stdout[-2000:]
    assert f"{len(ml.builtin_specs())} passed" in done.stdout
    assert np.all([len(ml.builtin_specs()) >= 6])
