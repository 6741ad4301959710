"""Sweeps: the erector's payload x leakage grid behaves as physics says; failures are reported;
the same call runs on a Dask cluster."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import maniplab as ml
from maniplab.sim.runset import RunSet
from maniplab.sim.sweep import sweep, variants

PAYLOADS = [3000.0, 4000.0, 5000.0]
LEAKAGES = [1e-12, 1e-11]
GRID = {"end_effector.mass": PAYLOADS, "joints.q2.actuator.leakage": LEAKAGES}


@pytest.fixture(scope="module")
def grid_runs(tmp_path_factory: pytest.TempPathFactory) -> RunSet:
    """q2's valve opened to a constant 0.2 A at 0.1 s, pressures balanced against gravity at 0."""
    return sweep("erector", GRID, out=tmp_path_factory.mktemp("sweep"), duration=3.0,
                 inputs={"q2": ml.signals.step(0.2, t0=0.1)}, initial={"dP": "gravity"},
                 processes=2)


def by_params(runs: RunSet) -> dict[tuple[float, float], ml.Run]:
    return {(r.spec.end_effector.mass, r.spec.joint("q2").actuator.leakage): r for r in runs}


def mean_frequency(t: np.ndarray, x: np.ndarray) -> float:
    """Mean frequency (Hz) of the oscillation in x, the centroid of its power spectrum between
    1 and 20 Hz (the hydraulic oil-spring modes, not the drift), after removing a linear trend.

    The ringing after the valve opens is a few decaying modes mixed with stick-slip, so its
    strongest single frequency jumps between them; the centroid follows the payload smoothly.
    """
    x = (x - np.polyval(np.polyfit(t, x, 1), t)) * np.hanning(len(x))
    pad = 16 * len(x)  # zero padding: 1/16 of the raw FFT bin
    power = np.abs(np.fft.rfft(x, pad)) ** 2
    freqs = np.fft.rfftfreq(pad, t[1] - t[0])
    band = (freqs > 1.0) & (freqs < 20.0)
    return float(np.sum(freqs[band] * power[band]) / np.sum(power[band]))


def test_grid_gives_every_variant(grid_runs: RunSet) -> None:
    assert len(grid_runs) == 6 and not grid_runs.failures
    assert sorted(by_params(grid_runs)) == [(m, le) for m in PAYLOADS for le in LEAKAGES]
    assert grid_runs.differing() == ["joints.q2.actuator.leakage", "end_effector.mass"]


def test_heavier_payload_needs_more_pressure_and_oscillates_slower(grid_runs: RunSet) -> None:
    runs = by_params(grid_runs)
    for leakage in LEAKAGES:
        moving = [runs[(m, leakage)] for m in PAYLOADS]
        pressure = [np.mean(r["dP"][r.t > 0.1, 1]) for r in moving]
        ringing = [(r.t > 0.1) & (r.t <= 1.0) for r in moving]  # after the valve opens
        frequency = [mean_frequency(r.t[w], r["dP"][w, 1]) for r, w in zip(moving, ringing)]
        assert pressure[0] < pressure[1] < pressure[2], pressure
        assert frequency[0] > frequency[1] > frequency[2], frequency


def test_more_leakage_leaves_a_larger_error_under_constant_valve_current(grid_runs) -> None:
    runs = by_params(grid_runs)
    for mass in PAYLOADS:
        tight, leaky = runs[(mass, 1e-12)], runs[(mass, 1e-11)]
        # the same valve current moves the tight cylinder further: leakage eats the flow
        assert leaky.q[-1, 1] < tight.q[-1, 1]


def test_failed_variant_is_reported_and_the_others_run(tmp_path: Path) -> None:
    runs = sweep("planar2", [{"end_effector.mass": 1.0}, {"end_effector.masss": 2.0},
                             {"end_effector.mass": 3.0}], out=tmp_path, duration=0.05, processes=1)
    assert [r.spec.end_effector.mass for r in runs] == [1.0, 3.0]
    assert len(runs.failures) == 1
    failure = runs.failures[0]
    assert failure.parameters == {"end_effector.masss": 2.0}
    assert "did you mean 'mass'" in failure.error


def test_any_executor_and_list_of_variants(tmp_path: Path) -> None:
    with ThreadPoolExecutor(2) as pool:
        runs = sweep("planar2", [{"joints.q1.body.mass": m} for m in (1.0, 2.0)], out=tmp_path,
                     duration=0.1, executor=pool, inputs={"q1": ml.signals.constant(5.0)})
        assert not pool._shutdown  # the caller's executor is left running
    assert [r.spec.joint("q1").body.mass for r in runs] == [1.0, 2.0]
    # a heavier link accelerates less under the same torque
    assert runs[0].q[-1, 0] > runs[1].q[-1, 0]


def test_grid_is_the_full_product() -> None:
    combos = variants({"a": [1, 2], "b": [10, 20, 30]})
    assert combos[:2] == [{"a": 1, "b": 10}, {"a": 1, "b": 20}] and len(combos) == 6
    with pytest.raises(ml.ManiplabError, match="must be a list"):
        variants({"a": 1.0})


