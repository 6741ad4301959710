"""CascadeController: sampling, state access, log, settings; closed loop on MuJoCo directly."""

from __future__ import annotations

import types

import mujoco
import numpy as np
import pytest

import maniplab as ml
from maniplab.control import CascadeController, MinJerkMove, Pose
from maniplab.control.cascade import LOG_SIGNALS


@pytest.fixture(scope="module")
def erector() -> tuple[ml.ManipulatorSpec, ml.AnalyticModel]:
    spec = ml.builtin_spec("erector")
    return spec, ml.AnalyticModel(spec)


Q0 = np.array([-0.18, 1.27, 0.0, 0.0, 0.0, 0.0])


def move(am: ml.AnalyticModel, q0: np.ndarray = Q0, d=(-0.9, 0.45, 0.0)) -> MinJerkMove:
    start = Pose.from_matrix(am.fk(q0))
    return MinJerkMove(start, start.translated(d), 4.0, t0=0.5)


def test_samples_at_its_rate_and_holds_between(erector: tuple) -> None:
    spec, am = erector
    c = CascadeController(spec, move(am), model=am, rate=200.0)
    state = {"q": Q0, "qd": np.zeros(6), "dP": np.zeros(6)}
    outputs = [c(k * 1e-3, state).copy() for k in range(50)]  # called at 1 kHz for 50 ms
    assert len(c.times) == 10
    np.testing.assert_allclose(c.times, np.arange(10) * 5e-3, atol=1e-12)
    assert all(np.array_equal(outputs[k], outputs[k - k % 5]) for k in range(50))


def test_reads_state_attributes_or_keys(erector: tuple) -> None:
    spec, am = erector
    a = CascadeController(spec, move(am), model=am)
    b = CascadeController(spec, move(am), model=am)
    fields = {"q": Q0, "qd": np.full(6, 0.01), "dP": np.full(6, 1e6)}
    np.testing.assert_array_equal(a(0.0, fields), b(0.0, types.SimpleNamespace(**fields)))
    with pytest.raises(TypeError, match="q and qd"):
        CascadeController(spec, move(am), model=am)(0.0, {"q": Q0})


def test_log_signals_and_resampling(erector: tuple) -> None:
    spec, am = erector
    c = CascadeController(spec, move(am), model=am, rate=100.0)
    for k in range(5):
        c(k * 0.01, {"q": Q0, "qd": np.zeros(6), "dP": np.full(6, 2e6)})
    sig = c.signals()
    assert set(sig) == set(c.log_signals) == set(LOG_SIGNALS) | {"dP_d", "phi"}
    assert sig["x_d"].shape == (5, 6) and sig["cmd"].shape == (5, 6) and sig["a_x"].shape == (5, 6)
    np.testing.assert_allclose(sig["x"][0, :3], am.fk(Q0)[:3, 3])
    np.testing.assert_allclose(sig["x_d"][0], move(am).start.xyzrpy, atol=1e-12)
    # the command at rest, on target: the pressure loop's flow and G2's current are consistent
    assert np.all(np.abs(sig["cmd"]) <= 1.0)
    at = c.signals_at(np.array([-0.01, 0.0, 0.015, 0.5]))
    assert np.isnan(at["ctrl.cmd"][0]).all()
    np.testing.assert_array_equal(at["ctrl.cmd"][2], sig["cmd"][1])
    np.testing.assert_array_equal(at["ctrl.cmd"][3], sig["cmd"][4])
    c.reset()
    assert c.signals()["cmd"].shape == (0, 6)


def test_settings_from_the_spec_and_arguments(erector: tuple) -> None:
    spec, am = erector
    tuned = spec.with_overrides({"control.rate": 250.0, "control.task": "position",
                                 "control.position.kp": 50.0})
    c = CascadeController(tuned, move(am))
    assert c.dt == pytest.approx(4e-3) and c.task == "position" and c.outer.kp[0] == 50.0
    c2 = CascadeController(tuned, move(am), model=am, rate=500.0)
    assert c2.rate == 500.0 and c2.task == "position"
    assert CascadeController(spec, move(am), model=am).task == "pose"
    with pytest.raises(ValueError, match="mode"):
        CascadeController(spec, move(am), model=am, mode="lqr")
    with pytest.raises(ml.SpecError, match="field 'rate': expected a number > 0, got -1.0"):
        CascadeController(spec, move(am), model=am, rate=-1.0)


def test_computed_torque_tracks_on_a_torque_arm() -> None:
    """planar2 (torque joints): the cascade is computed-torque control; closed loop in MuJoCo."""
    spec = ml.builtin_spec("planar2")
    am = ml.AnalyticModel(spec)
    q0 = np.array([0.3, 1.2])
    start = Pose.from_matrix(am.fk(q0))
    traj = MinJerkMove(start, start.translated([0.4, -0.3, 0.0]), 1.0, t0=0.1)
    c = CascadeController(spec, traj, model=am, rate=1000.0)
    m = ml.build_model(spec)
    m.opt.timestep = 1e-3
    d = mujoco.MjData(m)
    d.qpos[:] = q0
    mujoco.mj_forward(m, d)
    errors = []
    for _ in range(1300):
        tau = c(d.time, {"q": d.qpos.copy(), "qd": d.qvel.copy()})
        d.qfrc_applied[:] = tau
        d.ctrl[:] = 0.0
        mujoco.mj_step(m, d)
        errors.append(np.linalg.norm(am.fk(d.qpos)[:3, 3] - traj.sample(d.time).position))
    assert max(errors) < 1e-3  # 1 mm on a 0.5 m move in 1 s
    assert errors[-1] < 1e-4
