"""The valve law in C (maniplab_native/valve.h) against the frozen Python law it replaced
(tests/reference/valve_law.py): equal to 1e-15 relative over many random points, both laws, both
signs, zero current, the root vanishing, the relief open and closed; the cylinder's derivatives,
steady state and Jacobians likewise; and the engine plugin's rates are the same C code."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from reference import valve_law as ref

import maniplab as ml
from maniplab.actuators.hydraulic import valve
from maniplab.spec import model_of

PS = 20e6
RTOL = 1e-15


def points(rng: np.random.Generator, count: int) -> list[tuple[float, float, float, float]]:
    """(current A, ΔP Pa, gain m³/(s·A), Ps Pa): random, plus zero currents and pressures where
    the root vanishes (|ΔP| = Ps exactly and beyond) or nearly does."""
    out = []
    for k in range(count):
        ps = float(rng.uniform(5e6, 35e6))
        current = float(rng.uniform(-1.5, 1.5)) if k % 7 else 0.0
        kind = k % 5
        dP = {0: ps, 1: -ps, 2: float(rng.uniform(-2.5, 2.5)) * ps,
              3: ps * (1.0 - 1e-13), 4: float(rng.uniform(-1.0, 1.0)) * ps}[kind]
        out.append((current, dP, float(rng.uniform(1e-5, 1e-2)), ps))
    return out


def close(actual: float, expected: float, rtol: float = RTOL) -> bool:
    return actual == expected or abs(actual - expected) <= rtol * abs(expected)


@pytest.mark.parametrize("orifice", [True, False])
def test_root_flow_and_slopes_equal_the_frozen_law(orifice: bool) -> None:
    rng = np.random.default_rng(1 + orifice)
    vanished = 0
    for current, dP, gain, ps in points(rng, 3000):
        inv = 1.0 / ps
        r = valve.root(current, dP, inv, orifice)
        assert close(r, ref.root(current, dP, inv, orifice)), (current, dP)
        assert close(valve.flow(current, dP, gain, inv, orifice),
                     ref.flow(current, dP, gain, inv, orifice)), (current, dP)
        for got, want in zip(valve.slopes(current, dP, gain, inv, orifice),
                             ref.slopes(current, dP, gain, inv, orifice)):
            assert close(got, want), (current, dP)
        vanished += r == 0.0
    assert vanished > 300  # the root's zero is well covered


@pytest.mark.parametrize("orifice", [True, False])
def test_the_valve_inversion_equals_the_frozen_g2(orifice: bool) -> None:
    rng = np.random.default_rng(3 + orifice)
    rows = points(rng, 2000)
    gains = np.array([r[2] for r in rows])
    supply = np.array([r[3] for r in rows])
    dP = np.array([r[1] for r in rows])
    flow = rng.uniform(-1.0, 1.0, len(rows)) * gains * rng.choice([0.0, 0.01, 1.0, 3.0], len(rows))
    limit = rng.uniform(0.2, 2.0, len(rows))
    for min_root in (0.05, 0.0, 0.5):
        got = valve.valve_current(flow, dP, gains, supply, limit, min_root=min_root,
                                  orifice=orifice)
        with np.errstate(divide="ignore", invalid="ignore"):  # min_root 0: 1/0 where r = 0
            want = ref.valve_current(flow, dP, gains, supply, limit, min_root=min_root,
                                     orifice=orifice)
        np.testing.assert_allclose(got, want, rtol=RTOL, atol=0.0)
        assert np.any(np.abs(got) == limit) and np.any(np.abs(got) < limit)  # clipped and not
    currents = rng.uniform(-1.5, 1.5, len(rows))
    np.testing.assert_allclose(valve.valve_flow(currents, dP, gains, supply, orifice=orifice),
                               ref.valve_flow(currents, dP, gains, supply, orifice=orifice),
                               rtol=RTOL, atol=0.0)


def test_vectorised_helpers_broadcast_like_the_frozen_ones() -> None:
    dP = np.array([[0.0], [0.5 * PS], [-PS]])
    law = np.array([True, False])
    np.testing.assert_array_equal(valve.valve_flow(0.4, dP, 1e-3, PS, orifice=law),
                                  ref.valve_flow(0.4, dP, 1e-3, PS, orifice=law))
    got = valve.valve_current(np.array([2e-4, -2e-4]), dP, 1e-3, PS, 1.0, orifice=law)
    assert got.shape == (3, 2)
    np.testing.assert_array_equal(got, ref.valve_current(np.array([2e-4, -2e-4]), dP, 1e-3, PS,
                                                         1.0, orifice=law))
    nan = valve.valve_current(np.array([np.nan]), np.zeros(1), 1e-3, PS, 1.0)
    assert np.isnan(nan).all()  # a NaN flow is not clipped into a number


def test_relief_flow_equals_the_frozen_one() -> None:
    rng = np.random.default_rng(5)
    for _ in range(2000):
        setting = float(rng.uniform(10e6, 40e6))
        dP = float(rng.uniform(-1.05, 1.05)) * setting * rng.choice([1.0, 1.0, 0.5])
        gain = float(rng.uniform(1e-10, 1e-8))
        assert close(valve.relief_flow(dP, setting, gain), ref.relief_flow(dP, setting, gain))
    assert valve.relief_flow(0.99 * PS, PS, 1e-9) == 0.0
    assert valve.relief_flow(-1.01 * PS, PS, 1e-9) < 0.0


def cylinder(law: str, relief: float | None) -> ml.actuators.HydraulicCylinder:
    actuator = {"type": "hydraulic", "area": 2e-3, "volume": 3e-3, "bulk_modulus": 1.2e9,
                "leakage": 2e-12, "valve_gain": 1.5e-3, "valve_tau": 0.012,
                "supply_pressure": PS, "current_limit": 0.8, "valve_law": law}
    if relief is not None:
        actuator["relief_pressure"] = relief
    spec = ml.ManipulatorSpec.from_dict({"name": "lift", "joints": [
        {"name": "lift", "type": "P", "axis": "z", "limits": [-3.0, 0.5], "body": {"mass": 50.0},
         "actuator": actuator}]})
    return model_of(spec.joints[0])


CYLINDERS = [("orifice", None), ("paper", None), ("orifice", 18e6), ("paper", 18e6)]


@pytest.mark.parametrize(("law", "relief"), CYLINDERS)
def test_cylinder_rates_steady_and_jacobians_equal_the_frozen_ones(law: str,
                                                                   relief: float | None) -> None:
    a = cylinder(law, relief)
    p = a.params
    rng = np.random.default_rng(7)
    relieving = 0
    for k in range(1500):
        x = np.array([float(rng.uniform(-1.3, 1.3)) * PS, float(rng.uniform(-2e-3, 2e-3))])
        u = float(rng.uniform(-0.8, 0.8)) if k % 9 else 0.0
        v = float(rng.uniform(-1.0, 1.0))
        got, want = a.derivatives(x, u, 0.0, v), ref.derivatives(p, x, u, 0.0, v)
        # the C law sums eq. (4)'s terms in the plugin's order: round-off of the largest term
        terms = p.bulk_modulus / p.volume * (abs(x[1]) + p.leakage * abs(x[0]) + p.area * abs(v)
                                             + abs(ref.relief_flow(x[0], relief or math.inf,
                                                                   p.relief_gain)))
        assert abs(got[0] - want[0]) <= 4 * RTOL * terms
        assert close(got[1], want[1], 4 * RTOL)
        jac, jref = a.jacobians(x, u, 0.0, v), ref.jacobians(p, x, u, 0.0, v)
        for name in ("dxdot_dx", "dxdot_du", "dxdot_dv"):
            np.testing.assert_allclose(getattr(jac, name), jref[name], rtol=4 * RTOL, atol=0.0)
        force = float(rng.uniform(-1.2, 1.2)) * PS * p.area
        (dP, Q), iv = a.steady(force, 0.0, v)
        (dP0, Q0), iv0 = ref.steady(p, force, 0.0, v)
        assert (dP, Q) == (dP0, Q0) and close(iv, iv0), (force, v)
        relieving += relief is not None and abs(x[0]) > relief
    assert relief is None or relieving > 100


@pytest.mark.parametrize(("law", "relief"), CYLINDERS)
def test_the_engine_plugin_runs_the_same_rates(law: str, relief: float | None) -> None:
    """MuJoCo's act_dot from the plugin equals the actuator model's derivatives bit for bit with
    the relief closed (the plugin takes an open relief after the step instead)."""
    a = cylinder(law, relief)
    spec = ml.ManipulatorSpec.from_dict({"name": "lift", "joints": [
        {"name": "lift", "type": "P", "axis": "z", "limits": [-3.0, 0.5], "body": {"mass": 50.0},
         "actuator": {"type": "hydraulic", **{k: getattr(a.params, k) for k in (
             "area", "volume", "bulk_modulus", "leakage", "valve_gain", "valve_tau",
             "supply_pressure", "current_limit", "valve_law", "relief_pressure")
             if getattr(a.params, k) is not None}}}]})
    m = ml.build_model(spec)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(11)
    for _ in range(200):
        d.act[:] = [float(rng.uniform(-0.95, 0.95)) * (relief or PS), float(rng.uniform(-1e-3, 1e-3))]
        d.qvel[:] = rng.uniform(-0.5, 0.5)
        d.ctrl[:] = rng.uniform(-0.8, 0.8)
        mujoco.mj_forward(m, d)
        want = a.derivatives(d.act, float(d.ctrl[0]), float(d.qpos[0]), float(d.qvel[0]))
        np.testing.assert_array_equal(d.act_dot, want)
