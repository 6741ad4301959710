"""Hybrid stick/slip friction and the joint-limit automaton in the plant, against statics,
closed forms and the analytic model's constrained (stuck-joint) dynamics."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import maniplab as ml
from maniplab.friction import FrictionMode

STICK, SLIP = FrictionMode.STICK, FrictionMode.SLIP
AT_LOWER, AT_UPPER = FrictionMode.AT_LOWER, FrictionMode.AT_UPPER


def slider(friction: dict, *, mass: float = 10.0, limits: list[float] | None = None,
           actuator: dict | None = None) -> ml.ManipulatorSpec:
    """A horizontal prismatic joint (gravity across it) driven by a force source."""
    joint = {"name": "x", "type": "P", "axis": "x", "body": {"mass": mass},
             "actuator": actuator or {"type": "torque"}, "friction": friction}
    if limits:
        joint["limits"] = limits
    return ml.ManipulatorSpec.from_dict({"name": "slider", "joints": [joint]})


HYBRID = {"model": "hybrid", "coulomb": 20.0, "static": 10.0, "stribeck_velocity": 0.01,
          "viscous": 5.0, "stick_velocity": 1e-3}


def test_breakaway_under_a_slow_force_ramp() -> None:
    """A stuck joint starts moving when the applied force crosses Fc + Fs = 30 N."""
    rate = 5.0  # N/s: 0.005 N per step, 0.02 % of the break-away force
    run = ml.simulate(slider(HYBRID), inputs={"x": ml.signals.ramp(rate)}, duration=7.0)
    moving = np.flatnonzero(run["mode"][:, 0] == SLIP)
    first = moving[0]
    assert run.q[first - 1, 0] == 0.0 and np.all(run.q[:first, 0] == 0.0)
    assert run["ctrl"][first, 0] == pytest.approx(30.0, rel=1e-2)
    assert np.all(run["mode"][first:, 0] == SLIP) and run.q[-1, 0] > 0.0
    # while stuck, stiction holds exactly the applied force (statics)
    stuck = slice(1, first - 2)
    np.testing.assert_allclose(run["tau_fric"][stuck, 0],
                               -(run["ctrl"][stuck, 0]), rtol=1e-9, atol=1e-9)


def test_stiction_holds_a_joint_against_gravity() -> None:
    """A 2 kg, 1 m rod held horizontal by stiction (gravity torque 9.81 N·m < Fc + Fs = 12)."""
    spec = ml.ManipulatorSpec.from_dict({
        "name": "rod", "gravity": [0.0, -9.81, 0.0],
        "joints": [{"name": "q", "type": "R", "axis": "z", "body": {"length": 1.0, "mass": 2.0},
                    "friction": {"model": "hybrid", "coulomb": 10.0, "static": 2.0}}],
    })
    run = ml.simulate(spec, duration=10.0, sample_dt=0.01)
    assert np.max(np.abs(run.q[:, 0] - run.q[0, 0])) < 1e-6
    assert np.all(run["mode"][:, 0] == STICK)
    np.testing.assert_allclose(run["tau_fric"][:, 0], 2.0 * 9.81 * 0.5, rtol=1e-9)


def test_a_slipping_joint_stops_as_coulomb_friction_says() -> None:
    """Sliding at v0 against Coulomb friction alone: it stops after m v0 / Fc, having travelled
    m v0² / (2 Fc), and sticks there."""
    mass, v0, fc = 10.0, 0.5, 20.0
    friction = {"model": "hybrid", "coulomb": fc, "static": 0.0, "stick_velocity": 1e-3}
    run = ml.simulate(slider(friction, mass=mass), initial={"qd": [v0]}, duration=0.5)
    stop = np.flatnonzero(run["mode"][:, 0] == STICK)[0]
    assert run.t[stop] == pytest.approx(mass * v0 / fc, abs=2e-3)
    assert run.q[-1, 0] == pytest.approx(mass * v0**2 / (2 * fc), rel=1e-3)
    assert np.all(run.qd[stop:, 0] == 0.0)


def test_limits_hold_and_release() -> None:
    """Pushed at 5 N into its upper limit the joint stays on it, the stop pushing back 5 N; pulled
    back at 5 N after 1 s it leaves."""
    spec = slider({"model": "none"}, limits=[-0.1, 0.05])
    push = ml.signals.step(5.0) - ml.signals.step(10.0, t0=1.0)
    run = ml.simulate(spec, inputs={"x": push}, duration=1.2)
    q, mode = run.q[:, 0], run["mode"][:, 0]
    assert np.all(q <= 0.05) and np.all(q >= -0.1)
    at_stop = (run.t > 0.46) & (run.t < 0.999)
    assert np.all(mode[at_stop] == AT_UPPER) and np.all(q[at_stop] == 0.05)
    np.testing.assert_allclose(run["tau_limit"][at_stop, 0], -5.0, rtol=1e-9)
    assert mode[-1] == SLIP and q[-1] < 0.05
    # free flight before the stop: x = F t² / (2 m)
    reach = np.sqrt(2 * 10.0 * 0.05 / 5.0)
    first = np.flatnonzero(mode == AT_UPPER)[0]
    assert run.t[first] == pytest.approx(reach, abs=2e-3)
    # after release at once (the joint's own force reversed): x = 0.05 - F (t - 1)² / (2 m)
    late = run.t > 1.0
    np.testing.assert_allclose(q[late], 0.05 - 5.0 * (run.t[late] - 1.0) ** 2 / 20.0,
                               atol=1e-12)


def test_a_joint_with_stiction_at_a_limit_releases_into_stick() -> None:
    """Leaving the stop is a release into STICK; it slips only when the pull exceeds Fc + Fs."""
    spec = slider(HYBRID, limits=[-0.1, 0.0])
    pull = ml.signals.step(50.0) - ml.signals.step(70.0, t0=0.5) - ml.signals.step(20.0, t0=1.0)
    run = ml.simulate(spec, inputs={"x": pull}, duration=1.3)
    mode, t = run["mode"][:, 0], run.t
    assert np.all(mode[(t > 0.01) & (t < 0.5)] == AT_UPPER)
    assert np.all(mode[(t > 0.51) & (t < 1.0)] == STICK)  # pulled by 20 N < 30 N
    assert np.all(run.q[t < 1.0, 0] == 0.0)
    assert mode[-1] == SLIP and run.q[-1, 0] < 0.0


def test_erector_stuck_joint_stays_put_while_the_others_move() -> None:
    """Valve steps on q1, q3 and q4; q2 stays stuck while q1 swings the arm around it."""
    inputs = {"q1": ml.signals.step(0.3, t0=0.1), "q3": ml.signals.step(0.2, t0=0.1),
              "q4": ml.signals.step(0.2, t0=0.1)}
    spec = ml.builtin_spec("erector").with_overrides({"joints.q2.friction.static": 3e5})
    run = ml.simulate(spec, inputs=inputs, duration=1.5, initial={"dP": "gravity"})
    assert np.all(run.q[:, 1] == 0.0) and np.all(run["mode"][:, 1] == STICK)
    assert np.ptp(run.q[:, 0]) > 0.05 and np.ptp(run.q[:, 2]) > 0.01
    assert np.max(np.abs(run["tau_fric"][:, 1])) > 1e4  # it takes real force to hold it


@pytest.mark.parametrize("stuck", [[1], [1, 3]])
def test_stuck_joints_follow_the_constrained_dynamics(stuck) -> None:
    """The free joints move as M_FF q̈_F = τ_F - b_F (with q̇_S = 0) and the stiction holds
    M_SF q̈_F + b_S - τ_S: AnalyticModel.constrained_dynamics (derived independently of MuJoCo),
    integrated by scipy, is the reference."""
    names = [f"q{i + 1}" for i in range(6)]
    overrides = {f"joints.{j}.actuator": {"type": "torque"} for j in names}
    overrides |= {f"joints.{j}.friction": {"model": "none"} for j in names}
    overrides |= {f"joints.{j}.limits": None for j in names}
    for i in stuck:
        overrides[f"joints.{names[i]}.friction"] = {"model": "hybrid", "coulomb": 1e9}
    spec = ml.builtin_spec("erector").with_overrides(overrides)
    torque = np.array([4e4, 1e3, 5e3, 2e3, 500.0, 300.0])
    q0 = np.array([0.2, -0.3, 0.4, 0.1, 0.05, -0.1])
    run = ml.simulate(spec, inputs=dict(zip(names, torque)), duration=0.3, initial={"q": q0})
    assert np.all(run.q[:, stuck] == q0[stuck])

    model = ml.AnalyticModel(spec)
    free = [i for i in range(6) if i not in stuck]

    def rhs(_t: float, y: np.ndarray) -> np.ndarray:
        q, qd = q0.copy(), np.zeros(6)
        q[free], qd[free] = y[: len(free)], y[len(free):]
        qdd = model.constrained_dynamics(q, qd, torque, stuck)[0]
        return np.concatenate([qd[free], qdd[free]])

    y0 = np.concatenate([q0[free], np.zeros(len(free))])
    ref = solve_ivp(rhs, (0.0, 0.3), y0, method="DOP853", rtol=1e-11, atol=1e-13, t_eval=run.t)
    np.testing.assert_allclose(run.q[:, free], ref.y[: len(free)].T, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(run.qd[:, free], ref.y[len(free):].T, rtol=1e-5, atol=1e-8)
    for k in (0, 150, 298):  # the step's holding force: the average of its ends' (trapezoid)
        ends = [model.constrained_dynamics(run.q[i], run.qd[i], torque, stuck)[1]
                for i in (k, k + 1)]
        np.testing.assert_allclose(run["tau_fric"][k, stuck], (0.5 * (ends[0] + ends[1]))[stuck],
                                   rtol=1e-4)


def erector_creep(dt: float, duration: float = 2.5) -> ml.Run:
    """The erector with a 5 t segment, q2's valve opened to 0.2 A at 0.1 s and the other valves
    closed: q2 lifts slowly, and q1 and q3 (closed cylinders, stiff oil springs coupled through
    the arm's inertia, 2.6 to 67 Hz) creep by stick-slip with holding forces within a few per
    cent of their break-away forces."""
    return ml.simulate("erector", inputs={"q2": ml.signals.step(0.2, t0=0.1)}, duration=duration,
                       initial={"dP": "gravity"}, dt=dt, sample_dt=1e-3,
                       overrides={"end_effector.mass": 5000.0,
                                  "joints.q2.actuator.leakage": 1e-11})


def test_hybrid_friction_converges_at_the_default_step() -> None:
    """The default step (1 ms) gives the stick-slip creep of a ten times finer step: q1's motion,
    how long it sticks, and where q2 ends."""
    coarse, fine = erector_creep(1e-3), erector_creep(1e-4)
    late = fine.t > 1.25
    ptp = [np.ptp(run.q[late, 0]) for run in (coarse, fine)]
    assert ptp[0] == pytest.approx(ptp[1], rel=0.2)
    assert coarse.q[-1, 1] == pytest.approx(fine.q[-1, 1], rel=0.01)
    stuck = [np.mean(run["mode"][:, 0] == STICK) for run in (coarse, fine)]
    assert stuck[1] > 0.3  # q1 does stick and slip
    assert stuck[0] == pytest.approx(stuck[1], rel=0.2)


def erector_to_the_stops() -> ml.Run:
    """Valve steps that swing q1 and q3 and drive q4 and q6 onto their upper stops, q4 back."""
    s = ml.signals
    inputs = {"q1": s.step(0.3, t0=0.1) - s.step(0.6, t0=0.8), "q3": s.step(-0.3, t0=0.2),
              "q4": s.step(1.0, t0=0.1) - s.step(2.0, t0=0.9), "q6": s.step(1.0, t0=0.1)}
    return ml.simulate("erector", inputs=inputs, duration=1.5, initial={"dP": "gravity"})


@pytest.mark.parametrize("case", ["creep", "stops"])
def test_held_joints_obey_the_constrained_dynamics_at_every_step(case) -> None:
    """At every sample, with the held joints those whose mode is STICK, AT_LOWER or AT_UPPER, the
    force that holds them (the analytic model's constrained dynamics under the recorded actuator
    and slip-friction forces) is within stiction's break-away force, and a stop only pushes:
    transitions of neighbours are taken into account in the same step, not one step late."""
    if case == "creep":
        run, payload = erector_creep(1e-3, duration=1.0), 5000.0
    else:
        run, payload = erector_to_the_stops(), 4000.0
    spec = ml.builtin_spec("erector").with_overrides({"end_effector.mass": payload})
    model = ml.AnalyticModel(spec)
    breakaway = np.array([j.friction.coulomb + j.friction.static for j in spec.joints])
    mode = run["mode"]
    held = mode != SLIP
    if case == "stops":
        assert np.any(mode[:, 3] == AT_UPPER) and np.any(mode[:, 5] == AT_UPPER)
        assert mode[-1, 3] == SLIP  # q4 left its stop
    tau = run["tau_act"] + np.where(held, 0.0, run["tau_fric"])  # slip friction incl. viscous
    checked = 0
    for pattern in np.unique(held, axis=0):
        if not pattern.any():
            continue
        rows = np.flatnonzero((held == pattern).all(axis=1))
        hold = model.constrained_dynamics(run.q[rows], run.qd[rows], tau[rows], pattern)[1]
        m = mode[rows]
        stuck = m == STICK
        limit = np.broadcast_to(breakaway * (1.0 + 1e-6) + 1e-3, m.shape)
        assert np.all(np.abs(hold[stuck]) <= limit[stuck])
        assert np.all(hold[m == AT_UPPER] <= 1e-3) and np.all(hold[m == AT_LOWER] >= -1e-3)
        checked += int(held[rows].sum())
    assert checked > 1000
