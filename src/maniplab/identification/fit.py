"""Fit spec parameters to measured experiments: the plant simulated under the measured inputs.

For parameter values θ, each experiment is simulated from its measured initial state (q, and q̇
and the pressures when measured; otherwise at rest with the pressures that hold the arm) under
its measured commands, held between samples; the residuals are simulated minus measured at the
measured times, each signal divided by its scale. scipy's trust-region reflective least squares
(bounds, any loss) then moves θ in search variables x: a positive parameter (start > 0, lower
bound >= 0: flows, friction, leakage, masses) as x = log(value/start), so that a start ten times
too large or too small is equally near and the value stays positive (above
:data:`~.parameters.FLOOR` of its start); any other as x = value/start. The Jacobian is taken by
finite differences, one simulation per parameter, run in parallel threads (the plant's loop runs
in C without the interpreter lock).

The initial state is estimated too: an offset to each measured first value (in units of
:data:`UNIT_SCALES`) joins the parameters, so that the noise of the first samples does not bias
them; the intervals are those of the parameters with the offsets free.

Before an experiment is fitted, its simulation is tested for chaos: when a change of a millionth
of a unit to the initial state moves a simulated signal by more than that signal's noise (joints
chattering in stick/slip, dragged by a neighbour), no values can make the simulation follow the
data, and the fit refuses with one line naming the joint and signal.

Stick/slip makes the cost a staircase with narrow valleys: a joint that
sticks one plant step earlier or later shifts all that follows. So before the local solver, each
parameter is moved to the best of a grid along its axis (±40 % in 2 % steps, the others held),
until no such move lowers the cost.

The fit runs twice: first with each signal divided by a unit scale (:data:`UNIT_SCALES`), then,
from there, with each signal of each joint divided by the spread of its own residuals, so that a
signal's weight is its measured precision.

The covariance of the estimate is 2 s² H⁻¹, s² the residual variance per degree of freedom and H
the Hessian of the cost Σ r²: secants on each axis over which the cost rises by about 9 s²,
correlations from the Gauss-Newton Hessian 2 JᵀJ. Then each parameter's profile is walked (the
cost along its axis, the others held, in steps of half the larger of its secant and Gauss-Newton
standard deviations) until the data reject it: a value is accepted while its cost is within
3.84 s² + 2ρ of the lowest seen, ρ the height of the largest step or spike of the cost near its
accepted values that the valley's curvature does not explain (zero on a smooth valley). Where the
profile reaches further than 1.96 of that axis's own standard deviations, the parameter's
standard deviation is widened by the ratio.

Where the steps are higher than the interval's own 3.84 s² and the walk meets spikes that high
(costs above or below both neighbours), stick/slip has made the simulation follow the parameter
chaotically: a change of a millionth moves when a joint sticks, the fit sits in the narrow valley
of one draw of that chaos, its secants measure that valley and the Jacobian's differences span two
draws, and neither says how well the data place the parameter (intervals of a millionth of the
value, which missed the truth). So the residuals are simulated at 48 values over ±100 of the walk's
standard deviations, each sample is regressed on the parameter (a parabola), and the scatter about
the parabolas along their slope g, of variance τ², is taken as a second noise: the data hold one
draw of it and the fit another, so the parameter's variance grows by 2τ²/|g|² (and the profile's
reach, whose costs are draws of the chaos, does not widen it). All of this is in x. The
confidence intervals are x ± 1.96 of its standard deviation σ_x, mapped to values: start (x ± 1.96
σ_x) on the linear scale, value exp(±1.96 σ_x) on the log scale; the standard deviation reported
in the value's unit is start σ_x, or value σ_x (the first order of the exponential); the
correlation is the covariance's in x.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
from scipy.optimize import least_squares

from maniplab.builtin import resolve_spec
from maniplab.errors import ManiplabError
from maniplab.identification.data import Experiment, load_experiments
from maniplab.identification.parameters import FLOOR, Parameter, parse_parameters
from maniplab.progress import Progress
from maniplab.sim.signals import held
from maniplab.spec import ManipulatorSpec, model_of
from maniplab.workers import Threads

UNIT_SCALES = {"q": 1e-3, "qd": 1e-2, "dP": 1e5, "pA": 1e5, "pB": 1e5, "stroke": 1e-3}
"""The first fit's scale of each signal: 1 mrad (or mm), 0.01 rad/s (or m/s), 1 bar, 1 mm."""

CORRELATED = 0.95
"""|correlation| above which two parameters cannot be told apart from the data."""

FAILED = 1e3
"""The residual (in scales) of a simulation that fails for a parameter set: the fit backs off."""

STEP = 1e-2
"""Relative finite-difference step of the Jacobian (1 % of each parameter's value: of x on the
linear scale, x itself on the log scale): large enough to step over the roughness stick/slip gives
the residuals."""

SCAN_SPAN, SCAN_STEP, SCAN_ROUNDS = 0.4, 0.02, 3
"""The grid of :meth:`_Problem.scan`: ±40 % of each parameter's start in 2 % steps about its
value (on either scale), at most three rounds over the parameters."""

