"""The step an arm needs: computed from its actuators over its workspace, and kept by the plant.

A cylinder far stiffer than a 1 ms step can follow used to freeze silently (the valve fully open,
no flow, the joint still). Now the plant sub-steps what the arm needs, and the same run at a
100 times finer step agrees; where even that would take too long it stops and says which step
works."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import maniplab as ml
from maniplab.mjcf_gen.accuracy import StepWarning
from maniplab.mjcf_gen.builder import arm_step_limit
from maniplab.mjcf_gen.timestep import DEFAULT, OSCILLATION, RATE, default_step
from maniplab.mjcf_gen.workspace import mass_matrices, poses


def two_link(**actuator: float) -> ml.ManipulatorSpec:
    """Two 1 m, 20 kg links about vertical axes, each with a cylinder (second one's overridden)."""
    base = {"type": "hydraulic", "area": 2e-4, "volume": 2e-4, "valve_gain": 2e-4,
            "supply_pressure": 20e6, "valve_tau": 0.01}
    link = {"type": "R", "axis": "z", "limits": [-2.0, 2.0], "body": {"length": 1.0, "mass": 20.0}}
    return ml.ManipulatorSpec.from_dict({"name": "two-link", "joints": [
        {"name": "q1", **link, "actuator": base},
        {"name": "q2", **link, "actuator": {**base, **actuator}}]})


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_the_step_limit_is_the_fastest_spring_mode_over_the_workspace() -> None:
    """An independent search: the eigen-frequencies of the oil springs on M(q) at the sampled
    poses, and the valve's lag."""
    spec = ml.builtin_spec("erector")
    model = ml.build_model(spec)
    k = np.array([j.actuator.area**2 * j.actuator.bulk_modulus / j.actuator.volume
                  for j in spec.joints])
    omega = max(np.sqrt(np.max(np.linalg.eigvals(np.linalg.solve(M, np.diag(k))).real))
                for M in mass_matrices(model, poses(spec, 48)))
    limit = arm_step_limit(spec)
    assert limit.dt == pytest.approx(min(OSCILLATION / omega, RATE * 0.01), rel=1e-9)
    assert model.opt.timestep == default_step(limit) == DEFAULT  # the erector keeps 1 ms
    assert "oil spring mode" in limit.describe()


def test_a_stiff_arm_gets_a_finer_default_step_in_its_mjcf() -> None:
    spec = two_link(volume=1e-6)
    limit = arm_step_limit(spec)
    step = default_step(limit)
    assert step < limit.dt < 2.5 * step and step < DEFAULT
    derived = ml.Plant(spec).dt  # the model carries the plant's step: the accuracy's, if finer
    assert derived <= step and ml.build_model(spec).opt.timestep == derived
    assert f'timestep="{derived!r}"' in ml.to_mjcf(spec)


@pytest.mark.parametrize("actuator", [{"volume": 1e-7},
                                      {"valve_gain": 10.0, "relief_pressure": 22e6}],
                         ids=["tiny-oil-volume", "huge-valve"])
def test_a_stiff_cylinder_moves_as_at_a_hundred_times_finer_step(actuator: dict) -> None:
    """The motion agrees to 1e-2. (The pressures agree less well: the oil spring of 1e-7 m³
    rings undamped at about 3 kHz, which samples 1 ms apart catch at another phase; the huge
    valve's relief, sized for 10 m³/s, switches in and out within a step, a kink in time the
    step resolves only to first order: ΔP and Q agree there to about 5e-2.)"""
    spec = two_link(**actuator)
    plant = ml.Plant(spec, dt=1e-3)
    assert plant.substeps > 1 and plant.model.opt.timestep == pytest.approx(1e-3 / plant.substeps)
    duration = 0.1
    coarse = ml.simulate(plant, inputs={"q2": 0.5}, duration=duration)
    fine = ml.simulate(spec, inputs={"q2": 0.5}, duration=duration, dt=1e-5, sample_dt=1e-3)
    assert abs(fine.q[-1, 1]) > 1e-3  # the joint moves
    for name in ("q", "qd"):
        assert relative(coarse[name][:, 1], fine[name][:, 1]) < 1e-2, name
    assert relative(coarse["dP"][:, 1], fine["dP"][:, 1]) < (5e-2 if "relief_pressure" in actuator
                                                              else 0.5)


def test_a_valve_that_floods_its_cylinder_stops_the_run_and_says_why() -> None:
    """At the derived step the arm is refused before it runs (its pressures would need a step
    of microseconds to be accurate); at a step given explicitly the run stops when the flooded
    cylinder's pressure runs away, naming the joint and the missing relief."""
    spec = two_link(valve_gain=10.0)
    with pytest.raises(ml.InstabilityError, match=r"joint q\d's \w+ needs dt <= "):
        ml.Plant(spec)
    with pytest.warns(StepWarning), pytest.raises(ml.InstabilityError) as caught:
        ml.simulate(spec, inputs={"q2": 0.5}, duration=0.1, dt=1e-3)
    message = str(caught.value)
    assert "joint q2" in message and "relief_pressure" in message
    assert "smaller step" not in message  # the step resolves the arm: the model is at fault


def test_a_step_that_would_need_too_many_substeps_is_refused_with_one_that_works() -> None:
    spec = two_link(volume=4e-9)
    with pytest.raises(ml.InstabilityError) as caught:
        ml.Plant(spec, dt=1e-2)
    message = str(caught.value)
    assert "joint q2" in message and "oil spring mode" in message and "use dt <=" in message
    works = float(message.split("use dt <= ")[1].split(" ")[0])
    assert ml.Plant(spec, dt=works).substeps <= 1000


def test_substeps_change_nothing_in_an_arm_that_needs_none() -> None:
    plant = ml.Plant("erector", dt=2e-3)
    assert plant.substeps == 2
    a = ml.simulate(plant, inputs={"q2": 0.3}, duration=0.1)
    b = ml.simulate("erector", inputs={"q2": 0.3}, duration=0.1, sample_dt=2e-3)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
    assert mujoco.mjtIntegrator.mjINT_RK4 == plant.model.opt.integrator