def test_runs_on_a_local_dask_cluster(tmp_path: Path) -> None:
    import distributed  # the test extra installs it
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=40)
    with cluster, distributed.Client(cluster) as client:
        runs = sweep("planar2", {"end_effector.mass": [0.5, 1.5]}, out=tmp_path, duration=0.1,
                     executor=client, inputs={"q2": ml.signals.constant(1.0)})
    assert [r.spec.end_effector.mass for r in runs] == [0.5, 1.5]
    assert not runs.failures


def test_threaded_sweep_equals_simulating_each_variant(grid_runs: RunSet) -> None:
    """The default sweep of arms that need no Python per step runs in threads of this process
    (the plant in C releases the GIL): each run is bit for bit the variant simulated alone."""
    from maniplab.sim.sweep import _needs_python

    base = ml.builtin_spec("erector")
    assert not _needs_python(base, [dict(zip(GRID, p)) for p in [(3000.0, 1e-12)]], {})
    for run in list(grid_runs)[:2]:
        alone = ml.simulate(base.with_overrides(run.meta["overrides"]), duration=3.0,
                            inputs={"q2": ml.signals.step(0.2, t0=0.1)},
                            initial={"dP": "gravity"})
        np.testing.assert_array_equal(run.q, alone.q)
        np.testing.assert_array_equal(run["dP"], alone["dP"])


def test_variants_that_need_python_go_to_processes() -> None:
    from maniplab.sim.sweep import _needs_python

    motor = {"type": "plugins.dcmotor:GearedDCMotor", "resistance": 1.0, "inductance": 5e-3,
             "torque_constant": 0.5, "gear_ratio": 100.0}
    base = ml.builtin_spec("crane3")
    assert not _needs_python(base, [{}], {})
    assert _needs_python(base, [{}, {"joints.slew.actuator": motor}], {})  # a Python actuator
    assert _needs_python(base, [{}], {"controller": lambda t, s: [0.0] * 3})


def test_spawned_workers_load_the_plugins_the_parent_named(monkeypatch: pytest.MonkeyPatch,
                                                           tmp_path: Path) -> None:
    """A worker started by spawn (as under a fork server, the default from Python 3.14) imports
    no plugin by itself, and a spec never makes it import one: the modules the parent named on
    purpose (ml.load_plugins) are handed to it. Each variant equals simulating it alone."""
    import multiprocessing

    monkeypatch.delenv("MANIPLAB_PLUGINS", raising=False)
    monkeypatch.setenv("PYTHONPATH", str(Path(__file__).parent))  # where tests/plugins lives
    monkeypatch.setattr(multiprocessing, "get_start_method", lambda allow_none=False: "forkserver")
    ml.load_plugins("plugins.spring")
    springs = [{"type": "plugins.spring:LinearSpring", "stiffness": k} for k in (20.0, 80.0)]
    base = ml.builtin_spec("planar2")
    inputs = {"q1": ml.signals.step(0.3)}
    runs = ml.sweep(base, {"joints.q1.actuator": springs}, out=tmp_path / "s", inputs=inputs,
                    duration=0.2, processes=2)
    assert not runs.failures, runs.failures
    for run, spring in zip(runs, springs):
        alone = ml.simulate(base.with_overrides({"joints.q1.actuator": spring}), duration=0.2,
                            inputs=inputs)
        np.testing.assert_array_equal(run.q, alone.q)


def test_an_interrupted_sweep_leaves_the_folder_as_it_was(monkeypatch: pytest.MonkeyPatch,
                                                          tmp_path: Path) -> None:
    """Ctrl-C while the second run is saved: the runs wait in a staging folder until all are
    done, so the earlier run of the same name and the other files are untouched, and nothing
    of the sweep (not even its staging folder) is left."""
    from maniplab.sim.run import Run

    out = tmp_path / "runs"
    out.mkdir()
    (out / "001_payload=20.npz").write_text("an earlier run")
    (out / "notes.txt").write_text("mine")
    saved: list[Path] = []
    original = Run.save

    def save(run: Run, path: Path) -> None:
        if saved:
            raise KeyboardInterrupt
        saved.append(Path(path))
        original(run, path)

    monkeypatch.setattr(Run, "save", save)
    with pytest.raises(KeyboardInterrupt):
        sweep("planar2", {"end_effector.mass": [10.0, 20.0]}, out=out, duration=0.05,
              processes=1)
    assert saved and saved[0].parent != out  # the first run went to the staging folder
    assert sorted(p.name for p in out.iterdir()) == ["001_payload=20.npz", "notes.txt"]
    assert (out / "001_payload=20.npz").read_text() == "an earlier run"


def test_a_run_name_taken_by_a_folder_is_refused_before_anything_moves(tmp_path: Path) -> None:
    out = tmp_path / "runs"
    (out / "001_payload=20.npz").mkdir(parents=True)
    with pytest.raises(ml.ManiplabError, match="001_payload=20.npz: a folder, not a regular"):
        sweep("planar2", {"end_effector.mass": [10.0, 20.0]}, out=out, duration=0.05,
              processes=1)
    assert [p.name for p in out.iterdir()] == ["001_payload=20.npz"]
