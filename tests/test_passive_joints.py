"""Passive joints and hanging tools (issue 39): a pendulum on a cart against its closed forms and
plain MuJoCo, the arm's M, C, G against Pinocchio, the pose a tool hangs in, and the cascade on a
forestry crane with a hanging grapple, with and without its sway damping."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

import maniplab as ml
from maniplab.control.errors import ControlError
from maniplab.control.move import run_move
from maniplab.control.shaping import zvd
from maniplab.control.suspended import hanging, pendulum_frequency, suspended
from maniplab.model import AnalyticModel

GRAPPLE = Path(__file__).parent / "arms" / "grapple_crane.yaml"
G, L, CART, BOB = 9.81, 1.5, 10.0, 5.0


def cart_pendulum(force_limit: float = 500.0) -> ml.ManipulatorSpec:
    """A 10 kg cart on a rail (a force source) with a 1.5 m pendulum of 5 kg hanging from it
    on a passive joint (its rod all but massless)."""
    return ml.ManipulatorSpec.from_dict({
        "name": "cart-pendulum", "gravity": [0.0, 0.0, -G],
        "joints": [
            {"name": "cart", "type": "P", "axis": "x", "limits": [-50.0, 50.0],
             "body": {"mass": CART}, "actuator": {"type": "torque", "limit": force_limit}},
            {"name": "swing", "type": "R", "axis": "y",
             "body": {"length": L, "direction": [0, 0, -1], "mass": 1e-6},
             "actuator": {"type": "passive"}}],
        "end_effector": {"mass": BOB}})


def crossings(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The times x(t) crosses zero (linear between samples)."""
    k = np.flatnonzero(np.diff(np.sign(x)) != 0)
    return t[k] - x[k] * (t[k + 1] - t[k]) / (x[k + 1] - x[k])


def test_a_pendulum_on_a_free_cart_swings_at_its_closed_form_period() -> None:
    """Released at 0.02 rad with the cart free, the pair swings at the small-angle period
    2π sqrt(L M / ((M + m) g)) (the cart recoils), to 1e-4."""
    run = ml.simulate(cart_pendulum(), duration=8.0, dt=1e-4, initial={"q": [0.0, 0.02]},
                      sample_dt=1e-3)
    period = 2.0 * np.mean(np.diff(crossings(run.t, run.q[:, 1])))
    expected = 2.0 * math.pi * math.sqrt(L * CART / ((CART + BOB) * G))
    assert period == pytest.approx(expected, rel=1e-4)


def test_a_pendulum_on_an_accelerating_cart_leans_and_swings_as_its_closed_form() -> None:
    """A constant 5 N on the cart from rest: the pair accelerates at a = F/(M + m), the pendulum
    leans back by θ0 = atan(a/g) (its mean over whole periods, to 1e-3) and swings about it at
    ω² = g_eff (M + m) / (L (M + m sin²θ0)), g_eff = sqrt(g² + a²) (the Lagrangian linearised
    about the lean; to 1e-3)."""
    force = 5.0
    run = ml.simulate(cart_pendulum(), duration=8.0, dt=1e-4, inputs={"cart": force},
                      sample_dt=1e-3)
    a = force / (CART + BOB)
    lean = math.atan2(a, G)
    angle = run.q[:, 1]
    times = crossings(run.t, angle - lean)  # a positive angle about y is the bob behind
    period = 2.0 * np.mean(np.diff(times))
    omega2 = math.hypot(G, a) * (CART + BOB) / (L * (CART + BOB * math.sin(lean) ** 2))
    assert period == pytest.approx(2.0 * math.pi / math.sqrt(omega2), rel=1e-3)
    end = times[-1] if len(times) % 2 else times[-2]  # whole periods: crossings the same way
    whole = (run.t >= times[0]) & (run.t < end)
    assert np.mean(angle[whole]) == pytest.approx(lean, rel=1e-3)


def test_the_plant_is_plain_mujoco_of_the_exported_model() -> None:
    """A passive joint is a zero-gain motor in the exported MJCF: plain MuJoCo stepping the
    exported model with the cart's force (and any command on the passive joint, which does
    nothing) ends where the plant does, to 1e-9."""
    spec = cart_pendulum()
    model = mujoco.MjModel.from_xml_string(ml.to_mjcf(spec))
    data = mujoco.MjData(model)
    data.qpos[:] = [0.0, 0.3]
    data.ctrl[:] = [40.0, 123.0]
    steps = round(1.3 / model.opt.timestep)
    for _ in range(steps):
        mujoco.mj_step(model, data)
    run = ml.simulate(spec, duration=steps * model.opt.timestep, dt=model.opt.timestep,
                      initial={"q": [0.0, 0.3]}, inputs={"cart": 40.0, "swing": 123.0})
    np.testing.assert_allclose(run.q[-1], data.qpos, atol=1e-9)
    assert abs(data.qpos[1] - 0.3) > 0.03  # it swung