PROFILE_BATCHES = 8
"""A profile walks at most this many batches of 8 steps each way (half a standard deviation in the
first, doubling from batch to batch)."""

CHAOS_SPAN, CHAOS_POINTS = 100.0, 48
"""The scan of :meth:`_Problem.chaos`: 48 values evenly over ±100 of the walk's standard
deviations (the Gauss-Newton ones where stick/slip steps the cost: ±1 % for the payload of an
erector)."""

WIDENED = 1.5
"""A profile that widens an interval by more than this says so in a warning."""

NUDGE = 1e-6
"""The change to the initial state (in :data:`UNIT_SCALES`) by which a fit tests that the
simulation of its data is not chaotic."""

RISE = 9.0
"""The cost rise (in s²) over which the Hessian's secants are taken: three standard deviations."""

CHI2 = 3.84
"""χ² with one degree of freedom at 95 %: the cost rise at the edge of a confidence interval."""


class IdentificationError(ManiplabError):
    """The fit cannot start or cannot be completed: one line saying why."""


@dataclasses.dataclass(frozen=True)
class Identification:
    """A fit's result.

    Attributes:
        parameters: what was fitted.
        values: the fitted values, (p,), in the spec's units.
        std: their standard deviations, (p,).
        correlation: (p, p).
        residual_rms: signal -> RMS of simulated minus measured over the experiments, in the
            signal's unit (rad or m, rad/s or m/s, Pa).
        noise: (signal, joint) -> the spread of that signal's residuals (its weight in the fit).
        warnings: one line each: parameters the data cannot tell apart, or that they hardly move.
        spec: the spec with the fitted values.
        fitted: per experiment, signal key -> the simulated values at the measured times.
        experiments: the data.
        evaluations: simulations run (residuals and Jacobians).
    """

    parameters: tuple[Parameter, ...]
    values: np.ndarray
    std: np.ndarray
    correlation: np.ndarray
    residual_rms: dict[str, float]
    noise: dict[tuple[str, str], float]
    warnings: tuple[str, ...]
    spec: ManipulatorSpec
    fitted: tuple[dict[tuple[str, str], np.ndarray], ...]
    experiments: tuple[Experiment, ...]
    evaluations: int

    @property
    def interval(self) -> np.ndarray:
        """95 % confidence intervals, (p, 2): value ± 1.96 std, or for a parameter searched on
        the log scale value exp(±1.96 std/value) (1.96 standard deviations of log(value))."""
        low, high = self.values - 1.96 * self.std, self.values + 1.96 * self.std
        for i, p in enumerate(self.parameters):
            if p.log_scale and self.values[i] > 0.0:
                spread = math.exp(1.96 * float(self.std[i] / self.values[i]))
                low[i], high[i] = self.values[i] / spread, self.values[i] * spread
        return np.column_stack([low, high])

    def table(self) -> str:
        """The fitted values as a Markdown table."""
        lines = ["| parameter | start | fitted | 95 % interval | ± |", "|---|---|---|---|---|"]
        for p, value, std, (lo, hi) in zip(self.parameters, self.values, self.std, self.interval):
            rel = f"{100 * std / abs(value):.2g} %" if value else "-"
            lines.append(f"| {p.path} | {p.start:.6g} | {value:.6g} | [{lo:.6g}, {hi:.6g}] | "
                         f"{rel} |")
        return "\n".join(lines)

    def report(self) -> str:
        """The table, the residuals and the warnings, as text for a terminal."""
        rms = ", ".join(f"{s} {v:.3g}" for s, v in self.residual_rms.items())
        out = [self.table(), "", f"residual RMS: {rms} ({self.evaluations} simulations)"]
        out += [f"warning: {w}" for w in self.warnings]
        return "\n".join(out)


