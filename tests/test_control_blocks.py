"""G1 (against MuJoCo's mj_inverse), the hydraulic drive's domain transformation, G2 (inverts
eq. 4) and the pressure loop (against eq. 4 integrated on its own)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import maniplab as ml
from maniplab.actuators.hydraulic import PressureDrive, PressureLoop, valve_current, valve_flow
from maniplab.control.inverse_dynamics import InverseDynamics
from maniplab.control.tuning import resolve
from maniplab.spec import model_of


@pytest.fixture(scope="module")
def erector() -> ml.ManipulatorSpec:
    return ml.builtin_spec("erector")


@pytest.mark.parametrize("name", ["erector", "planar2", "crane3"])
def test_g1_equals_mj_inverse_plus_viscous_friction(name: str) -> None:
    spec = ml.builtin_spec(name)
    m = ml.build_model(spec)
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    d = mujoco.MjData(m)
    g1 = InverseDynamics(ml.AnalyticModel(spec))
    fv = np.array([j.friction.viscous for j in spec.joints])
    np.testing.assert_array_equal(m.dof_damping, fv)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = np.array([rng.uniform(*(j.limits or (-2.0, 2.0))) for j in spec.joints])
        qd, qdd = rng.normal(size=spec.n), rng.normal(size=spec.n)
        d.qpos[:], d.qvel[:], d.qacc[:] = q, qd, qdd
        mujoco.mj_inverse(m, d)  # the model's joint damping is the viscous friction
        expected = d.qfrc_inverse
        np.testing.assert_allclose(g1.torque(q, qd, qdd), expected,
                                   rtol=1e-9, atol=1e-9 * np.abs(expected).max())


def test_g1_coulomb_feedforward(erector: ml.ManipulatorSpec) -> None:
    am = ml.AnalyticModel(erector)
    plain, with_fc = InverseDynamics(am), InverseDynamics(am, coulomb=True)
    q, qd, qdd = np.zeros(6), np.full(6, 0.01), np.zeros(6)
    ref = np.array([1.0, -1.0, 0.0, 1e-9, 1.0, -1.0])
    fc = np.array([j.friction.coulomb for j in erector.joints])
    vs = np.array([j.friction.stribeck_velocity for j in erector.joints])
    np.testing.assert_allclose(with_fc.torque(q, qd, qdd, ref) - plain.torque(q, qd, qdd),
                               fc * np.tanh(ref / vs))


def test_domain_transformation_divides_by_area() -> None:
    spec = ml.builtin_spec("erector").with_overrides({"joints.q4.actuator": {"type": "torque"}})
    hydraulic = [0, 1, 2, 4, 5]
    drive = PressureDrive([model_of(spec.joints[j]) for j in hydraulic], hydraulic, dt=5e-3,
                          settings=resolve(spec))
    tau = np.arange(1.0, 7.0) * 1e3
    zeros = np.zeros(5)
    drive.command(tau[hydraulic], zeros, zeros, zeros, {"dP": zeros})
    areas = [j.actuator.area for j in spec.joints if j.actuator.type == "hydraulic"]
    np.testing.assert_allclose(drive.log["dP_d"], tau[hydraulic] / areas)
    assert model_of(spec.joints[3]).command_limit is None and drive.limit[0] == 1.0


# --- G2 --------------------------------------------------------------------------------------
def test_valve_inversion_inverts_eq4_exactly_within_limits() -> None:
    rng = np.random.default_rng(8)
    C, Ps, imax = 0.005, 20e6, 1.0
    for _ in range(200):
        dP = rng.uniform(-0.99, 0.99) * Ps
        iv_true = rng.uniform(-imax, imax)
        if 1 - abs(dP) / Ps < 0.05**2:
            continue
        flow = iv_true * C * np.sqrt(1 - abs(dP) / Ps)  # eq. (4), written out here
        iv = valve_current(np.array([flow]), np.array([dP]), C, Ps, imax, orifice=False)
        assert iv[0] == pytest.approx(iv_true, rel=1e-12, abs=1e-15)
        assert valve_flow(iv, dP, C, Ps, orifice=False)[0] == pytest.approx(flow, rel=1e-12,
                                                                              abs=1e-20)


def test_valve_inversion_inverts_the_orifice_law_exactly_within_limits() -> None:
    rng = np.random.default_rng(9)
    C, Ps, imax = 0.005, 20e6, 1.0
    for _ in range(200):
        dP = rng.uniform(-1.5, 1.5) * Ps
        iv_true = rng.uniform(-imax, imax)
        drop = 1 - np.sign(iv_true) * dP / Ps  # the metering edges' pressure drop, over Ps
        if drop < 0.05**2:
            continue
        flow = iv_true * C * np.sqrt(drop)  # Merritt's orifice law, written out here
        iv = valve_current(np.array([flow]), np.array([dP]), C, Ps, imax)
        assert iv[0] == pytest.approx(iv_true, rel=1e-12, abs=1e-15)
        assert valve_flow(iv, dP, C, Ps)[0] == pytest.approx(flow, rel=1e-12, abs=1e-20)


def test_valve_inversion_clips_and_guards_the_root() -> None:
    C, Ps = 0.005, 20e6
    # more flow than the valve passes: clipped at the limit, with the flow's sign
    assert valve_current(np.array([0.01, -0.01]), np.zeros(2), C, Ps, 1.0).tolist() == [1.0, -1.0]
    # at |ΔP| >= Ps the root vanishes: the current stays finite (and clipped)
    iv = valve_current(np.array([1e-6, -1e-6]), np.array([Ps, -2 * Ps]), C, Ps, 1.0,
                       min_root=0.05)
    assert np.all(np.isfinite(iv))
    np.testing.assert_allclose(iv, [1e-6 / (C * 0.05), -1e-6 / (C * 0.05)])
    assert valve_flow(np.array([1.0]), np.array([2 * Ps]), C, Ps)[0] == 0.0


# --- the pressure loop -----------------------------------------------------------------------
def one_joint(**override: float) -> ml.ManipulatorSpec:
    actuator = {"type": "hydraulic", "area": 0.01, "volume": 0.002, "bulk_modulus": 1e9,
                "leakage": 1e-11, "valve_gain": 0.002, "supply_pressure": 20e6, **override}
    return ml.ManipulatorSpec.from_dict({"name": "one", "joints": [
        {"type": "P", "axis": "x", "body": {"length": 1.0, "mass": 100.0}, "actuator": actuator}]})


def loop_of(spec: ml.ManipulatorSpec, **gains: float | bool) -> PressureLoop:
    a = spec.joints[0].actuator
    return PressureLoop([a.area], [a.volume / a.bulk_modulus], [a.leakage], **gains)


def test_pressure_loop_first_sample_by_hand() -> None:
    loop = loop_of(one_joint(), dt=1e-3, bandwidth=50.0, speed_gain=0.5, compressibility=True)
    dP_d, dP, qd, qd_ref = 5e6, 4e6, 0.1, 0.2
    phi = loop.flow([dP_d], [dP], [qd], [qd_ref])[0]
    # A q̇ + Le ΔP + ω V/E (ΔP_d - ΔP) + k_v A (q̇_ref - q̇); no ΔP_d rate on the first sample
    expected = 0.01 * 0.1 + 1e-11 * 4e6 + 50.0 * 0.002 / 1e9 * 1e6 + 0.5 * 0.01 * 0.1
    assert phi == pytest.approx(expected, rel=1e-12)


def test_pressure_error_decays_at_the_loop_bandwidth() -> None:
    # eq. (4)'s pressure equation, the valve taken as ideal (Q = Φ) and the piston moving at a
    # constant speed: the loop cancels the piston flow and leakage, so e(t) = e0 exp(-ω t)
    spec = one_joint()
    a = spec.joints[0].actuator
    dt, omega, v = 1e-4, 30.0, 0.05
    loop = loop_of(spec, dt=dt, bandwidth=omega, compressibility=False)
    dP, target = 0.0, 2e6
    for _ in range(1000):  # 0.1 s
        Q = loop.flow([target], [dP], [v])[0]
        dP += dt * a.bulk_modulus / a.volume * (Q - a.leakage * dP - a.area * v)
    assert (target - dP) == pytest.approx(target * np.exp(-omega * 0.1), rel=0.01)


def test_compressibility_term_tracks_a_pressure_ramp() -> None:
    spec = one_joint(leakage=0.0)
    a = spec.joints[0].actuator
    dt, slope = 1e-4, 5e7  # Pa/s
    results = {}
    for comp in (False, True):
        loop = loop_of(spec, dt=dt, bandwidth=20.0, rate_filter=0.0, compressibility=comp)
        dP = 0.0
        for k in range(2000):
            Q = loop.flow([slope * k * dt], [dP], [0.0])[0]
            dP += dt * a.bulk_modulus / a.volume * Q
        results[comp] = slope * 2000 * dt - dP
    # without it a ramp leaves a lag of slope/ω; with it the lag is one sample's worth
    assert results[False] == pytest.approx(slope / 20.0, rel=0.05)
    assert abs(results[True]) < 0.01 * results[False]