@pytest.mark.parametrize("seed", [0, 1])
def test_m_c_g_of_an_arm_with_passive_joints_are_pinocchios(seed: int) -> None:
    """The grapple crane (three actuated joints, a universal joint of two passive ones): M, C q̇
    and G at random poses against Pinocchio on its URDF, to 1e-9 of their scale."""
    pin = pytest.importorskip("pinocchio")
    from test_urdf import pinocchio_model, pinocchio_q

    spec = ml.load_spec(GRAPPLE)
    model, pmodel = AnalyticModel(spec), pinocchio_model(spec)
    pdata = pmodel.createData()
    rng = np.random.default_rng(seed)
    low = np.array([j.limits[0] for j in spec.joints])
    high = np.array([j.limits[1] for j in spec.joints])
    q, qd = rng.uniform(low, high), rng.normal(size=spec.n)
    pq = pinocchio_q(pmodel, q)
    M = pin.crba(pmodel, pdata, pq)
    M = np.triu(M) + np.triu(M, 1).T
    G_ref = pin.computeGeneralizedGravity(pmodel, pdata, pq)
    bias = pin.rnea(pmodel, pdata, pq, qd, np.zeros(spec.n))
    scale = np.abs(M).max()
    np.testing.assert_allclose(model.M(q), M, atol=1e-9 * scale)
    np.testing.assert_allclose(model.G(q), G_ref, atol=1e-9 * np.abs(G_ref).max())
    np.testing.assert_allclose(model.C(q, qd) @ qd + model.G(q), bias,
                               atol=1e-9 * np.abs(bias).max())


def test_the_tool_hangs_where_its_gravity_torques_vanish() -> None:
    """At the hanging pose the passive joints carry no gravity torque (to 1e-7 of the hanging
    weight's moment) and it is stable: the swing is the negative of boom plus jib (all about
    y)."""
    spec = ml.load_spec(GRAPPLE)
    q = hanging(spec, [0.4, -0.3, 1.2, 0.7, -0.5])
    G_passive = AnalyticModel(spec).G(q)[3:]
    hanging_mass = suspended(spec).end_effector.mass
    assert np.abs(G_passive).max() < 1e-7 * hanging_mass * G * 1.3  # its weight's moment
    assert q[3] == pytest.approx(-(-0.3 + 1.2), abs=1e-6) and q[4] == pytest.approx(0.0, abs=1e-6)
    assert pendulum_frequency(spec, q) > 0.0


def test_the_zvd_shaper_has_its_closed_form() -> None:
    """Undamped: impulses 1/4, 1/2, 1/4 at 0, T/2 and T; damped (ζ = 0.1): (1, 2K, K²)/(1+K)²
    with K = exp(-ζπ/sqrt(1-ζ²)) at the damped period's halves."""
    flat = lambda impulses: [x for pair in impulses for x in pair]
    assert flat(zvd(2.0)) == pytest.approx([0.0, 0.25, math.pi / 2, 0.5, math.pi, 0.25])
    k = math.exp(-0.1 * math.pi / math.sqrt(0.99))
    period = 2 * math.pi / (2.0 * math.sqrt(0.99))
    expected = ((0.0, 1 / (1 + k) ** 2), (period / 2, 2 * k / (1 + k) ** 2),
                (period, k * k / (1 + k) ** 2))
    assert flat(zvd(2.0, 0.1)) == pytest.approx(flat(expected))


@functools.cache
def slew(damped: bool) -> object:
    spec = ml.load_spec(GRAPPLE)
    target = AnalyticModel(suspended(spec)).fk([1.2, -0.3, 1.2])[:3, 3]
    return run_move(spec, list(target), start=[0.0, -0.3, 1.2, 0.0, 0.0], duration=3.0,
                    settle=6.0, sway_damping=damped)


@pytest.mark.parametrize("damped", [False, True])
def test_the_cascade_slews_the_crane_with_its_grapple_hanging(damped: bool) -> None:
    """The grapple crane slews 1.2 rad (its suspension point 6 m on a chord): the cascade drives
    the actuated chain (its inertia without the grapple, the grapple's weight as a force at the
    point) and meets the target; the grapple sways after the move by more than 3° (not settled
    within 1° in 6 s) unless the move is shaped, which leaves less than 0.5°, settled at once.
    Measured: 7.6° and 0.3°."""
    result = slew(damped)
    assert result.health.verdict == "ok"
    assert result.metrics.final_error_mm < 2.0
    worst = max(s.amplitude for s in result.sway)
    if damped:
        assert worst < math.radians(0.5) and all(s.settling == 0.0 for s in result.sway)
        assert result.plan.move.duration > slew(False).plan.move.duration + 2.0  # one period
    else:
        assert worst > math.radians(3.0) and max(s.settling for s in result.sway) == math.inf


def test_a_passive_joint_inside_the_chain_is_refused_in_one_line() -> None:
    data = ml.load_spec(GRAPPLE).to_dict()
    data["joints"][1]["actuator"] = {"type": "passive"}
    spec = ml.ManipulatorSpec.from_dict(data)
    with pytest.raises(ControlError, match="joint boom is passive") as err:
        run_move(spec, [4.0, 0.0, 2.0], start=None, duration=3.0)
    assert "\n" not in str(err.value)


def test_the_load_chart_rates_a_hanging_tool_at_its_suspension_point() -> None:
    """The grapple crane's chart is its actuated chain's at the suspension point, less the
    hanging links' 64 kg: the same payloads as a chart of that chain with the links counted as
    its own (a rigid 64 kg body at the point), at the same poses."""
    spec = ml.load_spec(GRAPPLE)
    chart = ml.load_chart(spec, points=4)
    chain = suspended(spec)
    rigid = ml.load_chart(chain, points=4)  # its payload includes the links' 64 kg
    np.testing.assert_allclose(chart.q, rigid.q)
    np.testing.assert_allclose(chart.payload, np.maximum(rigid.payload - 64.0, 0.0), rtol=1e-12)
    assert chart.spec.name == spec.name and chart.q.shape[1] == 3
