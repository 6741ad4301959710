"""The hydraulic cylinder of eq. (4) in the plant (its engine plugin, integrated by MuJoCo's RK4),
against closed forms and an independent integration of the same ODEs (scipy's Radau)."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import maniplab as ml


def cylinder_joint(**hydraulic: float) -> dict:
    """A prismatic joint along x (gravity along -z: no load) with a hydraulic actuator."""
    params = {"type": "hydraulic", "area": 1e-3, "volume": 1e-3, "bulk_modulus": 1.4e9,
              "leakage": 1e-11, "valve_gain": 1e-4, "valve_tau": 0.01,
              "supply_pressure": 1e15, **hydraulic}
    return {"name": "piston", "type": "P", "axis": "x", "body": {"mass": 100.0},
            "actuator": params}


def held_piston(**hydraulic: float) -> ml.ManipulatorSpec:
    """The piston held by stiction far above any pressure force."""
    joint = cylinder_joint(**hydraulic)
    joint["friction"] = {"model": "hybrid", "coulomb": 1e13, "static": 0.0}
    return ml.ManipulatorSpec.from_dict({"name": "held", "joints": [joint]})


def test_pressure_of_a_held_piston_under_constant_flow() -> None:
    """ΔP(t) = (Q/Le)(1 - exp(-Le E t / V)) (docs/guide/hydraulics.md, "Typical values"), with Q constant: the valve starts at
    its steady flow i_v C and the supply pressure is so high that sqrt(1 - |ΔP|/Ps) = 1."""
    iv, C, Le, E, V = 0.5, 1e-4, 1e-11, 1.4e9, 1e-3
    Q = iv * C
    run = ml.simulate(held_piston(), inputs={"piston": iv}, duration=0.3,
                      initial={"Q": [Q]})
    exact = Q / Le * (1.0 - np.exp(-Le * E * run.t / V))
    assert np.all(run.q == 0.0) and np.all(run["mode"] == ml.friction.FrictionMode.STICK)
    np.testing.assert_allclose(run["dP"][1:, 0], exact[1:], rtol=1e-3)
    np.testing.assert_allclose(run["Q"][:, 0], Q, rtol=1e-8)
    # stiction holds exactly the pressure force, averaged over each step
    mean_force = 1e-3 * 0.5 * (run["dP"][:-1, 0] + run["dP"][1:, 0])
    np.testing.assert_allclose(run["tau_fric"][:-1, 0], -mean_force, rtol=1e-2)


def test_valve_lag() -> None:
    """Q(t) = i_v C (1 - exp(-t/τ)) while |ΔP| << Ps."""
    iv, C, tau = 0.8, 1e-4, 0.01
    run = ml.simulate(held_piston(), inputs={"piston": iv}, duration=0.05)
    np.testing.assert_allclose(run["Q"][:, 0], iv * C * (1.0 - np.exp(-run.t / tau)),
                               rtol=1e-3, atol=1e-12)
    np.testing.assert_array_equal(run["iv"][:, 0], iv)


def test_valve_current_is_clipped_at_the_limit() -> None:
    run = ml.simulate(held_piston(current_limit=0.2), inputs={"piston": 3.0}, duration=0.01)
    assert np.all(run["iv"][:, 0] == 0.2) and np.all(run["ctrl"][:, 0] == 0.2)


# --- a 1-DOF hydraulic lift against Radau ------------------------------------------------------

M, G, A, V, E, LE, CV, TAU, PS, FV = 500.0, 9.81, 2e-3, 1e-3, 1.4e9, 1e-12, 1e-3, 0.01, 20e6, 2e3
IV, T_STEP, T_END = 0.2, 0.05, 1.0

LIFT = ml.ManipulatorSpec.from_dict({
    "name": "lift", "gravity": [0.0, 0.0, -G],
    "joints": [{"name": "lift", "type": "P", "axis": "z", "body": {"mass": M},
                "actuator": {"type": "hydraulic", "area": A, "volume": V, "bulk_modulus": E,
                             "leakage": LE, "valve_gain": CV, "valve_tau": TAU,
                             "supply_pressure": PS},
                "friction": {"model": "hybrid", "viscous": FV}}],
})


@functools.cache
def _lift_solution() -> tuple:
    """Radau solution of the lift, from rest with ΔP holding the weight; the valve opens at
    T_STEP (integrated in two pieces, so the step is not smeared)."""

    def rhs(_t: float, y: np.ndarray, iv: float) -> list[float]:
        _x, v, p, q = y
        return [v, (A * p - M * G - FV * v) / M, E / V * (q - LE * p - A * v),
                (CV * iv * np.sqrt(max(0.0, 1.0 - abs(p) / PS)) - q) / TAU]

    opts = {"method": "Radau", "rtol": 1e-10, "atol": [1e-13, 1e-13, 1e-5, 1e-15],
            "dense_output": True}
    before = solve_ivp(rhs, (0.0, T_STEP), [0.0, 0.0, M * G / A, 0.0], args=(0.0,), **opts)
    after = solve_ivp(rhs, (T_STEP, T_END), before.y[:, -1], args=(IV,), **opts)
    return before.sol, after.sol


def lift_reference(t: np.ndarray) -> np.ndarray:
    """The reference at times t: rows x, v, ΔP, Q."""
    before, after = _lift_solution()
    return np.where(t <= T_STEP, before(np.minimum(t, T_STEP)), after(np.maximum(t, T_STEP)))


@pytest.mark.parametrize("dt", [1e-3, 2e-4])
def test_lift_matches_radau(dt) -> None:
    run = ml.simulate(LIFT, inputs={"lift": ml.signals.step(IV, t0=T_STEP)}, duration=T_END,
                      dt=dt, initial={"dP": "gravity"}, sample_dt=dt)
    x, _, p, q = lift_reference(run.t)
    assert x[-1] > 0.05  # it lifts
    assert np.max(np.abs(run.q[:, 0] - x)) < 1e-3 * np.max(np.abs(x))
    assert np.max(np.abs(run["dP"][:, 0] - p)) < 1e-3 * np.max(np.abs(p))
    assert np.max(np.abs(run["Q"][:, 0] - q)) < 1e-3 * np.max(np.abs(q))


def test_plant_is_fourth_order() -> None:
    """MuJoCo's RK4 integrates eq. (4) (the engine plugin) with the arm: halving dt divides the
    pressure error by about 16 (the accuracy figures of the hydraulics guide)."""
    errors = []
    for dt in (2e-3, 1e-3):
        run = ml.simulate(LIFT, inputs={"lift": ml.signals.step(IV, t0=T_STEP)}, duration=0.4,
                          dt=dt, initial={"dP": "gravity"}, sample_dt=dt)
        p = lift_reference(run.t)[2]
        errors.append(np.max(np.abs(run["dP"][:, 0] - p)) / np.max(np.abs(p)))
    assert errors[1] < 2e-5
    assert 10.0 < errors[0] / errors[1] < 20.0


def test_balance_pressures_holds_the_arm() -> None:
    plant = ml.Plant(LIFT.with_overrides({"joints.lift.actuator.leakage": 0.0}))
    plant.balance_pressures()
    assert plant.states()["dP"][0] == pytest.approx(M * G / A, rel=1e-12)
    run = ml.simulate(plant, duration=0.2)
    assert np.max(np.abs(run.q)) < 1e-12


def test_leakage_lets_a_held_load_sink() -> None:
    """With the valve closed the load sinks at the leakage flow: v = -Le ΔP / A, ΔP = m g / A
    (once the oscillation the start excites has died down)."""
    run = ml.simulate(LIFT, duration=2.0, initial={"dP": "gravity"})
    sink = (run.q[-1, 0] - run.q[1000, 0]) / (run.t[-1] - run.t[1000])
    assert sink == pytest.approx(-LE * M * G / A**2, rel=5e-3)


def test_an_absurdly_stiff_cylinder_is_refused_with_joint_and_advice() -> None:
    """A cylinder of 1e-12 m³: its oil spring needs a step far below what a run can afford (it
    used to diverge a few steps into the run; the plant now knows the step the arm needs)."""
    spec = LIFT.with_overrides({"joints.lift.actuator.volume": 1e-12})
    with pytest.raises(ml.InstabilityError) as caught:
        ml.simulate(spec, inputs={"lift": 1.0}, duration=0.5)
    error = caught.value
    assert error.joint == "lift" and error.time == 0.0
    assert "needs dt <=" in str(error) and "check that actuator's parameters" in str(error)
