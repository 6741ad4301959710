"""The actuator models on their own: eq. (4) of the hydraulic cylinder, the native cylinder
update against exact solutions, the torque source, the plugin interface's defaults."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import maniplab as ml
from maniplab.actuators.hydraulic import HydraulicBank, HydraulicCylinder
from maniplab.actuators.torque import TorqueSource
from maniplab.numerics import phi1

CYLINDER = ml.HydraulicActuator(type="hydraulic", area=2e-3, volume=1e-3, valve_gain=1e-3,
                                supply_pressure=20e6, bulk_modulus=1.4e9, leakage=1e-11,
                                valve_tau=0.01, current_limit=0.5)
JOINT = ml.Joint(name="p", type="P", axis="z", actuator=CYLINDER)


def test_cylinder_is_eq_4() -> None:
    model = HydraulicCylinder(CYLINDER, JOINT)
    assert model.states == ("dP", "Q") and model.command_limit == 0.5
    dP, Q, u, v = 4e6, 2e-4, 0.3, 0.05
    dP_dot, Q_dot = model.derivatives(np.array([dP, Q]), u, 0.0, v)
    # (V/E) dΔP/dt + Le ΔP + A v = Q
    assert 1e-3 / 1.4e9 * dP_dot + 1e-11 * dP + 2e-3 * v == pytest.approx(Q, rel=1e-12)
    # Q + τ dQ/dt = i_v C sqrt(1 - |ΔP|/Ps)
    assert Q + 0.01 * Q_dot == pytest.approx(u * 1e-3 * math.sqrt(1 - 4e6 / 20e6), rel=1e-12)
    assert model.force(np.array([dP, Q]), u, 0.0, v) == pytest.approx(2e-3 * dP)
    # beyond the supply pressure the valve passes nothing (the root's argument is clipped)
    assert model.derivatives(np.array([30e6, 0.0]), u, 0.0, 0.0)[1] == 0.0


def test_phi1() -> None:
    for x in (0.0, 1e-14, 1e-6, 0.3, 40.0):
        expected = 1.0 if x == 0.0 else -math.expm1(-x) / x
        assert phi1(x) == pytest.approx(expected, rel=1e-12)


def one_cylinder_bank(params: ml.HydraulicActuator, dt: float
                      ) -> tuple[HydraulicBank, mujoco.MjModel, list[float]]:
    """The bank on a one-joint MuJoCo model of its own: (bank, model, a zero ctrl list)."""
    joint = ml.Joint(name="p", type="P", axis="z", actuator=params)
    s = mujoco.MjSpec()
    body = s.worldbody.add_body(name="b", mass=1.0, inertia=[1.0, 1.0, 1.0])
    body.add_joint(name="p", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, 1.0])
    s.add_actuator(name="p", target="p", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    HydraulicCylinder(params, joint).configure_mjcf(s.actuators[0])
    bank = HydraulicBank([HydraulicCylinder(params, joint)], [0], dt=dt,
                         integrator=int(mujoco.mjtIntegrator.mjINT_RK4))
    bank.configure(s)
    model = s.compile()
    bank.bind(model, mujoco.MjData(model))
    return bank, model, [0.0] * model.nu


def test_bank_is_exact_for_a_held_piston_under_constant_flow() -> None:
    """With Δq = 0, a constant valve target and |ΔP| << Ps, one update of any length is exact:
    ΔP' = e^(-λ dt) ΔP + (Q/Le)(1 - e^(-λ dt)), λ = Le E/V, and the valve's Q' too."""
    big = ml.HydraulicActuator(**{**CYLINDER.__dict__, "supply_pressure": 1e30})
    for dt in (1e-3, 0.05):
        bank, _, ctrl = one_cylinder_bank(big, dt)
        target = 0.4 * 1e-3
        act = [1e5, target, 0.0]  # ΔP, Q at the valve's steady flow; the flow ramp
        bank.prepare([0.0], act, [0.4], ctrl)
        new = list(act)
        assert bank.finish([0.0], [0.0], act, [0.4], new) is None
        lam = 1e-11 * 1.4e9 / 1e-3
        expected = math.exp(-lam * dt) * 1e5 + target / 1e-11 * -math.expm1(-lam * dt)
        assert new[0] == pytest.approx(expected, rel=1e-12)
        assert new[1] == pytest.approx(target, rel=1e-12)


def test_bank_oil_spring_and_force_constant() -> None:
    bank, model, ctrl = one_cylinder_bank(CYLINDER, 1e-3)
    assert bank.spring == [pytest.approx(2e-3**2 * 1.4e9 / 1e-3)]
    assert model.actuator_biasprm[0, 1] == -bank.spring[0]  # the oil spring: b0 - k q
    flow = model.actuator("p/flow").id
    bank.prepare([0.1], [3e6, 0.0, 0.0], [0.0], ctrl)  # closed valve: only leakage changes ΔP
    b0 = model.actuator_biasprm[0, 0]
    assert b0 == pytest.approx(2e-3 * 3e6 + bank.spring[0] * 0.1, rel=1e-12)  # A ΔP + k q
    assert ctrl[flow] == pytest.approx(-1e-11 * 3e6, rel=1e-12)  # -Le ΔP, m³/s
    bank.prepare([0.1], [3e6, 2e-4, 0.0], [0.0], ctrl)  # the valve closing: Q decays with τ
    tau = CYLINDER.valve_tau
    volume = 2e-4 * tau * -math.expm1(-1e-3 / tau)  # ∫Q over the step
    assert ctrl[flow] == pytest.approx(volume / 1e-3 - 1e-11 * 3e6, rel=1e-12)


def test_torque_source() -> None:
    joint = ml.Joint(name="r", type="R", axis="z", actuator=ml.TorqueActuator(limit=40.0))
    source = TorqueSource(joint.actuator, joint)
    assert source.states == () and source.command_limit == 40.0
    assert source.force(source.initial_state(), 12.5, 0.0, 0.0) == 12.5
    assert source.derivatives(np.zeros(0), 1.0, 0.0, 0.0).shape == (0,)
    assert repr(source) == "TorqueSource(joint='r')"


def test_model_of_builds_the_joints_model() -> None:
    spec = ml.builtin_spec("crane3")
    models = [ml.spec.model_of(j) for j in spec.joints]
    assert all(isinstance(m, HydraulicCylinder) for m in models)
    assert models[2].params is spec.joints[2].actuator
    assert set(ml.actuators.registered()) >= {"torque", "hydraulic"}
