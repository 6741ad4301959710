"""The valve laws and the relief valve in the plant: a 2 t load on a vertical cylinder, lowered.

The orifice law (the default) brakes a lowered load: the oscillation the start excites dies out,
the load sinks at the speed the law gives in closed form, and the valve takes energy out (the
lumped model's energy balance, written out here, closes). The paper's eq. (4) lets the same
oscillation grow (its negative damping). A relief valve caps the pressure at its setting."""

from __future__ import annotations

import math

import numpy as np
import pytest

import maniplab as ml

M, G, A, V, E, LE, C, TAU, PS = 2000.0, 9.81, 2e-3, 2e-3, 1.4e9, 1e-12, 1e-3, 0.01, 20e6
IV = -0.6  # A: lowering


def lift(law: str = "orifice", **extra: float) -> ml.ManipulatorSpec:
    actuator = {"type": "hydraulic", "area": A, "volume": V, "bulk_modulus": E, "leakage": LE,
                "valve_gain": C, "valve_tau": TAU, "supply_pressure": PS, "valve_law": law,
                **extra}
    return ml.ManipulatorSpec.from_dict({"name": "lift", "joints": [
        {"name": "lift", "type": "P", "axis": "z", "limits": [-3.0, 0.5], "body": {"mass": M},
         "actuator": actuator}]})


def lowered(law: str) -> ml.Run:
    return ml.simulate(lift(law), inputs={"lift": ml.signals.step(IV, t0=0.1)}, duration=2.0,
                       initial={"dP": "gravity"})


def swing(run: ml.Run, t0: float, t1: float) -> float:
    window = (run.t > t0) & (run.t < t1)
    return float(np.ptp(run["dP"][window, 0]))


def test_orifice_law_lowers_at_its_closed_form_speed() -> None:
    run = lowered("orifice")
    hold = M * G / A  # the pressure that carries the load
    # steady lowering: A v = Q* - Le ΔP with Q* = i C sqrt(1 + ΔP/Ps) (the load adds to the drop)
    speed = (IV * C * math.sqrt(1.0 + hold / PS) - LE * hold) / A
    last = run.t > 1.5  # the mean over the last half second: the start's ringing has died out
    assert np.mean(run.qd[last, 0]) == pytest.approx(speed, rel=1e-4)
    assert np.mean(run["dP"][last, 0]) == pytest.approx(hold, rel=1e-3)
    assert swing(run, 1.5, 2.0) < 0.01 * swing(run, 0.1, 0.6)  # the start's oscillation dies out


def test_paper_law_lets_the_lowering_oscillation_grow() -> None:
    run = lowered("paper")
    assert swing(run, 1.5, 2.0) > swing(run, 0.1, 0.6) > PS  # negative damping
    assert np.max(np.abs(run["dP"])) > 1.5 * PS  # and nothing bounds the pressure


def test_the_valve_takes_energy_out_of_a_lowered_load() -> None:
    """E = ½ m v² + m g x + ½ (V/E) ΔP² changes by ∫(ΔP Q - Le ΔP²) dt (no friction): the valve's
    power ΔP Q is negative while the load goes down, which is the energy it dissipates."""
    run = lowered("orifice")
    x, v, dP, Q = run.q[:, 0], run.qd[:, 0], run["dP"][:, 0], run["Q"][:, 0]
    energy = 0.5 * M * v**2 + M * G * x + 0.5 * V / E * dP**2
    power = dP * Q - LE * dP**2
    supplied = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(run.t))])
    scale = M * G * abs(x[-1] - x[0])
    np.testing.assert_allclose(energy - energy[0], supplied, atol=2e-3 * scale)
    moving = run.t > 0.2
    assert np.trapezoid(dP[moving] * Q[moving], run.t[moving]) < -0.9 * M * G * abs(
        x[-1] - x[moving][0])


def test_relief_caps_the_pressure_of_a_cylinder_driven_into_its_stop() -> None:
    relief = 15e6
    run = ml.simulate(lift("orifice", relief_pressure=relief), inputs={"lift": 1.0},
                      duration=2.0, initial={"dP": "gravity"})
    assert run["mode"][-1, 0] == ml.friction.FrictionMode.AT_UPPER  # on its stop
    assert np.max(run["dP"]) <= 1.01 * relief  # never above the relief's override
    assert run["dP"][-1, 0] == pytest.approx(relief, rel=0.01)  # blowing off at its setting
    without = ml.simulate(lift("orifice"), inputs={"lift": 1.0}, duration=2.0,
                          initial={"dP": "gravity"})
    assert without["dP"][-1, 0] == pytest.approx(PS, rel=0.02)  # the valve alone: up to Ps
