"""The controller's gains derived from the arm: the rule checked against the arm's own numbers
(valve lags, spring modes computed here from MuJoCo's mass matrix), gains in the spec winning,
and ``maniplab tune``."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

import maniplab as ml
from maniplab.cli import main
from maniplab.control.tuning import derive, resolve
from maniplab.mjcf_gen.timestep import POSES
from maniplab.mjcf_gen.workspace import poses

ARMS = Path(__file__).parent / "arms"


def joint_spring_frequencies(spec: ml.ManipulatorSpec) -> np.ndarray:
    """Each joint's min over poses of sqrt(k_j / M_jj), its oil spring on its own inertia with
    the other joints held, written out (lumped cylinders: k = A² E / V), rad/s, (n,)."""
    model = ml.build_model(spec)
    data = mujoco.MjData(model)
    k = np.array([j.actuator.area**2 * j.actuator.bulk_modulus / j.actuator.volume
                  for j in spec.joints])
    lowest = np.full(spec.n, np.inf)
    for q in poses(spec, POSES):
        data.qpos[:] = q
        mujoco.mj_forward(model, data)
        M = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, M)
        lowest = np.minimum(lowest, np.sqrt(k / np.diag(M)))
    return lowest


@pytest.mark.parametrize("name", ["erector", "crane3", str(ARMS / "excavator.yaml")],
                         ids=["erector", "crane3", "excavator"])
def test_the_rule_on_hydraulic_arms(name: str) -> None:
    spec = ml.resolve_spec(name)
    control = derive(spec).control
    tau = max(j.actuator.valve_tau for j in spec.joints)
    force = 0.4 / tau
    assert control.pressure.bandwidth == pytest.approx(force)
    outer = control.position
    poles = np.roots([1.0, outer.kd, outer.kp, outer.ki])
    np.testing.assert_allclose(poles, -force / 3.0, rtol=1e-4)  # a triple pole at ω_F / 3
    assert control.orientation == outer
    assert control.rate >= force / 0.2 and control.rate >= 200.0
    pid, omega = control.pid_only, joint_spring_frequencies(spec)
    kp = np.minimum(0.1 * omega, [0.2 / j.actuator.valve_tau for j in spec.joints])
    np.testing.assert_allclose(pid.kp, kp, rtol=1e-9)
    np.testing.assert_allclose(pid.ki, kp**2 / 2, rtol=1e-9)  # damping ratio 1/√2


def test_an_arm_of_ideal_torque_sources_gets_gains_from_the_rate() -> None:
    control = derive(ml.resolve_spec(str(ARMS / "electric2.yaml"))).control
    poles = np.roots([1.0, control.position.kd, control.position.kp, control.position.ki])
    np.testing.assert_allclose(poles, -0.05 * control.rate, rtol=1e-4)
    np.testing.assert_allclose(control.pid_only.ki, np.square(control.pid_only.kp) / 2)


def test_gains_written_in_the_spec_win() -> None:
    spec = ml.builtin_spec("crane3").with_overrides({"control.pressure.bandwidth": 15.0,
                                                    "control.position.kp": 50.0})
    derived, resolved = derive(spec).control, resolve(spec)
    assert resolved.pressure.bandwidth == 15.0 and resolved.position.kp == 50.0
    assert resolved.position.kd == derived.position.kd and resolved.rate == derived.rate
    assert ml.CascadeController(spec, ml.MinJerkMove(ml.Pose(np.zeros(3), np.eye(3)),
                                                     ml.Pose(np.ones(3), np.eye(3)), 1.0)
                                ).gains == resolved


def test_tune_prints_the_section_and_writes_a_copy(tmp_path: Path, capsys) -> None:
    out = tmp_path / "tuned.yaml"
    assert main(["tune", "crane3", "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    reasons = [line for line in printed.splitlines() if line.startswith("# ")]
    assert any("pressure.bandwidth" in r and "τ = 0.005 s" in r for r in reasons)
    section = yaml.safe_load(printed)["control"]
    assert section["pressure"]["bandwidth"] == pytest.approx(0.4 / 0.005)
    tuned = ml.load_spec(out)
    assert tuned.control == resolve(ml.builtin_spec("crane3"))
    assert tuned.joints == ml.builtin_spec("crane3").joints
