"""The actuator models on their own: eq. (4) of the hydraulic cylinder, the native cylinder
update against exact solutions, the torque source, the plugin interface's defaults."""

from __future__ import annotations

import math

import numpy as np
import pytest

import maniplab as ml
from maniplab.actuators.hydraulic import HydraulicBank, HydraulicCylinder, phi1
from maniplab.actuators.torque import TorqueSource

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


def test_bank_is_exact_for_a_held_piston_under_constant_flow() -> None:
    """With Δq = 0, a constant valve target and |ΔP| << Ps, one update of any length is exact:
    ΔP' = e^(-λ dt) ΔP + (Q/Le)(1 - e^(-λ dt)), λ = Le E/V, and the valve's Q' too."""
    big = ml.HydraulicActuator(**{**CYLINDER.__dict__, "supply_pressure": 1e30})
    for dt in (1e-3, 0.05):
        bank = HydraulicBank([big], dt)
        target = 0.4 * 1e-3
        act = [1e5, target]  # ΔP, Q at the valve's steady flow
        bank.prepare([0.0], act, [0.4], [0.0])
        new = list(act)
        assert bank.finish([0.0], [0.0], act, [0.4], new)
        lam = 1e-11 * 1.4e9 / 1e-3
        expected = math.exp(-lam * dt) * 1e5 + target / 1e-11 * -math.expm1(-lam * dt)
        assert new[0] == pytest.approx(expected, rel=1e-12)
        assert new[1] == pytest.approx(target, rel=1e-12)


def test_bank_oil_spring_and_force_constant() -> None:
    bank = HydraulicBank([CYLINDER], 1e-3)
    assert bank.spring == [pytest.approx(2e-3**2 * 1.4e9 / 1e-3)]
    b0 = [0.0]
    rate = bank.prepare([0.1], [3e6, 0.0], [0.0], b0)  # closed valve: only leakage changes ΔP
    assert b0[0] == pytest.approx(2e-3 * 3e6 + bank.spring[0] * 0.1, rel=1e-12)  # A ΔP + k q
    assert rate[0] == pytest.approx(-1e-11 * 3e6, rel=1e-12)  # -Le ΔP, m³/s
    rate = bank.prepare([0.1], [3e6, 2e-4], [0.0], b0)  # the valve closing: Q decays with τ
    tau = CYLINDER.valve_tau
    volume = 2e-4 * tau * -math.expm1(-1e-3 / tau)  # ∫Q over the step
    assert rate[0] == pytest.approx(volume / 1e-3 - 1e-11 * 3e6, rel=1e-12)


def test_torque_source() -> None:
    joint = ml.Joint(name="r", type="R", axis="z", actuator=ml.TorqueActuator(limit=40.0))
    source = TorqueSource(joint.actuator, joint)
    assert source.states == () and source.command_limit == 40.0
    assert source.force(source.initial_state(), 12.5, 0.0, 0.0) == 12.5
    assert source.derivatives(np.zeros(0), 1.0, 0.0, 0.0).shape == (0,)
    assert repr(source) == "TorqueSource(joint='r')"


def test_plugin_of_builds_the_joints_model() -> None:
    spec = ml.builtin_spec("crane3")
    models = [ml.actuators.plugin.plugin_of(j) for j in spec.joints]
    assert all(isinstance(m, HydraulicCylinder) for m in models)
    assert models[2].params is spec.joints[2].actuator
    assert set(ml.actuators.registered()) >= {"torque", "hydraulic"}
