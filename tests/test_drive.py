"""The cascade drives any actuator through the capabilities it declares: a plugin DC motor gets
volts within its limit (its steady-state inversion, written out here), and a plugin that declares
no way to be driven is refused with one line naming the joint."""

from __future__ import annotations

import numpy as np
import pytest

import maniplab as ml
from maniplab.cli import main
from maniplab.control.point_to_point import plan_move
from maniplab.control.trajectory import MinJerkMove

R, K, N, ETA, V_MAX = 1.0, 0.05, 100.0, 0.9, 48.0


def motor_arm(actuator: dict | None = None) -> ml.ManipulatorSpec:
    """Two links pitching about y under gravity, each driven by a geared DC motor plugin."""
    motor = actuator or {"type": "plugins.dcmotor:GearedDCMotor", "resistance": R,
                         "inductance": 2e-3, "torque_constant": K, "gear_ratio": N,
                         "efficiency": ETA, "voltage_limit": V_MAX}
    link = {"type": "R", "axis": "y", "body": {"length": 0.5, "mass": 2.0},
            "actuator": motor, "friction": {"model": "hybrid", "viscous": 0.5}}
    return ml.ManipulatorSpec.from_dict({"name": "motor-arm", "joints": [
        {"name": "shoulder", **link}, {"name": "elbow", **link}],
        "end_effector": {"mass": 1.0}})


def run_move(spec: ml.ManipulatorSpec, distance: float, duration: float) -> tuple[ml.Run, object]:
    model = ml.AnalyticModel(spec)
    q0 = np.array([0.3, 1.2])
    start = model.fk(q0)[:3, 3]
    target = start + distance * np.array([-0.6, 0.0, 0.8])
    plan = plan_move(spec, target.tolist(), start=q0.tolist(), duration=1.0, model=model)
    # the move as asked, also faster than the motors can follow (no stretching)
    move = MinJerkMove(plan.move.start, plan.move.goal, duration, t0=plan.move.t0)
    task, q_start = plan.task, q0
    controller = ml.CascadeController(spec, move, task=task, model=model)
    run = ml.simulate(spec, controller=controller, duration=move.t0 + move.duration + 1.0,
                      initial={"q": q_start, "dP": "gravity"})
    return run, move


def test_dc_motor_joints_get_volts_from_their_steady_state_inversion() -> None:
    spec = motor_arm()
    run, move = run_move(spec, 0.1, 2.0)
    volts = run["voltage"]
    np.testing.assert_array_equal(volts, run["ctrl"])  # the motors' command signal
    assert np.all(np.abs(volts) <= V_MAX)
    assert np.all(np.isnan(run["iv"]))  # no valve anywhere
    # at each controller sample: V = R i_d + K N ω, i_d = τ_d / (η N K), clipped at the limit
    period = round(1.0 / (run.meta["control"]["rate"] * 1e-3))
    k = np.arange(0, len(run.t) - 1, period)
    expected = np.clip(R * run["tau_d"][k] / (ETA * N * K) + K * N * run.qd[k], -V_MAX, V_MAX)
    np.testing.assert_allclose(volts[k], expected, rtol=1e-12, atol=1e-12)
    # and the arm follows the move to its target
    final = move.sample(run.t[-1]).position
    assert np.linalg.norm(run["ee_pos"][-1] - final) < 2e-3


def test_a_fast_move_saturates_the_motors_at_their_voltage_limit() -> None:
    run, _ = run_move(motor_arm(), 0.3, 0.1)
    volts = run["voltage"]
    assert np.max(np.abs(volts)) == V_MAX  # the controller asked for more and got the limit
    assert np.all(np.abs(volts) <= V_MAX)


def test_a_plugin_without_steady_state_or_drive_is_refused() -> None:
    spec = motor_arm({"type": "plugins.dcmotor:Spring", "stiffness": 10.0})
    model = ml.AnalyticModel(spec)
    plan = plan_move(spec, model.fk(np.array([0.3, 0.6]))[:3, 3].tolist(), start=[0.3, 0.6],
                     duration=1.0, model=model)
    move, task = plan.move, plan.task
    with pytest.raises(ml.actuators.CapabilityError) as caught:
        ml.CascadeController(spec, move, task=task, model=model)
    message = str(caught.value)
    assert "joint shoulder, elbow" in message and "steady()" in message and "\n" not in message


def test_the_control_command_refuses_it_in_one_line(tmp_path, capsys) -> None:
    path = tmp_path / "spring.yaml"
    motor_arm({"type": "plugins.dcmotor:Spring", "stiffness": 10.0}).dump(path)
    code = main(["control", str(path), "--target", "0.5,0,0.5", "--duration", "1",
                 "-o", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert "joint shoulder, elbow" in err and "cannot be driven" in err
    assert not (tmp_path / "out").exists()
