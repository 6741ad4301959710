"""The size of ``ml.identify``'s confidence intervals, checked both ways against a Monte Carlo.

``tests/test_identify.py`` asks that the truth lies inside the 95 % intervals, which intervals
inflated several times also pass. Here the reported standard deviations are compared with the
spread of the same least-squares estimate over independent noise draws: the experiment is
simulated once per draw with the noise of ``identify_data`` (seeds 0..N-1), and each draw is
fitted by a Gauss-Newton iteration written in this file (plain ``ml.simulate``, the parameters
and the initial q and ΔP free, each signal divided by its noise σ). The spread of those fits is
what the interval should describe: the reported standard deviation must lie within a factor
1/1.5..1.5 of it (its sampling error with N = 30 draws is about 13 %), and the reported 95 %
interval must cover about 95 % of the draws, not all of them at several widths.
"""

from __future__ import annotations

import numpy as np
from identify_data import NOISE, synthetic

import maniplab as ml
from maniplab.identification import Experiment, identify

S = ml.signals

BOOM = ml.ManipulatorSpec.from_dict({
    "name": "boom1", "gravity": [0.0, 0.0, -9.81],
    "joints": [{"name": "luff", "type": "R", "axis": "y", "limits": [-1.3, 0.3],
                "body": {"length": 3.0, "direction": [1, 0, 0], "mass": 143.7},
                "actuator": {"type": "hydraulic", "area": 0.00236, "volume": 0.0012,
                             "bulk_modulus": 1.0e9, "leakage": 1.0e-12, "valve_gain": 0.0009,
                             "valve_tau": 0.005, "supply_pressure": 8.0e6, "current_limit": 1.0},
                "friction": {"model": "hybrid", "coulomb": 0.0, "static": 0.0,
                             "viscous": 30.0}}],
    "end_effector": {"mass": 100.0}})
"""crane3's luff boom alone, with viscous friction only: a smooth cost, cheap to simulate."""

TRUTH = {"end_effector.mass": 130.0, "joints.luff.actuator.leakage": 3e-12}
INPUTS = {"luff": S.sine(0.3, 0.3, t0=0.2)}
START = [-0.3]
DURATION = 1.0
DRAWS = 30
FIRST_GUESS = {"end_effector.mass": 131.0, "joints.luff.actuator.leakage": 3.03e-12}
BOUNDS = ["end_effector.mass[120:140]", "joints.luff.actuator.leakage[2.7e-12:3.3e-12]"]
"""identify starts 1 % off the truth, within bounds that hold it by more than 15 standard
deviations: its grid scan and its profile walks stay short (``test_identify.py`` fits from far),
and no interval is cut by a bound."""


def _simulate(values: np.ndarray, q0: float, dP0: float, t: np.ndarray,
              commands: np.ndarray) -> np.ndarray:
    """q and ΔP at the times t, each divided by its noise σ, for parameter values and a start."""
    spec = BOOM.with_overrides({p: float(v) for p, v in zip(TRUTH, values)})
    run = ml.simulate(spec, inputs={"luff": S.held(t, commands)}, duration=float(t[-1]),
                      initial={"q": [q0], "dP": [dP0]}, sample_dt=float(t[1] - t[0]),
                      progress=False)
    return np.concatenate([np.interp(t, run.t, run["q"][:, 0]) / NOISE["q"],
                           np.interp(t, run.t, run["dP"][:, 0]) / NOISE["dP"]])


def _fit(data: Experiment, start: np.ndarray, J: np.ndarray, iterations: int = 2) -> np.ndarray:
    """Gauss-Newton on the weighted residuals, from ``start`` = (values..., q0, dP0), with the
    Jacobian J (of the columns scaled as ``_scales``) taken once at the truth."""
    measured = np.concatenate([data.measured[("q", "luff")] / NOISE["q"],
                               data.measured[("dP", "luff")] / NOISE["dP"]])
    x = start.copy()
    for _ in range(iterations):
        r = _simulate(x[:-2], x[-2], x[-1], data.t, data.inputs["luff"]) - measured
        x = x - _scales() * np.linalg.lstsq(J, r, rcond=None)[0]
    return x


def _scales() -> np.ndarray:
    """The finite-difference step of each unknown: 1 % of each parameter, the noise of q0, ΔP0."""
    return np.array([0.01 * v for v in TRUTH.values()] + [NOISE["q"], NOISE["dP"]])


def test_reported_standard_deviations_match_a_monte_carlo_of_the_fit() -> None:
    draws = [synthetic(BOOM, TRUTH, INPUTS, START, DURATION, seed=k) for k in range(DRAWS)]
    clean = ml.simulate(BOOM.with_overrides(TRUTH), inputs={"luff": S.held(
        draws[0].t, draws[0].inputs["luff"])}, duration=DURATION,
        initial={"q": START, "dP": "gravity"}, sample_dt=float(draws[0].t[1]), progress=False)
    truth = np.array([*TRUTH.values(), START[0], float(clean["dP"][0, 0])])
    base = _simulate(truth[:-2], truth[-2], truth[-1], draws[0].t, draws[0].inputs["luff"])
    steps = _scales()
    J = np.column_stack([
        (_simulate(x[:-2], x[-2], x[-1], draws[0].t, draws[0].inputs["luff"]) - base) / 1.0
        for x in (truth + h * e for h, e in zip(steps, np.eye(len(truth))))])
    fits = np.array([_fit(d, truth, J) for d in draws])[:, :len(TRUTH)]
    spread = fits.std(axis=0, ddof=1)

    result = identify(BOOM.with_overrides(FIRST_GUESS), [draws[0]], BOUNDS, progress=False,
                      workers=2)
    # the Monte Carlo fits the same estimate: on draw 0 both land on the same minimum
    assert np.all(np.abs(result.values - fits[0]) < 0.05 * result.std), (result.values, fits[0])
    # measured: std / spread = 0.85 (payload) and 0.97 (leakage); 90 and 93 % of draws inside
    ratio = result.std / spread
    assert np.all((ratio > 1 / 1.5) & (ratio < 1.5)), (result.std, spread)
    inside = np.abs(fits - np.array(list(TRUTH.values()))) <= 1.96 * result.std
    assert np.all(inside.mean(axis=0) >= 0.8), inside.mean(axis=0)
    assert not result.warnings