def identify(spec: ManipulatorSpec | str | os.PathLike[str],
             data: Sequence[Experiment] | Sequence[str | os.PathLike[str]],
             params: Iterable[str | Parameter], *, signals: Iterable[str] | None = None,
             loss: Loss = "linear", max_evaluations: int = 60, workers: int | None = None,
             progress: bool | None = None, dt: float | None = None) -> Identification:
    """Fit ``params`` of ``spec`` to measured experiments.

    Args:
        spec: the arm (spec, file or built-in name): the start of every parameter.
        data: experiments, or files to read them from (CSV or run files, see
            :mod:`~maniplab.identification.data`).
        params: dotted paths (``"joints.q2.friction.coulomb"``, ``"end_effector.mass[0:8000]"``)
            or :class:`Parameter` objects.
        signals: the measured signals to fit (default: all the data has).
        loss: scipy's loss: "linear" (least squares), or "soft_l1", "huber", "cauchy" to limit
            the pull of outliers.
        max_evaluations: residual evaluations per fit stage (each also takes a Jacobian).
        workers: threads for the Jacobian's simulations (default: the cores).
        progress: show progress (None: a bar on a terminal, lines in a log when it lasts).
        dt: the plant's step for every candidate, s (default: the one derived for the start's
            accuracy); a finer one shows how far the plant's discretization moves the values.

    Raises:
        IdentificationError, DataError, SpecError: one line.
    """
    spec = resolve_spec(spec)
    given = [e for e in data if isinstance(e, Experiment)]
    files = [d for d in data if not isinstance(d, Experiment)]
    experiments = tuple(given) + tuple(load_experiments(files, spec, signals))
    if not experiments:
        raise IdentificationError("no data: give one or more experiments (CSV or run files)")
    wanted = list(params)
    texts = [p for p in wanted if not isinstance(p, Parameter)]
    parameters = tuple(p for p in wanted if isinstance(p, Parameter)) + \
        (tuple(parse_parameters(texts, spec)) if texts else ())
    problem = _Problem(spec, parameters, experiments, dt)
    pool = Threads(workers or os.cpu_count() or 1)
    bar = Progress(2 * max_evaluations, f"identify {spec.name}: {len(parameters)} parameters",
                   progress)
    try:
        x = problem.x0()
        for stage in ("unit scales", "measured precision"):
            bar.start(f"fitting with {stage}")
            if stage == "unit scales":
                x = problem.scan(x, pool)
            else:
                problem.reweight(x)
            x = _solve(problem, x, loss, max_evaluations, pool, bar)
            bar.step(f"fitted with {stage}")
        return problem.result(x, pool)
    except BaseException:
        pool.stop()
        raise
    finally:
        pool.shutdown()
        bar.close()


Loss = Literal["linear", "soft_l1", "huber", "cauchy", "arctan"]


def _solve(problem: _Problem, x0: np.ndarray, loss: Loss, budget: int, pool: Threads,
           bar: Progress) -> np.ndarray:
    def fun(x: np.ndarray) -> np.ndarray:
        r = problem.residual_at(x)
        bar.step(f"cost {float(r @ r):.6g} after {problem.evaluations} simulations")
        return r

    def jac(x: np.ndarray) -> np.ndarray:
        return problem.jacobian(x, pool)

    lower, upper = problem.bounds()
    x0 = np.clip(x0, np.nextafter(lower, np.inf), np.nextafter(upper, -np.inf))
    result = least_squares(fun, x0, jac=jac, bounds=(lower, upper), method="trf", loss=loss,
                           x_scale="jac", max_nfev=budget, ftol=1e-10, xtol=1e-10, gtol=1e-10)
    return np.asarray(result.x)


