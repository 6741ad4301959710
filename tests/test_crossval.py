"""Cross-validation: the MuJoCo plant and scipy's integration of the analytic model agree.

The two sides share nothing but the spec: mjcf_gen builds the MuJoCo model with MjSpec, model/
derives the equations with sympy, MuJoCo's RK4 integrates one and scipy's DOP853 the other.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from commandline import run_cli

import maniplab as ml
from maniplab.sim.crossval import crossvalidate, ideal, integrate_analytic

S = ml.signals


@pytest.mark.parametrize(
    ("name", "q0", "inputs"),
    [
        ("planar2", [-np.pi / 2, 0.0], {"q1": S.sine(2.0, frequency=0.5), "q2": S.sine(1.0, frequency=0.8)}),
        ("erector", [-np.pi / 2, 0.3, 0.0, 0.0, 0.0, 0.0],
         {"q1": S.sine(2e4, frequency=0.3), "q3": S.sine(2e3, frequency=0.5),
          "q4": S.sine(2e3, frequency=0.4), "q5": S.sine(500.0, frequency=0.6),
          "q6": S.sine(50.0, frequency=0.7)}),
        ("erector", None, None),  # released from q = 0: falls and swings under gravity
    ],
    ids=["planar2 driven", "erector driven", "erector falling"],
)
def test_mujoco_plant_and_analytic_model_agree_over_5_s(name, q0, inputs) -> None:
    result = crossvalidate(name, inputs=inputs, q0=q0, duration=5.0)
    assert result.mujoco.t[-1] == pytest.approx(5.0)
    assert np.ptp(result.mujoco.q, axis=0).max() > 0.5  # the arm really moved
    assert result.max_deviation < 1e-4, (result.joint, result.time)


def test_ideal_arm_has_torque_sources_and_no_friction_or_limits() -> None:
    arm = ideal(ml.builtin_spec("erector"))
    assert {j.actuator.type for j in arm.joints} == {"torque"}
    assert {j.friction.model.value for j in arm.joints} == {"none"}
    assert all(j.limits is None for j in arm.joints)
    assert arm.end_effector == ml.builtin_spec("erector").end_effector


def test_analytic_integration_matches_the_small_oscillation_period() -> None:
    """A hanging rod is a compound pendulum: T = 2π sqrt(I/(m g d)), I = m L²/3, d = L/2."""
    spec = ml.ManipulatorSpec.from_dict({
        "name": "pendulum", "gravity": [0.0, -9.81, 0.0],
        "joints": [{"type": "R", "axis": "z", "body": {"length": 1.0, "mass": 2.0}}],
    })
    t = np.linspace(0.0, 4.0, 4001)
    run = integrate_analytic(spec, {}, t, q0=np.array([-np.pi / 2 + 1e-3]))
    period = 2 * np.pi * np.sqrt((1.0 / 3.0) / (9.81 * 0.5))
    upward = t[np.where(np.diff(np.sign(run.q[:, 0] + np.pi / 2)) > 0)[0]]
    assert np.diff(upward).mean() == pytest.approx(period, rel=1e-3)


PUMP_ARM = Path(__file__).parent / "arms" / "mixed" / "forestry_pump.yaml"


def test_an_arm_with_a_shared_supply_crossvalidates(capsys, tmp_path) -> None:
    """An arm with a ``supply:`` section (two pinned cylinders on one pump, lumped slew and
    rotator) cross-validates, through the API and ``maniplab crossval``: its ideal arm drops the
    supply with the cylinders.

    Before (issue 33): ``ideal`` swapped every actuator for a torque source and kept the supply,
    so the spec refused itself ("field 'supply': no joint has a pinned cylinder ..."), exit 2."""
    spec = ml.load_spec(PUMP_ARM)
    assert spec.supply is not None
    arm = ideal(spec)
    assert arm.supply is None and {j.actuator.type for j in arm.joints} == {"torque"}
    result = crossvalidate(spec, inputs={"lift": S.sine(2e3, frequency=0.5)}, duration=1.0)
    assert np.ptp(result.mujoco.q, axis=0).max() > 0.1  # the arm really moved
    assert result.max_deviation < 1e-6, (result.joint, result.time)
    code, out, err = run_cli(capsys, "crossval", str(PUMP_ARM), "--duration", "0.5", "-o",
                             str(tmp_path / "cv.png"))
    assert code == 0, err
    assert "largest deviation" in out and (tmp_path / "cv.png").exists()
