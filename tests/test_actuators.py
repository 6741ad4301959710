"""The actuator models on their own: eq. (4) of the hydraulic cylinder in Python and as MuJoCo's
engine plugin (C), the torque source, the plugin interface's defaults."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from scipy.optimize import brentq

import maniplab as ml
from maniplab.actuators.hydraulic import HydraulicCylinder
from maniplab.actuators.plugin_mjcf import EnginePlugin, activate_plugins, set_plugin
from maniplab.actuators.torque import TorqueSource
from maniplab.friction import steady_force

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


def one_cylinder_model(params: ml.HydraulicActuator, mass: float = 1.0) -> mujoco.MjModel:
    """A one-joint MuJoCo model (no gravity) whose actuator is the cylinder's engine plugin."""
    joint = ml.Joint(name="p", type="P", axis="z", actuator=params)
    s = mujoco.MjSpec()
    s.option.gravity = [0.0, 0.0, 0.0]
    body = s.worldbody.add_body(name="b", mass=mass, inertia=[1.0, 1.0, 1.0])
    body.add_joint(name="p", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, 1.0])
    act = s.add_actuator(name="p", target="p", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    cylinder = HydraulicCylinder(params, joint)
    cylinder.configure_mjcf(act)
    set_plugin(s, act, cylinder.mujoco_plugin())
    activate_plugins(s)
    return s.compile()


@pytest.mark.parametrize("law", ["orifice", "paper"])
@pytest.mark.parametrize("u", [0.3, -0.2, 0.9])  # 0.9: beyond the limit, clipped to 0.5
@pytest.mark.parametrize("dP", [4e6, -6e6, 23e6, 30e6])  # 23, 30 MPa: relieving, beyond supply
def test_engine_plugin_is_eq_4(law: str, u: float, dP: float) -> None:
    """The C plugin's state derivatives and force, as MuJoCo evaluates them, against eq. (4)
    written out here: (V/E) dΔP/dt = Q - A v - Le ΔP, τ dQ/dt = Q* - Q, f = A ΔP at the step's
    start (the relief acts within the step: each later evaluation and the step's end take ΔP
    through its regime, which brings it back to at most its pressure at full flow)."""
    params = ml.HydraulicActuator(**{**CYLINDER.__dict__, "valve_law": law,
                                     "relief_pressure": 22e6})
    model = one_cylinder_model(params)
    data = mujoco.MjData(model)
    Q, v = 2e-4, 0.05
    data.act[:] = [dP, Q]
    data.qvel[0] = v
    data.ctrl[0] = u
    mujoco.mj_forward(model, data)
    i = max(-0.5, min(0.5, u))
    drop = (dP if i >= 0 else -dP) if law == "orifice" else abs(dP)
    target = i * 1e-3 * math.sqrt(max(0.0, 1.0 - drop / 20e6))
    expected = [1.4e9 / 1e-3 * (Q - 2e-3 * v - 1e-11 * dP), (target - Q) / 0.01]
    assert data.act_dot[0] == pytest.approx(expected[0], rel=1e-12, abs=1e-3)
    assert data.act_dot[1] == pytest.approx(expected[1], rel=1e-12, abs=1e-15)
    force = 2e-3 * dP
    assert data.actuator_force[0] == pytest.approx(force, rel=1e-15)
    assert data.qfrc_actuator[0] == pytest.approx(force, rel=1e-15)
    mujoco.mj_step(model, data)
    assert abs(data.act[0]) <= 22e6 * 1.01  # the relief passes C i_max 1 % above its setting


@pytest.mark.parametrize("dt", [1e-3, 1e-4])
def test_engine_plugin_relief_settles_where_its_flow_balances_the_valve(dt: float) -> None:
    """A held piston (a huge mass), the valve wide open against a relief set below supply: the
    pressure settles where the valve's flow equals leakage plus relief flow, the root of
    Q*(ΔP) = Le ΔP + K_r (ΔP - p_r) (scipy's brentq), at any step."""
    params = ml.HydraulicActuator(**{**CYLINDER.__dict__, "supply_pressure": 40e6,
                                     "relief_pressure": 22e6})
    model = one_cylinder_model(params, mass=1e15)
    model.opt.timestep = dt
    data = mujoco.MjData(model)
    data.ctrl[0] = 0.5
    for _ in range(round(1.0 / dt)):
        mujoco.mj_step(model, data)
    k_r = 1e-3 * 0.5 / (0.01 * 22e6)
    balance = brentq(lambda p: 0.5e-3 * math.sqrt(1 - p / 40e6) - 1e-11 * p - k_r * (p - 22e6),
                     22e6, 40e6, xtol=1e-6)
    assert data.act[0] == pytest.approx(balance, rel=1e-9)
    assert 22e6 < balance < 22e6 * 1.01


def test_engine_plugin_refuses_a_bad_config() -> None:
    """A parameter missing or out of range in a hand-edited file: MuJoCo refuses the model's
    data with the plugin's message, never a silent default."""
    s = mujoco.MjSpec.from_string(ml.to_mjcf(ml.builtin_spec("crane3")))
    mujoco.MjData(s.compile())  # as exported: accepted
    s.plugins[0].config = {**s.plugins[0].config, "volume": "-1e-3"}
    with pytest.raises(ValueError, match="config 'volume' must be positive, got -0.001"):
        mujoco.MjData(s.compile())


@pytest.mark.parametrize(("z", "v"), [(2e-5, 0.03), (-1e-5, -0.004), (3e-6, 0.0)])
def test_lugre_engine_plugin_is_canudas_de_wit(z: float, v: float) -> None:
    """The C plugin ``maniplab.lugre`` against the 1995 paper's equations written out here:
    g = Fc + Fs e^(-(v/vs)²), dz/dt = v - σ0 |v| z / g, force -(σ0 z + σ1 dz/dt); after a step
    z is the exact solution of dz/dt at the step's mean velocity v̄ (z relaxes to g(v̄)/σ0 sign v̄
    at the rate σ0 |v̄| / g(v̄))."""
    s = mujoco.MjSpec()
    body = s.worldbody.add_body(name="b", mass=1.0, inertia=[1.0, 1.0, 1.0])
    body.add_joint(name="x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0])
    act = s.add_actuator(name="x/lugre", target="x", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    config = {"sigma0": 1e5, "sigma1": 316.0, "coulomb": 1.0, "static": 0.5,
              "stribeck_velocity": 1e-3}
    set_plugin(s, act, EnginePlugin("maniplab.lugre", 1, config))
    activate_plugins(s)
    model = s.compile()
    data = mujoco.MjData(model)
    data.act[0], data.qvel[0] = z, v
    mujoco.mj_forward(model, data)

    def g(u: float) -> float:
        return 1.0 + 0.5 * math.exp(-((u / 1e-3) ** 2))

    zdot = v - 1e5 * abs(v) * z / g(v)
    assert data.act_dot[0] == 0.0  # z moves only between steps, exactly
    if v != 0.0:  # in steady sliding (dz/dt = 0) the bristles give the Stribeck curve (+ σ2 v)
        steady = mujoco.MjData(model)
        steady.act[0], steady.qvel[0] = g(v) * math.copysign(1.0, v) / 1e5, v
        mujoco.mj_forward(model, steady)
        friction = ml.Friction(model="lugre", coulomb=1.0, static=0.5, stribeck_velocity=1e-3,
                               viscous=0.4)
        assert -steady.actuator_force[0] + 0.4 * v == pytest.approx(
            float(steady_force(friction, np.array(v))), rel=1e-12)
    assert data.actuator_force[0] == pytest.approx(-(1e5 * z + 316.0 * zdot), rel=1e-12)
    h = model.opt.timestep
    mujoco.mj_step(model, data)
    mean = data.qpos[0] / h
    a = 1e5 * abs(mean) / g(mean)
    z_ss = g(mean) / 1e5 * math.copysign(1.0, mean)
    assert data.act[0] == pytest.approx(z_ss + (z - z_ss) * math.exp(-a * h), rel=1e-12)


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
