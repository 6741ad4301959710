"""The actuators' maps a controller of your own computes with (``ml.ActuatorMaps``), on built-in
and corpus arms of every actuator type, each against something independent: MuJoCo's actuator
moments, the spec's closed forms, and the actuator's own equations at the state it returns."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

import maniplab as ml

ARMS = Path(__file__).parent / "arms"
HYDRAULIC = ["erector", "patu655", "excavator", str(ARMS / "loader_crane.yaml"),
             str(ARMS / "gantry.yaml")]


def poses(spec: ml.ManipulatorSpec, count: int = 3) -> np.ndarray:
    rng = np.random.default_rng(7)
    lo = np.array([j.limits[0] if j.limits else -1.0 for j in spec.joints])
    hi = np.array([j.limits[1] if j.limits else 1.0 for j in spec.joints])
    return lo + (hi - lo) * rng.uniform(0.2, 0.8, (count, spec.n))


@pytest.mark.parametrize("arm", ["patu655", "excavator", "erector_pinned"])
def test_moment_arms_equal_mujocos_actuator_moments(arm: str) -> None:
    spec = ml.resolve_spec(arm)
    maps = ml.ActuatorMaps(spec)
    model = ml.build_model(spec)
    data = mujoco.MjData(model)
    pinned = np.isfinite(maps.chamber_areas[:, 0])
    assert pinned.any()
    for q in poses(spec):
        data.qpos[:spec.n] = q
        mujoco.mj_forward(model, data)
        moment = np.zeros((model.nu, model.nv))
        mujoco.mju_sparse2dense(moment, data.actuator_moment, data.moment_rownnz,
                                data.moment_rowadr, data.moment_colind)
        r = maps.moment_arms(q)
        np.testing.assert_allclose(r[pinned], np.diag(moment)[:spec.n][pinned], rtol=1e-12)
        assert np.isnan(r[~pinned]).all()


def test_chamber_areas_are_the_bore_and_the_annulus() -> None:
    spec = ml.builtin_spec("patu655")
    areas = ml.ActuatorMaps(spec).chamber_areas
    for j, joint in enumerate(spec.joints):
        cylinder = getattr(joint.actuator, "cylinder", None)
        if cylinder is None:
            assert np.isnan(areas[j]).all()
            continue
        np.testing.assert_allclose(areas[j], [math.pi / 4 * cylinder.bore**2,
                                              math.pi / 4 * (cylinder.bore**2 - cylinder.rod**2)])


@pytest.mark.parametrize("arm", ["erector", str(ARMS / "gantry.yaml"), "planar2"])
def test_limits_and_top_speeds_of_lumped_and_torque_joints(arm: str) -> None:
    """Lumped cylinder: no-load speed C i_max / A (eq. 4 at ΔP = 0, steady); torque: none."""
    spec = ml.resolve_spec(arm)
    maps = ml.ActuatorMaps(spec)
    for j, joint in enumerate(spec.joints):
        a = joint.actuator
        if a.type == "torque":
            assert maps.command_limits[j] == (a.limit or math.inf)
            assert maps.top_speeds[j] == math.inf
        else:
            assert maps.command_limits[j] == a.current_limit
            assert maps.top_speeds[j] == pytest.approx(a.valve_gain * a.current_limit / a.area,
                                                       rel=1e-12)


@pytest.mark.parametrize("arm", HYDRAULIC)
def test_the_valve_inversion_holds_the_force_steadily(arm: str) -> None:
    """At the commanded state the actuator's own law has zero derivatives and exerts tau."""
    spec = ml.resolve_spec(arm)
    maps = ml.ActuatorMaps(spec)
    q = poses(spec, 1)[0]
    speeds = 0.05 * np.minimum(maps.top_speeds, 1.0)
    tau = np.array([1e3 * (j + 1) for j in range(spec.n)])
    u = maps.commands(tau, q, speeds)
    assert np.isfinite(u).all() and (np.abs(u) <= maps.command_limits).all()
    for j, a in enumerate(maps.actuators):
        x = a.steady(tau[j], q[j], speeds[j]).x
        np.testing.assert_allclose(a.force(x, u[j], q[j], speeds[j]), tau[j], rtol=1e-6)
        rates = a.derivatives(x, u[j], q[j], speeds[j])
        scale = np.maximum(np.abs(x), 1.0) * max(a.rates().values() or [1.0])
        assert (np.abs(rates) <= 1e-6 * scale).all(), (j, rates)


@pytest.mark.parametrize("arm", HYDRAULIC)
def test_torque_to_pressure_and_back(arm: str) -> None:
    spec = ml.resolve_spec(arm)
    maps = ml.ActuatorMaps(spec)
    q = poses(spec, 4)
    tau = np.linspace(-5e3, 8e3, q.size).reshape(q.shape)
    states = maps.holding_states(tau, q)
    np.testing.assert_allclose(maps.forces(states, q), tau, rtol=1e-9, atol=1e-6)
    if "dP" in states:  # a lumped cylinder's ΔP = tau / A (eq. 4's force law)
        for j, joint in enumerate(spec.joints):
            if joint.actuator.type == "hydraulic" and getattr(joint.actuator, "area", None):
                np.testing.assert_allclose(states["dP"][:, j], tau[:, j] / joint.actuator.area)


def test_the_maps_are_vectorised_over_samples() -> None:
    maps = ml.ActuatorMaps("patu655")
    q = poses(maps.spec, 5)
    tau = np.full_like(q, 2e3)
    together = maps.commands(tau, q, np.zeros_like(q))
    one_by_one = np.array([maps.commands(t, x, np.zeros(3)) for t, x in zip(tau, q)])
    np.testing.assert_array_equal(together, one_by_one)
    assert maps.moment_arms(q).shape == q.shape
