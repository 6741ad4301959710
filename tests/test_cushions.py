"""End cushions (issue 35): over the last ``length`` of the stroke the leaving oil passes a
throttle that brakes the piston, against the quasi-steady closed form of the documented law; the
energy they take; an impact they remove."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import fsolve

import maniplab as ml
from maniplab.errors import SpecError
from maniplab.sim.energy import energy_report
from maniplab.sim.health import impacts

BORE, ROD, STROKE, MIN_LENGTH = 0.063, 0.036, 0.4, 0.6
A_A = math.pi / 4.0 * BORE**2
A_B = math.pi / 4.0 * (BORE**2 - ROD**2)
PS, PT = 10.0e6, 0.0
VALVE = {"nominal_flow": 3.0e-4, "nominal_pressure_drop": 35.0e5, "tau": 0.005}
CUSHION = {"length": 0.05, "nominal_flow": 2.0e-5, "nominal_pressure_drop": 1.0e6}
MASS = 20.0


def slide(cushions: dict | None) -> ml.ManipulatorSpec:
    """A 20 kg carriage on a horizontal slide, pushed by an inline cylinder (s = q + 0.6 m)."""
    cylinder = {"pins": {"parent": [-MIN_LENGTH, 0.0, 0.0], "child": [0.0, 0.0, 0.0]},
                "bore": BORE, "rod": ROD, "min_length": MIN_LENGTH, "stroke": STROKE,
                "dead_volumes": [5e-5, 5e-5]}
    if cushions is not None:
        cylinder["cushions"] = cushions
    return ml.ManipulatorSpec.from_dict({
        "name": "slide", "gravity": [0.0, 0.0, -9.81],
        "joints": [{"name": "x", "type": "P", "axis": "x", "limits": [0.0, STROKE],
                    "body": {"mass": MASS},
                    "actuator": {"type": "hydraulic", "cylinder": cylinder, "valve": VALVE,
                                 "supply_pressure": PS, "tank_pressure": PT},
                    "friction": {"model": "none"}}]})


def quasi_steady_speed(distance: float) -> float:
    """The piston's speed (m/s) at `distance` from the extended end with the valve wide open and
    no load: the documented law (hydraulics page) written here: P->A and B->T orifices of gain
    K = Q_n / sqrt(drop per edge), laminar below 5 % of it; within the cushion B->T in series
    with the throttle K_c / (1 - d/l); force balance pA A_A = pB A_B."""
    drop = VALVE["nominal_pressure_drop"] / 2.0
    k, laminar = VALVE["nominal_flow"] / math.sqrt(drop), 0.05 * drop
    kc = CUSHION["nominal_flow"] / math.sqrt(CUSHION["nominal_pressure_drop"])
    share = max(0.0, 1.0 - distance / CUSHION["length"])
    out = k / math.sqrt(1.0 + (k * share / kc) ** 2)

    def g(dp: float) -> float:
        return dp / (dp * dp + laminar**2) ** 0.25

    def balance(z: np.ndarray) -> list[float]:
        pa, v = z[0] * 1e6, z[1]
        pb = pa * A_A / A_B
        return [(k * g(PS - pa) - A_A * v) * 1e4, (out * g(pb - PT) - A_B * v) * 1e4]

    _, v = fsolve(balance, [1.0, 0.1], xtol=1e-12)
    return float(v)


def test_a_cushion_brakes_the_piston_to_its_closed_form_speed() -> None:
    """The carriage driven at full opening into the extended end: before the cushion it runs at
    the valve's speed, within it (past the entry's deceleration) at the quasi-steady speed the
    throttle allows at each distance (measured: within 0.2 %), down to the closed form's speed
    at the very end, a fifth of the free speed or less."""
    run = ml.simulate(slide(CUSHION), duration=3.0, inputs={"x": 1.0},
                      initial={"q": [0.1]}, sample_dt=1e-3)
    q, v = run.q[:, 0], run.qd[:, 0]
    distance = STROKE - q
    # past the entry's deceleration (the carriage's inertia: 2 % off over the first 10 mm)
    inside = (distance < 0.7 * CUSHION["length"]) & (distance > 0.002) & (v > 0.0)
    assert inside.sum() > 50
    expected = np.array([quasi_steady_speed(d) for d in distance[inside]])
    np.testing.assert_allclose(v[inside], expected, rtol=5e-3)
    free = (distance > 1.5 * CUSHION["length"]) & (run.t > 0.2)
    assert v[free].mean() == pytest.approx(quasi_steady_speed(1.0), rel=0.01)
    assert quasi_steady_speed(0.0) < 0.2 * quasi_steady_speed(1.0)
    report = energy_report(run)
    assert report.total("cushion") > 0.0
    assert abs(report.residual) < 1e-9 * report.pump


def test_the_cushion_takes_the_impact_a_bare_cylinder_reports() -> None:
    """Without cushions the carriage hits its stop with more than a 0.1 J rating (0.4 J); with
    them it arrives slowly enough that no impact is reported."""
    over = {"joints.x.stop_energy": 0.1}
    bare = ml.simulate(slide(None), duration=3.0, inputs={"x": 1.0}, initial={"q": [0.1]},
                       overrides=over)
    cushioned = ml.simulate(slide(CUSHION), duration=3.0, inputs={"x": 1.0},
                            initial={"q": [0.1]}, overrides=over)
    ((_, _, _, energy),) = impacts(bare)
    assert energy > 0.1 and [f for f in bare.health.findings if f.check == "impact"]
    assert not [f for f in cushioned.health.findings if f.check == "impact"]
    hits = impacts(cushioned)
    assert all(e < 0.1 for *_, e in hits)


def test_a_cushion_longer_than_the_stroke_is_one_line() -> None:
    with pytest.raises(SpecError, match="cushion") as err:
        ml.Plant(slide({**CUSHION, "length": 0.5}))
    assert "\n" not in str(err.value)