class _Problem:
    """The residual function of a fit: search variables x (each parameter's value over its start,
    or its logarithm: module docstring; then the initial-state offsets) -> weighted residuals."""

    def __init__(self, spec: ManipulatorSpec, parameters: tuple[Parameter, ...],
                 experiments: tuple[Experiment, ...], dt: float | None = None) -> None:
        self.spec, self.parameters, self.experiments = spec, parameters, experiments
        self.dt = dt
        self.log = np.array([p.log_scale for p in parameters], dtype=bool)
        self.starts = np.array([p.start for p in parameters], dtype=float)
        self.keys = [sorted(e.measured, key=_order) for e in experiments]
        self.scales = [{k: UNIT_SCALES[k[0]] for k in keys} for keys in self.keys]
        self.evaluations = 0
        self.size = sum(len(e.t) * len(keys) for e, keys in zip(experiments, self.keys))
        # the initial state is estimated too: an offset to each measured first value
        self.offsets = [(i, k) for i, keys in enumerate(self.keys) for k in keys]
        self.dimension = len(parameters) + len(self.offsets)
        self._last: tuple[np.ndarray, np.ndarray] | None = None
        start = self.simulate(self.x0())
        if start is None:
            raise IdentificationError(f"the plant of {spec.name} fails to simulate the data with "
                                      "the starting values (see the message above)")
        self._last = (self.x0(), self._residual(start))
        self.check_predictable(start)

    def check_predictable(self, sims: list[dict[tuple[str, str], np.ndarray]]) -> None:
        """Refuse experiments whose simulation is chaotic: when a change of
        :data:`NUDGE` of each measured first value's unit moves a simulated signal by more than
        the measurement's own spread, no parameter values can make the simulation follow the data
        (joints that chatter in stick/slip, dragged by a neighbour), and a fit would be noise."""
        x = self.x0()
        x[len(self.parameters):] = NUDGE
        nudged = self.simulate(x)
        if nudged is None:
            return
        for e, keys, a, b in zip(self.experiments, self.keys, sims, nudged):
            for k in keys:
                moved = float(np.sqrt(np.mean((a[k] - b[k]) ** 2)))
                noise = float(np.std(np.diff(e.measured[k]))) / math.sqrt(2.0)
                if moved > max(noise, 1e-3 * UNIT_SCALES[k[0]]):
                    unit = "Pa" if k[0] in ("dP", "pA", "pB") else "rad or m"
                    raise IdentificationError(
                        f"{e.name}: joint {k[1]}'s {k[0]} is chaotic under these inputs: a change "
                        f"of 1e-6 of a unit to the initial state moves it by {moved:.3g} {unit} "
                        f"RMS, more than its noise ({noise:.3g}): no values can make the "
                        "simulation follow it; use inputs under which every joint slides or "
                        "stays put")

    def x0(self) -> np.ndarray:
        """The start: every parameter at its spec value (x = 1, or 0 on the log scale), no
        initial-state offset."""
        return np.concatenate([np.where(self.log, 0.0, 1.0), np.zeros(len(self.offsets))])

    def values(self, x: np.ndarray) -> np.ndarray:
        """The parameters' values at x: start x, or start exp(x) on the log scale."""
        z = np.asarray(x[:len(self.parameters)], dtype=float)
        grown = np.exp(np.minimum(np.where(self.log, z, 0.0), 700.0))  # 700: a finite overflow
        return np.where(self.log, grown, z) * self.starts

    def deviations(self, x: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        """Standard deviations ``sigma`` of x as the values' (to first order): start σ, or
        value σ on the log scale."""
        return np.where(self.log, np.abs(self.values(x)), np.abs(self.starts)) * sigma

    def magnitudes(self, x: np.ndarray) -> np.ndarray:
        """|x|, and 1 on the log scale, where a step of h is already h of the value: the size
        relative steps are taken of."""
        size = np.abs(np.asarray(x, dtype=float))
        size[:len(self.parameters)][self.log] = 1.0
        return size

    def initial_offsets(self, x: np.ndarray, i: int) -> dict[tuple[str, str], float]:
        """Experiment i's offsets to its measured first values, in their units."""
        z = x[len(self.parameters):]
        return {k: float(z[n]) * UNIT_SCALES[k[0]] for n, (e, k) in enumerate(self.offsets)
                if e == i}

    def fitted_spec(self, x: np.ndarray) -> ManipulatorSpec:
        return self.spec.with_overrides({p.path: float(v)
                                         for p, v in zip(self.parameters, self.values(x))})

    def simulate(self, x: np.ndarray) -> list[dict[tuple[str, str], np.ndarray]] | None:
        """Each experiment's simulated signals at its measured times, or None when the plant fails
        for these values."""
        from maniplab.mjcf_gen.builder import arm_accuracy
        from maniplab.sim.plant import Plant
        from maniplab.sim.simulate import simulate

        self.evaluations += 1
        try:
            spec = self.fitted_spec(x)
            known = arm_accuracy(self.spec)  # every candidate at the arm's step (cached)
            out = []
            for i, (e, keys) in enumerate(zip(self.experiments, self.keys)):
                plant = Plant(spec, dt=self.dt, accuracy=known)
                _start(plant, e, self.initial_offsets(x, i))
                run = simulate(plant, inputs={j: held(e.t, u) for j, u in e.inputs.items()},
                               duration=max(e.duration, 1e-9), progress=False,
                               supply=None if e.supply is None else held(e.t, e.supply))
                out.append({k: np.interp(e.t, run.t, run[k[0]][:, spec.joint_index(k[1])])
                            for k in keys})
            return out
        except ManiplabError:
            return None

    def residual(self, x: np.ndarray) -> np.ndarray:
        return self._residual(self.simulate(x))

    def residuals(self, points: Iterable[np.ndarray], pool: Threads) -> list[np.ndarray]:
        """The residual at each of ``points``, computed in the pool's threads."""
        return pool.map_results(self.residual, [(x,) for x in points])

    def residual_at(self, x: np.ndarray) -> np.ndarray:
        """The residual at ``x``, reusing the last one asked here (the solver evaluates a point,
        then takes its Jacobian there). Main thread only; the pool's threads call residual."""
        if self._last is None or not np.array_equal(self._last[0], x):
            self._last = (np.array(x, dtype=float), self.residual(x))
        return self._last[1]

    def _residual(self, sims: list[dict[tuple[str, str], np.ndarray]] | None) -> np.ndarray:
        if sims is None:
            return np.full(self.size, FAILED)
        parts = [(sim[k] - e.measured[k]) / scales[k]
                 for e, keys, sim, scales in zip(self.experiments, self.keys, sims, self.scales)
                 for k in keys]
        return np.concatenate(parts)

    def scan(self, x: np.ndarray, pool: Threads) -> np.ndarray:
        """Move each parameter to the best of a grid along its axis, the others held, until no
        move lowers the cost: stick/slip gives the cost narrow valleys between plateaus, where a
        local solver started on a plateau sees no slope. The grid spans
        :data:`SCAN_SPAN` of the start about the value in steps of :data:`SCAN_STEP` of the
        start, within the bounds (on either scale the same values)."""
        lower, upper = self.bounds()
        r = self.residual_at(x)
        best = float(r @ r)
        moves = np.arange(-SCAN_SPAN, SCAN_SPAN + 1e-9, SCAN_STEP)
        moves = moves[np.abs(moves) > 0.5 * SCAN_STEP]
        for _ in range(SCAN_ROUNDS):
            moved = False
            for i in range(len(self.parameters)):
                if self.log[i]:  # value + start g, as on the linear scale; none at or below 0
                    ratio = math.exp(x[i]) + moves
                    grid = np.log(np.where(ratio > 0.0, ratio, np.nan))
                else:
                    grid = x[i] + moves
                grid = grid[(grid > lower[i]) & (grid < upper[i])]
                points = [_along(x, i, g) for g in grid]
                costs = [float(r @ r) for r in self.residuals(points, pool)]
                if costs and min(costs) < best:
                    x, best, moved = points[int(np.argmin(costs))], min(costs), True
            if not moved:
                break
        return x

    def jacobian(self, x: np.ndarray, pool: Threads) -> np.ndarray:
        """Forward differences, one simulation per parameter in parallel (backward at a bound)."""
        base = self.residual_at(x)
        steps = STEP * np.maximum(self.magnitudes(x), 1e-2)
        steps[len(self.parameters):] = 0.1  # an offset of a tenth of its unit scale
        _, upper = self.bounds()
        steps = np.where(x + steps > upper, -steps, steps)
        shifted = [x + steps[i] * np.eye(len(x))[i] for i in range(len(x))]
        columns = self.residuals(shifted, pool)
        return np.column_stack([(c - base) / h for c, h in zip(columns, steps)])

    def reweight(self, x: np.ndarray) -> None:
        """Divide each signal of each joint by the spread of its residuals at ``x``."""
        sims = self.simulate(x)
        if sims is None:
            return
        self._last = None  # the weights change
        for e, keys, sim, scales in zip(self.experiments, self.keys, sims, self.scales):
            for k in keys:
                spread = float(np.std(sim[k] - e.measured[k]))
                scales[k] = max(spread, 1e-6 * UNIT_SCALES[k[0]])

    def result(self, x: np.ndarray, pool: Threads) -> Identification:
        sims = self.simulate(x)
        if sims is None:
            raise IdentificationError("the plant fails to simulate with the fitted values")
        r = self._residual(sims)
        self._last = (np.array(x, dtype=float), r)
        J = self.jacobian(x, pool)
        p = len(self.parameters)
        cost = float(r @ r)
        variance = cost / max(len(r) - len(x), 1)
        H = self.hessian(x, cost, variance, J, pool)
        cov_x = 2.0 * variance * self._inverse(H, J)[:p, :p]
        conditional = np.sqrt(2.0 * variance / np.maximum(np.diag(H)[:p], 1e-300))
        # the Gauss-Newton one, of the Jacobian's 1 % steps that stride over stick/slip's narrow
        # valleys: the scale of the walks also where the secants fell into one such valley (or
        # found none: a rough cost can be lower on both sides of the fit)
        smooth = np.sqrt(variance / np.maximum(np.einsum("ij,ij->j", J[:, :p], J[:, :p]), 1e-300))
        scale = np.where(np.diag(H)[:p] > 0.0, np.maximum(conditional, smooth), smooth)
        reach, chaos = self.profile_reach(x, cost, variance, scale, pool)
        # where the chaos was measured, the profile's costs are its draws: the regression says
        widen = np.where(chaos > 0.0, 1.0, np.maximum(1.0, reach / (1.96 * conditional)))
        local = np.diag(cov_x).copy()
        cov_x = cov_x * np.outer(widen, widen) + np.diag(chaos)
        widen = np.sqrt(np.diag(cov_x) / np.maximum(local, 1e-300))
        std = self.deviations(x, np.sqrt(np.clip(np.diag(cov_x), 0.0, None))[:p])
        scale = np.sqrt(np.clip(np.diag(cov_x), 1e-300, None))
        correlation = np.clip(cov_x / np.outer(scale, scale), -1.0, 1.0)
        J = J[:, :p]
        values = self.values(x)
        return Identification(
            self.parameters, values, std, correlation, self._rms(sims),
            {k: v for scales in self.scales for k, v in scales.items()},
            tuple(_warnings(self.parameters, values, std, correlation, J, widen)),
            self.fitted_spec(x), tuple(sims), self.experiments, self.evaluations)

    def hessian(self, x: np.ndarray, cost: float, variance: float, J: np.ndarray,
                pool: Threads) -> np.ndarray:
        """The cost's Hessian in x (module docstring): secants on the axes, correlations from the
        Gauss-Newton Hessian 2 JᵀJ."""
        gauss_newton = 2.0 * J.T @ J
        guess = np.sqrt(np.clip(np.diag(variance * 2.0 * np.linalg.pinv(gauss_newton)), 0.0, None))
        curvature = self.curvature(x, cost, variance, guess, RISE, pool)
        diagonal = np.sqrt(np.clip(np.diag(gauss_newton), 1e-300, None))
        correlation = gauss_newton / np.outer(diagonal, diagonal)
        root = np.sqrt(np.clip(curvature, 0.0, None))
        return np.asarray(correlation * np.outer(root, root))

    def profile_reach(self, x: np.ndarray, cost: float, variance: float, sigma: np.ndarray,
                      pool: Threads) -> tuple[np.ndarray, np.ndarray]:
        """Per parameter, how far (in x) its value can move, the others held, before the data
        reject it, and the variance (in x²) stick/slip's chaos adds to its estimate.

        The cost is walked along each axis in steps of half the standard deviation ``sigma``
        (p,) until it stays above the lowest cost + 3.84 s² + 2ρ. ρ is the largest jump on any
        axis's walk that the valley's curvature does not explain (:func:`_jumps`, among the
        triples of neighbours within the accepted costs): about 0 on a smooth valley, else the
        height of the steps and spikes stick/slip puts in the cost (a joint that sticks one plant
        step earlier), by which the true values may sit above the best. The walks are taken again
        once every axis has given its jumps. Where 2ρ is higher than the 3.84 s² of the interval
        itself, on any axis whose own walk has spikes that high (a cost above or below both its
        neighbours: chaos, not a staircase), :meth:`chaos` measures how much of the signals'
        dependence on the parameter is chaos."""
        walks: list[dict[float, float]] = [{0.0: cost} for _ in sigma]

        def lowest() -> float:
            return min(min(w.values()) for w in walks)

        def allowance() -> float:
            """2ρ: twice the largest jump that reaches down into the accepted costs."""
            gap = CHI2 * variance
            for _ in range(8):  # jumps that start inside the accepted costs widen them
                wider = CHI2 * variance + 2.0 * max(_jumps(w, lowest() + gap) for w in walks)
                if wider == gap:
                    break
                gap = wider
            return gap - CHI2 * variance

        def threshold() -> float:
            return lowest() + CHI2 * variance + allowance()

        for _ in range(2):
            for i, walked in enumerate(walks):
                for side in (-1.0, 1.0):
                    self._walk(x, i, side * 0.5 * sigma[i], walked, threshold, pool)
        limit = max(threshold(), cost + CHI2 * variance)  # the fit itself is never rejected
        reach = np.array([max(abs(d) for d, c in w.items() if c <= limit) for w in walks])
        stepped = allowance() > CHI2 * variance
        chaos = np.array([self.chaos(x, i, sigma[i], pool)
                          if stepped and 2.0 * _spikes(w, limit) > CHI2 * variance else 0.0
                          for i, w in enumerate(walks)])
        return reach, chaos

    def chaos(self, x: np.ndarray, i: int, sigma: float, pool: Threads) -> float:
        """The variance (in x²) that stick/slip's chaos adds to parameter i's estimate.

        Under stick/slip the simulated signals follow a parameter chaotically: a change of a
        millionth moves when a joint sticks, and with it every later sample, by as much as a
        change of a percent. Each value of the parameter then draws its own chaos, one as likely
        to match the data as another, and the fit finds the narrow valley of one draw: its cost
        rises within a millionth, and neither its curvature nor the walk's threshold describe how
        well the data place the parameter. The residuals are simulated at
        :data:`CHAOS_POINTS` values evenly over ±:data:`CHAOS_SPAN` ``sigma`` (the others held)
        and each sample is regressed on the parameter (a parabola): the slope g is what the
        parameter does to the signals, the scatter about the parabolas the chaos. Along g, the
        chaos is a second noise of variance τ²; the data hold one draw of it and the fit another,
        so the estimate's variance grows by 2τ²/|g|²."""
        lower, upper = self.bounds()
        span = CHAOS_SPAN * sigma
        d = span * np.linspace(-1.0, 1.0, CHAOS_POINTS)
        d = d[(x[i] + d > lower[i]) & (x[i] + d < upper[i])]
        rows = [(v, r) for v, r in zip(d, self.residuals([_along(x, i, x[i] + v) for v in d], pool))
                if not np.all(r == FAILED)]  # a plant that fails is no draw of the chaos
        if len(rows) < 8:
            return 0.0
        d = np.array([v for v, _ in rows]) / span
        residuals = np.array([r for _, r in rows])
        design = np.column_stack([np.ones_like(d), d, d * d])
        fit = np.linalg.lstsq(design, residuals, rcond=None)[0]
        slope = fit[1] / span
        norm = float(slope @ slope)
        if norm <= 0.0:
            return 0.0
        along = (residuals - design @ fit) @ slope / math.sqrt(norm)
        return 2.0 * float(along @ along) / (len(d) - 3) / norm

    def _walk(self, x: np.ndarray, i: int, step: float, walked: dict[float, float],
              threshold: Callable[[], float], pool: Threads) -> None:
        """Extend axis i's walk in batches of 8 steps, in the pool: ``step`` (signed) in the first
        batch, twice as long in each next one; until its three furthest costs exceed the
        threshold, a bound, or :data:`PROFILE_BATCHES`."""
        lower, upper = self.bounds()
        for _ in range(PROFILE_BATCHES):
            done = sorted((d for d in walked if d * step > 0), key=abs)
            if len(done) >= 3 and all(walked[d] > threshold() for d in done[-3:]):
                return
            if len(done) >= 8 * PROFILE_BATCHES:
                return
            last = done[-1] if done else 0.0
            steps = last + step * 2.0 ** (len(done) // 8) * np.arange(1, 9)
            steps = steps[(x[i] + steps > lower[i]) & (x[i] + steps < upper[i])]
            if not len(steps):
                return
            points = [_along(x, i, x[i] + d) for d in steps]
            walked.update(zip(steps.tolist(), (float(v @ v) for v in self.residuals(points, pool))))

    def curvature(self, x: np.ndarray, cost: float, variance: float, guess: np.ndarray,
                  rise_target: float, pool: Threads) -> np.ndarray:
        """The cost's second derivative along each axis, by secants over which the cost rises by
        about ``rise_target`` s² (the Gauss-Newton Hessian gives the correlations)."""
        lower, upper = self.bounds()
        room = np.minimum(x - lower, upper - x)
        step = np.clip(3.0 * guess * math.sqrt(rise_target / RISE),
                       1e-6 * np.maximum(self.magnitudes(x), 1e-3), 0.9 * room)

        def costs(points: list[np.ndarray]) -> np.ndarray:
            return np.array([float(v @ v) for v in self.residuals(points, pool)])

        eye = np.eye(len(x))
        target = rise_target * variance
        for _ in range(3):  # until each axis rises by the target within a factor of 4
            plus, minus = costs([x + h * e for h, e in zip(step, eye)]), \
                costs([x - h * e for h, e in zip(step, eye)])
            rise = 0.5 * (plus + minus) - cost
            off = (rise < target / 4.0) | (rise > 4.0 * target)
            if not off.any():
                break
            factor = np.sqrt(target / np.maximum(rise, 1e-3 * variance))
            step = np.where(off, np.minimum(step * np.clip(factor, 0.1, 10.0), 0.9 * room), step)
        return np.asarray((plus + minus - 2.0 * cost) / step**2)

    @staticmethod
    def _inverse(H: np.ndarray, J: np.ndarray) -> np.ndarray:
        """H⁻¹; where a rough cost makes the secant Hessian bend the wrong way, the Gauss-Newton
        Hessian 2 JᵀJ instead (positive semi-definite, unbounded where J has no column)."""
        symmetric = 0.5 * (H + H.T)
        if np.linalg.eigvalsh(symmetric)[0] <= 0.0:
            symmetric = 2.0 * J.T @ J
        return np.linalg.pinv(symmetric)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The bounds of x: the parameters' over their starts (their logarithms on the log scale,
        the lower one at least :data:`~.parameters.FLOOR`), then the free offsets."""
        lower = np.array([math.log(max(p.lower / p.start, FLOOR)) if p.log_scale
                          else p.lower / p.start if p.start > 0 else p.upper / p.start
                          for p in self.parameters])
        upper = np.array([math.log(p.upper / p.start) if p.log_scale
                          else p.upper / p.start if p.start > 0 else p.lower / p.start
                          for p in self.parameters])
        free = np.full(len(self.offsets), np.inf)
        return np.concatenate([lower, -free]), np.concatenate([upper, free])

    def _rms(self, sims: list[dict[tuple[str, str], np.ndarray]]) -> dict[str, float]:
        squares: dict[str, list[float]] = {}
        for e, keys, sim in zip(self.experiments, self.keys, sims):
            for k in keys:
                squares.setdefault(k[0], []).extend((sim[k] - e.measured[k]) ** 2)
        return {s: math.sqrt(float(np.mean(v))) for s, v in squares.items()}


def _along(x: np.ndarray, i: int, value: float) -> np.ndarray:
    """``x`` with its entry ``i`` set to ``value`` (a point on axis i through x)."""
    point = np.array(x, dtype=float)
    point[i] = value
    return point


def _jumps(walked: dict[float, float], ceiling: float) -> float:
    """The largest jump of the cost along a walk that its valley's curvature does not explain,
    among the triples of neighbours that reach down to ``ceiling`` (0 when none): how far the
    middle cost lies off the chord of the other two, less what the walk's typical (median)
    curvature puts there. A spike or dip of height h gives h, a step of height h (a joint that
    sticks one plant step earlier on one side of it) h/2 on each triple around it, a smooth
    valley about 0."""
    d = np.array(sorted(walked))
    costs = np.array([walked[v] for v in d])
    if len(costs) < 3:
        return 0.0
    left, right = d[1:-1] - d[:-2], d[2:] - d[1:-1]
    off = costs[1:-1] - (costs[:-2] * right + costs[2:] * left) / (left + right)
    near = np.minimum(costs[1:-1], np.minimum(costs[:-2], costs[2:])) <= ceiling
    if not near.any():
        return 0.0
    bend = (left * right)[near]  # a parabola a d² lies a·left·right below its chord
    curvature = float(np.median(-off[near] / bend))
    return float(np.abs(off[near] + curvature * bend).max())


def _spikes(walked: dict[float, float], ceiling: float) -> float:
    """The largest cost above or below both its neighbours along a walk, among the triples that
    reach down to ``ceiling`` (0 when none)."""
    costs = np.array([walked[d] for d in sorted(walked)])
    if len(costs) < 3:
        return 0.0
    middle, around = costs[1:-1], np.column_stack([costs[:-2], costs[2:]])
    near = np.minimum(middle, around.min(axis=1)) <= ceiling
    heights = np.maximum(middle - around.max(axis=1), around.min(axis=1) - middle)[near]
    return float(max(heights.max(initial=0.0), 0.0))


def _order(key: tuple[str, str]) -> tuple[int, str]:
    from maniplab.identification.data import MEASURABLE

    return (MEASURABLE.index(key[0]), key[1])


START_WINDOW = 0.02
"""The span (s) of the first samples a straight line is fitted through to estimate the initial
state: it averages out the noise of a single sample, and a state that moves is still followed."""


def _start(plant: Any, e: Experiment, offsets: dict[tuple[str, str], float]) -> None:
    """The plant at the experiment's start: measured q (unmeasured joints at 0) and q̇ (else at
    rest), the states that hold the arm there, then the measured pressures. Each measured value
    is the straight line through the samples of the first :data:`START_WINDOW` s, at t = 0."""
    names = plant.spec.joint_names
    window = max(3, int(np.searchsorted(e.t, START_WINDOW, side="right")))
    t = e.t[:window]

    def first(signal: str) -> dict[str, float]:
        out = {}
        for j in names:
            if (signal, j) in e.measured:
                values = e.measured[(signal, j)][:window]
                line = float(np.polyfit(t, values, 1)[1]) if len(t) >= 3 else float(values[0])
                out[j] = line + offsets.get((signal, j), 0.0)
        return out

    positions = {**_positions_of_strokes(plant.spec, first("stroke")), **first("q")}
    plant.set_state(q=[positions.get(j, 0.0) for j in names],
                    qd=[first("qd").get(j, 0.0) for j in names])
    plant.balance_pressures()
    measured = {s: first(s) for s in ("dP", "pA", "pB") if first(s)}
    if measured:
        plant.set_state(**measured)


def _positions_of_strokes(spec: ManipulatorSpec, strokes: dict[str, float]) -> dict[str, float]:
    """The joint positions where the cylinders have these strokes (m), on the branch of each
    joint's mid-range (the pins' geometry inverted)."""
    out = {}
    for name, stroke in strokes.items():
        joint = spec.joint(name)
        geometry = getattr(model_of(joint), "geometry", None)
        if geometry is None:
            continue
        middle = 0.5 * sum(joint.limits) if joint.limits else 0.0
        out[name] = geometry.position(joint.actuator.cylinder.min_length + stroke, middle)
    return out


def _warnings(parameters: Sequence[Parameter], values: np.ndarray, std: np.ndarray,
              correlation: np.ndarray, J: np.ndarray, widen: np.ndarray) -> list[str]:
    out = []
    widened = [f"{p.path} (×{w:.2g})" for p, w in zip(parameters, widen) if w > WIDENED]
    if widened:
        out.append(f"the cost steps where joints stick one plant step earlier or later, so these "
                   f"intervals were widened to the values the data cannot reject and the chaos "
                   f"of the steps: {', '.join(widened)}")
    for i, p in enumerate(parameters):
        if not np.any(J[:, i]):
            out.append(f"{p.path} has no effect on the measured signals: it cannot be fitted "
                       "from these data")
        elif values[i] and std[i] > 0.5 * abs(values[i]):
            out.append(f"{p.path} is poorly determined (± {100 * std[i] / abs(values[i]):.0f} %): "
                       "these data hardly depend on it")
    for i in range(len(parameters)):
        for j in range(i + 1, len(parameters)):
            if abs(correlation[i, j]) > CORRELATED:
                out.append(f"{parameters[i].path} and {parameters[j].path} cannot be told apart "
                           f"from these data (correlation {correlation[i, j]:+.3f}): fit one, or "
                           "add an experiment that moves them differently (see --suggest)")
    return out


def write_figure(result: Identification, path: str | os.PathLike[str]) -> Path:
    """Measured (dots) and fitted (lines) signals of every experiment, one panel per signal and
    joint, in display units."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from maniplab.atomic import atomic_path

    keys = sorted({k for e in result.experiments for k in e.measured}, key=_order)
    fig, axes = plt.subplots(len(keys), 1, figsize=(8, 1.8 * len(keys) + 0.6), sharex=True,
                             squeeze=False)
    pressure = (1e-6, "MPa")
    for ax, key in zip(axes[:, 0], keys):
        sliding = result.spec.joint(key[1]).prismatic
        factor, unit = {"q": (1.0, "m" if sliding else "rad"),
                        "qd": (1.0, "m/s" if sliding else "rad/s")}.get(key[0], pressure)
        for e, sim in zip(result.experiments, result.fitted):
            if key in e.measured:
                ax.plot(e.t, e.measured[key] * factor, ".", ms=2, alpha=0.5,
                        label=f"measured ({e.name})")
                ax.plot(e.t, sim[key] * factor, "-", lw=1.2, label=f"fitted ({e.name})")
        ax.set_ylabel(f"{key[0]} {key[1]}\n[{unit}]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle(f"{result.spec.name}: measured and fitted", fontsize=10)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format=Path(path).suffix.lstrip(".") or "png")
    plt.close(fig)
    return Path(path)
