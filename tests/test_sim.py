"""ml.simulate, the Plant and the Run they produce: signals, metadata, controllers, state in
MuJoCo's state vector, independence of plants, errors."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

import maniplab as ml

STANDARD = ("q", "qd", "tau_act", "tau_fric", "tau_limit", "ctrl", "iv", "dP", "Q", "mode")


@pytest.fixture(scope="module")
def erector_run() -> ml.Run:
    s = ml.signals
    return ml.simulate("erector", inputs={"q1": s.step(0.3, t0=0.1), "q4": s.step(0.5, t0=0.1)},
                       duration=1.0, initial={"dP": "gravity"}, label="demo")


def test_run_has_the_standard_signals(erector_run) -> None:
    run = erector_run
    assert run.t.shape == (1001,) and run.t[0] == 0.0 and run.t[-1] == pytest.approx(1.0)
    for name in STANDARD:
        assert run[name].shape == (1001, 6), name
    assert run["ee_pos"].shape == (1001, 3) and run["mode"].dtype == np.int8
    assert not np.isnan(run["dP"]).any() and not np.isnan(run["iv"]).any()
    # the force of a cylinder is A ΔP
    areas = np.array([j.actuator.area for j in run.spec.joints])
    np.testing.assert_allclose(run["tau_act"], areas * run["dP"])
    assert set(np.unique(run["mode"])) <= {m.value for m in ml.friction.FrictionMode}


def test_end_effector_matches_the_analytic_kinematics(erector_run) -> None:
    model = ml.AnalyticModel(erector_run.spec)
    k = [0, 500, 1000]
    np.testing.assert_allclose(erector_run["ee_pos"][k], model.fk(erector_run.q[k])[:, :3, 3],
                               atol=1e-9)


def test_torque_joints_have_nan_hydraulics() -> None:
    run = ml.simulate("planar2", inputs={"q1": 5.0}, duration=0.1)
    assert np.isnan(run["dP"]).all() and np.isnan(run["Q"]).all() and np.isnan(run["iv"]).all()
    np.testing.assert_array_equal(run["tau_act"][:, 0], 5.0)
    assert "z" not in run


def test_meta_records_how_the_run_was_made(erector_run, tmp_path) -> None:
    meta = erector_run.meta
    assert meta["inputs"] == {"q1": "step(0.3, t0=0.1)", "q4": "step(0.5, t0=0.1)"}
    assert meta["dt"] == 1e-3 and meta["integrator"] == "RK4"
    assert meta["initial"] == {"dP": "gravity"} and meta["label"] == "demo"
    assert meta["versions"]["mujoco"] == mujoco.__version__
    json.dumps(meta)
    erector_run.save(tmp_path / "run.npz")
    loaded = ml.Run.load(tmp_path / "run.npz")
    assert loaded.meta == meta and loaded.spec == erector_run.spec
    for name in erector_run:
        np.testing.assert_array_equal(loaded[name], erector_run[name])


def test_overrides_change_the_simulated_spec() -> None:
    run = ml.simulate("planar2", duration=0.05, overrides={"joints.q1.body.mass": 3.0})
    assert run.spec.joint("q1").body.mass == 3.0
    assert run.meta["overrides"] == {"joints.q1.body.mass": 3.0}


class CountingPD:
    """A PD controller on q1 at its own rate, that counts its calls and what it saw."""

    def __init__(self, dt: float | None) -> None:
        self.dt = dt
        self.calls: list[float] = []

    def __call__(self, t: float, state: ml.PlantState) -> dict[str, float]:
        self.calls.append(t)
        assert state.t == pytest.approx(t) and state.q.shape == (2,) and np.isnan(state.dP).all()
        assert list(state.mode) == [0, 0]
        return {"q1": 50.0 * (0.5 - state.q[0]) - 10.0 * state.qd[0]}


def test_controller_runs_at_its_own_rate_with_zero_order_hold() -> None:
    controller = CountingPD(dt=0.01)
    run = ml.simulate("planar2", controller=controller, duration=0.2, inputs={"q2": 1.0})
    np.testing.assert_allclose(controller.calls, np.arange(20) * 0.01, atol=1e-12)
    u = run["ctrl"][:, 0]
    for k in range(20):  # held over each controller period
        assert np.all(u[10 * k:10 * k + 10] == u[10 * k])
    np.testing.assert_array_equal(run["ctrl"][:, 1], 1.0)  # inputs add to the controller
    assert run.meta["controller"] == {"repr": "CountingPD", "dt": 0.01}


def test_controller_without_a_rate_is_called_every_step() -> None:
    controller = CountingPD(dt=None)
    ml.simulate("planar2", controller=controller, duration=0.05)
    assert len(controller.calls) == 50


def test_state_lives_in_mujocos_state_vector() -> None:
    """Saving and restoring the MuJoCo state (which holds ΔP and Q in act) reproduces a run."""
    plant = ml.Plant("erector")
    plant.balance_pressures()
    inputs = {"q1": ml.signals.step(0.4), "q2": ml.signals.sine(0.3, 2.0)}
    ml.simulate(plant, inputs=inputs, duration=0.3)
    saved = plant.save()
    size = mujoco.mj_stateSize(plant.model, mujoco.mjtState.mjSTATE_ACT)
    act = np.empty(size)
    mujoco.mj_getState(plant.model, plant.data, act, mujoco.mjtState.mjSTATE_ACT)
    np.testing.assert_array_equal(act[0:12:2], plant.states()["dP"])
    np.testing.assert_array_equal(act[1:12:2], plant.states()["Q"])
    assert size == 12  # (ΔP, Q) of six cylinders
    first = ml.simulate(plant, inputs=inputs, duration=0.3)
    plant.restore(saved)
    second = ml.simulate(plant, inputs=inputs, duration=0.3)
    assert first.t[0] == pytest.approx(0.3)
    for name in ("q", "qd", "dP", "Q", "mode"):
        np.testing.assert_array_equal(first[name], second[name])
    plant.reset()
    assert plant.t == 0.0 and not plant.data.act.any() and not plant.data.qpos.any()


def test_two_native_plants_interleaved_equal_each_alone() -> None:
    """Built-in actuators use no MuJoCo callback; plants share nothing."""
    specs = [ml.builtin_spec("erector"),
             ml.builtin_spec("erector").with_overrides({"end_effector.mass": 2000.0})]
    inputs = [0.4, -0.2, 0.1, 0.3, 0.0, 0.1]
    alone = []
    for spec in specs:
        plant = ml.Plant(spec)
        plant.balance_pressures()
        for _ in range(300):
            plant.step(inputs)
        alone.append(plant.save())
    a, b = (ml.Plant(spec) for spec in specs)
    for plant in (a, b):
        plant.balance_pressures()
    for _ in range(300):
        a.step(inputs)
        assert mujoco.get_mjcb_act_dyn() is None and mujoco.get_mjcb_act_bias() is None
        b.step(inputs)
    np.testing.assert_array_equal(a.save(), alone[0])
    np.testing.assert_array_equal(b.save(), alone[1])


def test_simulate_continues_a_plant() -> None:
    plant = ml.Plant("planar2")
    first = ml.simulate(plant, inputs={"q1": 2.0}, duration=0.1)
    second = ml.simulate(plant, inputs={"q1": 2.0}, duration=0.1)
    assert second.t[0] == pytest.approx(0.1) and second.q[0, 0] == first.q[-1, 0]
    with pytest.raises(ml.InputError, match="dt=0.001"):
        ml.simulate(plant, duration=0.1, dt=1e-4)
    with pytest.raises(ml.InputError, match="overrides"):
        ml.simulate(plant, duration=0.1, overrides={"end_effector.mass": 1.0})


def test_initial_state() -> None:
    run = ml.simulate("planar2", duration=0.01, initial={"q": {"q2": 0.5}, "qd": [1.0, 0.0]})
    assert run.q[0].tolist() == [0.0, 0.5] and run.qd[0].tolist() == [1.0, 0.0]
    plant = ml.Plant("erector")
    plant.set_state(q=[9.0, 0, 0, 0, 0, 0])  # beyond the limit 3.5: put on it
    assert plant.data.qpos[0] == 3.5 and plant.modes[0] == ml.friction.FrictionMode.AT_UPPER


@pytest.mark.parametrize(("kwargs", "words"), [
    ({"inputs": {"q9": 1.0}}, ["no joint 'q9'", "q1, q2"]),
    ({"inputs": {"q1": "fast"}}, ["inputs['q1']"]),
    ({"controller": lambda t, s: [np.nan, 0.0]}, ["non-finite command", "t = 0"]),
    ({"controller": lambda t, s: [1.0, 2.0, 3.0]}, ["expected 2 commands"]),
    ({"initial": {"dP": [1.0, 2.0]}}, ["no state 'dP'"]),
    ({"initial": {"q": [1.0]}}, ["expected shape (2,)"]),
    ({"duration": -1.0}, ["duration must be a positive"]),
    ({"sample_dt": 0.0}, ["sample_dt"]),
    ({"integrator": "RK45"}, ["unknown integrator 'RK45'"]),
])
def test_bad_arguments_are_input_errors(kwargs, words) -> None:
    kwargs = {"duration": 0.01, **kwargs}
    with pytest.raises(ml.InputError) as caught:
        ml.simulate("planar2", **kwargs)
    for word in words:
        assert word in str(caught.value)
    assert isinstance(caught.value, ml.ManiplabError)


def test_other_integrators() -> None:
    runs = {name: ml.simulate("planar2", inputs={"q1": 1.0}, duration=0.2, integrator=name)
            for name in ("RK4", "Euler", "implicitfast")}
    assert runs["Euler"].meta["integrator"] == "Euler"
    for name in ("Euler", "implicitfast"):
        assert np.max(np.abs(runs[name].q - runs["RK4"].q)) < 1e-2


def test_sampling_interval() -> None:
    run = ml.simulate("planar2", duration=0.1, dt=1e-4)
    assert len(run.t) == 101 and run.meta["sample_dt"] == pytest.approx(1e-3)
    run = ml.simulate("planar2", duration=0.1, sample_dt=0.01)
    assert len(run.t) == 11


def test_a_huge_value_stops_the_run_with_maniplabs_message_not_mujocos(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    """A velocity just inside MuJoCo's 1e10 sanity bound makes the Coriolis acceleration huge at
    once: the run stops naming the joint, MuJoCo neither prints nor writes MUJOCO_LOG.TXT into
    the user's folder; a velocity beyond the bound is refused as input."""
    monkeypatch.chdir(tmp_path)
    plant = ml.Plant("planar2")
    with pytest.raises(ml.InputError, match=r"qd: joint q1: 1e\+11 is beyond MuJoCo's bound"):
        plant.set_state(qd=[1e11, 0.0])
    plant.set_state(qd=[9e9, 9e9])
    with pytest.raises(ml.InstabilityError) as caught:
        ml.simulate(plant, duration=0.01)
    assert caught.value.joint in ("q1", "q2") and "huge value (> 1e10)" in str(caught.value)
    assert not list(tmp_path.iterdir())
    out, err = capfd.readouterr()
    assert "WARNING" not in out + err
