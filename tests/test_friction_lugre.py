"""LuGre friction (Canudas de Wit et al. 1995) in the plant: its closed forms, the paper's
stick-slip and presliding experiments against Radau integrations written here, and the hybrid
model's stick-slip period against LuGre's."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import maniplab as ml

# Table I of the 1995 paper (Canudas de Wit et al., IEEE TAC 1995); the static level Fs is coulomb + static
SIGMA0, SIGMA1, SIGMA2 = 1e5, math.sqrt(1e5), 0.4
FC, FS, VS, MASS = 1.0, 1.5, 1e-3, 1.0
K, VP, T_END = 2.0, 0.1, 20.0
FRICTION = {"coulomb": FC, "static": FS - FC, "viscous": SIGMA2, "stribeck_velocity": VS,
            "sigma0": SIGMA0, "sigma1": SIGMA1}


def block(model: str, **friction: float) -> ml.ManipulatorSpec:
    """The paper's 1 kg block on a horizontal prismatic joint."""
    return ml.ManipulatorSpec.from_dict({
        "name": "block",
        "joints": [{"name": "x", "type": "P", "axis": "x", "body": {"mass": MASS},
                    "friction": {"model": model, **FRICTION, **friction}}],
    })


class Spring:
    """The controller pulling the block through a spring k whose end moves at VP."""

    dt = None  # every step

    def __call__(self, t: float, state: ml.PlantState) -> list[float]:
        return [K * (VP * t - state.q[0])]


def g(v: float) -> float:
    return FC + (FS - FC) * math.exp(-((v / VS) ** 2))


def lugre_rhs(force):
    def rhs(t: float, y: np.ndarray) -> list[float]:
        x, v, z = y
        zd = v - SIGMA0 * abs(v) * z / g(v)
        return [v, (force(t, x) - SIGMA0 * z - SIGMA1 * zd - SIGMA2 * v) / MASS, zd]
    return rhs


@functools.cache
def stick_slip_reference():
    rhs = lugre_rhs(lambda t, x: K * (VP * t - x))
    return solve_ivp(rhs, (0.0, T_END), [0.0, 0.0, 0.0], method="Radau", rtol=1e-10,
                     atol=1e-12, dense_output=True, max_step=1e-2).sol


def slip_onsets(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Times at which the velocity rises through 1 cm/s."""
    up = np.flatnonzero((v[1:] > 0.01) & (v[:-1] <= 0.01))
    return t[up + 1]


def test_stick_slip_matches_radau() -> None:
    run = ml.simulate(block("lugre"), controller=Spring(), duration=T_END)
    ref = stick_slip_reference()(run.t)
    x, v = run.q[:, 0], run.qd[:, 0]
    assert np.ptp(x) > 1.0  # it moved, in jerks
    assert np.max(np.abs(x - ref[0])) < 5e-3
    onsets, expected = slip_onsets(run.t, v), slip_onsets(run.t, ref[1])
    assert len(onsets) == len(expected) == 2
    np.testing.assert_allclose(onsets, expected, atol=0.01)
    assert np.max(np.abs(v - ref[1])) < 0.02 * np.max(ref[1])
    # the bristles: close everywhere except for a step or two when they let go at a slip
    dz = np.abs(run["z"][:, 0] - ref[2]) / np.max(np.abs(ref[2]))
    assert np.percentile(dz, 99) < 0.02 and np.max(dz) < 0.25


def test_presliding_displacement_at_95_percent_of_the_static_force() -> None:
    """A force ramped slowly to 0.95 Fs: the block creeps by the bristles' deflection, about
    (Fs/σ0) ln 20 for a quasi-static ramp, and does not slide."""
    rate = 0.5  # N/s
    t95 = 0.95 * FS / rate
    run = ml.simulate(block("lugre"), inputs={"x": ml.signals.ramp(rate, t1=t95)},
                      duration=t95 + 0.5)
    rhs = lugre_rhs(lambda t, x: rate * min(t, t95))
    ref = solve_ivp(rhs, (0.0, run.t[-1]), [0.0, 0.0, 0.0], method="Radau", rtol=1e-10,
                    atol=1e-14, t_eval=run.t).y
    at = np.argmin(np.abs(run.t - t95))
    assert run.q[at, 0] == pytest.approx(ref[0, at], rel=1e-2)
    assert run.q[at, 0] == pytest.approx(FS / SIGMA0 * math.log(20.0), rel=5e-2)
    assert np.max(np.abs(run.q[:, 0])) < 1e-4  # presliding, not sliding


def test_hybrid_stick_slip_period_is_lugres() -> None:
    hybrid = ml.simulate(block("hybrid"), controller=Spring(), duration=T_END)
    hybrid_onsets = slip_onsets(hybrid.t, hybrid.qd[:, 0])
    lugre_onsets = slip_onsets(hybrid.t, stick_slip_reference()(hybrid.t)[1])
    assert len(hybrid_onsets) == len(lugre_onsets) == 2
    period, lugre_period = np.diff(hybrid_onsets)[0], np.diff(lugre_onsets)[0]
    assert period == pytest.approx(lugre_period, rel=0.10)
    # and the stuck phases really stand still
    stuck = hybrid["mode"][:, 0] == ml.friction.FrictionMode.STICK
    assert stuck.mean() > 0.5 and np.all(hybrid.qd[stuck, 0] == 0.0)
