"""Experiment design: the inputs that make the chosen parameters identifiable on this arm.

:func:`suggest` (``maniplab identify --suggest``) simulates a modest set of candidate experiments,
each from rest at a pose inside the limits (the middle of each joint's range, 0 on a joint without
limits) with the pressures that hold the arm, driving one joint with an input of the command-line
grammar (:func:`~maniplab.sim.grammar.parse_input`):

- steps up and down, ``J=step:A@0.5``, at 20, 50 and 90 % of the joint's command limit;
- up-and-down steps, ``J=step:A@0.5+step:-2A@TM`` (and down-and-up), which reverse the joint
  halfway so that it comes back (friction shows in reversals);
- sines ``J=sine:A,F@0.5`` at 20 and 90 % of the limit and 0.2, 0.5, 1 and 2 Hz.

A joint without a command limit (a torque source) is held by its gravity torque at the pose (a
constant added to every candidate) and excited with fractions of that torque (at least 1 N·m or
N). A candidate that drives a joint onto a limit within the duration is left out (an experiment
on the real arm should not hit the end stops), as is one whose simulation fails.

For each candidate the sensitivity matrix S, d(output / noise) / d(parameter / start), is taken by
finite differences, the outputs being the chosen signals of every joint sampled every
``sample_dt``, each divided by its measurement noise. Each parameter is moved by ±1 % and ±5 % of
its start; S's column is the gentlest of the secants from 0 to 1 % and from 1 to 5 % on either
side: stick/slip makes the outputs jump as a parameter moves (a joint that sticks one step
earlier), by about the same amount however small the move, and a 1 % secant alone would read such
a jump as a steep slope (see :func:`_slope`). For a parameter the outputs depend on mostly through
such jumps the prediction can still be optimistic: on crane3, a fit of simulated data (noise as
assumed) from the experiments suggested for the payload and the telescope's viscous friction
gave ± 0.14 % and ± 57 % where ± 0.04 % and ± 16 % were predicted (the fit widens its intervals
by the roughness of its cost, and the friction did come out 48 % off). Take the prediction as a
ranking of experiments and a lower bound, and check it with a fit of simulated data.

The perturbed runs start as a fit (:func:`~maniplab.identification.fit.identify`) would simulate
them: at the measured pose and, when a pressure is measured, at the measured pressures (the
nominal run's). SᵀS is then the Fisher information of the parameters divided by their starts. A
fit also estimates each experiment's initial state, an offset to each measured first value of q,
q̇ and ΔP (:data:`OFFSETS`): those are nuisance parameters, so each candidate's information is
what SᵀS keeps once they are estimated too, S's part outside the span of the offsets'
sensitivities (each offset moved by one noise; the Schur complement of the joint information,
additive over experiments since each has its own offsets).

A small set of experiments (up to ``experiments``, three by default) is chosen greedily to
maximise log det of the summed information (D-optimal design), stopping early once the next
experiment would improve no parameter's predicted standard deviation by 10 %. The predicted
relative standard deviation of each parameter is sqrt(diag((SᵀS)⁻¹)) over the chosen set: what a
fit of data from those experiments, with that noise, should achieve. A parameter whose predicted
relative standard deviation exceeds 50 %, or two whose correlation exceeds 0.95, is flagged with
the reason.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from maniplab.builtin import resolve_spec
from maniplab.errors import ManiplabError
from maniplab.identification.data import MEASURABLE
from maniplab.identification.fit import CORRELATED, STEP, UNIT_SCALES, IdentificationError
from maniplab.identification.parameters import Parameter, parse_parameters
from maniplab.progress import Progress
from maniplab.spec import ManipulatorSpec
from maniplab.workers import Threads

AMPLITUDES = (0.2, 0.5, 0.9)
"""Amplitudes of the steps, as fractions of the joint's command limit."""

SINE_AMPLITUDES = (0.2, 0.9)
"""Amplitudes of the sines, as fractions of the joint's command limit."""

FREQUENCIES = (0.2, 0.5, 1.0, 2.0)
"""Frequencies of the sines, Hz."""

START = 0.5
"""When each candidate's input starts, s (the arm rests before, so the data show its rest)."""

POOR = 0.5
"""Predicted relative standard deviation above which a parameter is flagged as unidentifiable."""

GAIN = 0.1
"""An experiment is added only when it lowers some parameter's predicted std by this fraction."""

MOVES = (1, 5)
"""Each parameter is moved by these many finite-difference steps (fit's STEP, 1 % of its start)
on each side: the sensitivity is the gentlest of the secants from 0 to 1 % and from 1 to 5 %
(see :func:`_slope`)."""

PRIOR = 1e-6
"""Information added to each parameter in the log det criterion (a prior of ±1000 times its
start), so that sets that leave a parameter undetermined still compare by the others."""

OFFSETS = ("q", "qd", "dP")
"""The measured signals whose first value a fit also estimates (an offset to the measured one),
as nuisance parameters of each experiment."""

SIGNALS = ("q", "dP")
"""The measured signals assumed by default."""


@dataclasses.dataclass(frozen=True)
class Candidate:
    """One candidate experiment.

    Attributes:
        joint: the joint it excites.
        kind: "step", "up-down" or "sine".
        inputs: its ``--input`` texts (the excited joint's, and the holding torques of joints
            without a command limit).
    """

    joint: str
    kind: str
    inputs: tuple[str, ...]

    def signals(self) -> dict[str | int, Any]:
        """The inputs as signals, read back through the command-line grammar."""
        from maniplab.sim.grammar import parse_input

        return dict(parse_input(text) for text in self.inputs)


@dataclasses.dataclass(frozen=True)
class Suggestion:
    """The experiments :func:`suggest` proposes.

    Attributes:
        spec_name: the arm.
        parameters: the parameters to identify.
        experiments: each chosen experiment's ``--input`` texts, best first.
        kinds: each chosen experiment's family ("step", "up-down", "sine").
        duration: each experiment's duration, s.
        initial: the pose each starts from, at rest with the pressures that hold the arm,
            joint -> rad or m.
        signals: the measured signals assumed.
        noise: signal -> its assumed measurement noise (rad or m, rad/s or m/s, Pa).
        sample_dt: the assumed sampling interval, s.
        relative_std: predicted standard deviation of each parameter from the chosen set,
            divided by its start, (p,) (inf: not determined at all).
        alone: the same from each chosen experiment alone, (k, p).
        correlation: predicted correlation of the parameters from the chosen set, (p, p).
        worst_correlation: the most correlated pair and its correlation, or None (one parameter).
        warnings: one line each: the parameters that stay unidentifiable, and why.
        candidates: how many candidates were simulated.
        dropped: one line per candidate left out (it reaches a joint limit or fails).
        fisher: the chosen set's Fisher information of the parameters divided by their starts.
    """

    spec_name: str
    parameters: tuple[Parameter, ...]
    experiments: tuple[tuple[str, ...], ...]
    kinds: tuple[str, ...]
    duration: float
    initial: dict[str, float]
    signals: tuple[str, ...]
    noise: dict[str, float]
    sample_dt: float
    relative_std: np.ndarray
    alone: np.ndarray
    correlation: np.ndarray
    worst_correlation: tuple[str, str, float] | None
    warnings: tuple[str, ...]
    candidates: int
    dropped: tuple[str, ...]
    fisher: np.ndarray

    def report(self) -> str:
        """The experiments, the predicted precision and the warnings, as Markdown."""
        pose = ", ".join(f"{j} = {v:.4g}" for j, v in self.initial.items())
        noise = ", ".join(f"{s} {self.noise[s]:g}" for s in self.signals)
        head = (f"Suggested experiments for {self.spec_name}: {self.duration:g} s each, from rest "
                f"at {pose} with the pressures that hold the arm; measuring "
                f"{', '.join(self.signals)} every {1000 * self.sample_dt:g} ms with noise {noise} "
                f"(SI units; {self.candidates} candidates simulated, {len(self.dropped)} left "
                "out).")
        out = [head, ""]
        names = "".join(f" {p.path} alone |" for p in self.parameters)
        out += [f"| # | inputs | kind |{names}", "|---|---|---|" + "---|" * len(self.parameters)]
        for k, (inputs, kind) in enumerate(zip(self.experiments, self.kinds)):
            texts = " ".join(f"`--input {t}`" for t in inputs)
            alone = "".join(f" ± {_percent(s)} |" for s in self.alone[k])
            out.append(f"| {k + 1} | {texts} | {kind} |{alone}")
        out += ["", "| parameter | start | predicted ± (all chosen) |", "|---|---|---|"]
        for p, s in zip(self.parameters, self.relative_std):
            out.append(f"| {p.path} | {p.start:.6g} | {_percent(s)} |")
        if self.worst_correlation is not None:
            a, b, c = self.worst_correlation
            out += ["", f"largest correlation: {a} and {b}, {c:+.3f}"]
        out += [""] * bool(self.warnings) + [f"warning: {w}" for w in self.warnings]
        if self.dropped:
            more = f"; and {len(self.dropped) - 3} more" if len(self.dropped) > 3 else ""
            out += ["", f"left out: {'; '.join(self.dropped[:3])}{more}"]
        return "\n".join(out)


def _percent(relative: float) -> str:
    if not math.isfinite(relative):
        return "∞"
    return f"{100 * relative:.3g} %"


def suggest(spec: ManipulatorSpec | str | os.PathLike[str], params: Iterable[str | Parameter], *,
            duration: float = 5.0, signals: Iterable[str] = SIGNALS,
            noise: Mapping[str, float] | None = None, workers: int | None = None,
            joints: Iterable[str] | None = None, experiments: int = 3, sample_dt: float = 0.01,
            progress: bool | None = None) -> Suggestion:
    """Propose inputs that make ``params`` identifiable on ``spec`` (module docstring).

    Args:
        spec: the arm (spec, file or built-in name), with the parameters at their expected
            values.
        params: dotted paths (``"end_effector.mass"``) or :class:`Parameter` objects.
        duration: each experiment's duration, s (more than 1 s).
        signals: the signals that will be measured (some of q, qd, dP, pA, pB).
        noise: signal -> measurement noise, overriding the defaults (1 mrad or mm for q, 0.01
            rad/s or m/s for qd, 1 bar for the pressures).
        workers: threads for the simulations (default: the cores).
        joints: the joints that may be excited (default: every joint).
        experiments: the most experiments to propose.
        sample_dt: the assumed sampling interval of the measurements, s.
        progress: show progress (None: a bar on a terminal, lines in a log when it lasts).

    Raises:
        SpecError: an unknown parameter path, or one that cannot be fitted (as
            :func:`parse_parameters`).
        IdentificationError: bad arguments (a signal, noise, joint, duration), or no candidate
            stays within the joint limits.
    """
    spec = resolve_spec(spec)
    parameters = _parameters(params, spec)
    keep = _signals(signals)
    scales = _noise(noise)
    if not (isinstance(duration, (int, float)) and math.isfinite(duration)
            and duration > 2 * START):
        raise IdentificationError(f"duration must be more than {2 * START:g} s, got {duration!r}")
    if not (isinstance(sample_dt, (int, float)) and 0.0 < sample_dt < duration):
        raise IdentificationError(f"sample_dt must be a positive number of seconds below the "
                                  f"duration, got {sample_dt!r}")
    if isinstance(experiments, bool) or not isinstance(experiments, int) or experiments < 1:
        raise IdentificationError(f"experiments must be a positive integer, got {experiments!r}")
    pose = _pose(spec)
    candidates = _candidates(spec, pose, float(duration), _joints(joints, spec))
    study = _Study(spec, parameters, keep, scales, pose, float(duration), float(sample_dt))
    fishers, kept, dropped = study.run(candidates, workers or os.cpu_count() or 1, progress)
    if not kept:
        raise IdentificationError(f"no candidate experiment on {spec.name} stays within the "
                                  f"joint limits for {duration:g} s: try a shorter duration "
                                  f"({dropped[0] if dropped else 'no candidate'})")
    chosen, total = _choose(fishers, experiments)
    cov = _covariance(total)
    rel = _std(cov)
    correlation = _correlation(cov)
    names = [p.path for p in parameters]
    worst = _worst(names, correlation)
    warnings = study.warnings + _warnings(names, rel, correlation, np.sum(fishers, axis=0), keep)
    return Suggestion(
        spec.name, parameters, tuple(kept[k].inputs for k in chosen),
        tuple(kept[k].kind for k in chosen), float(duration), dict(zip(spec.joint_names, pose)),
        keep, {s: scales[s] for s in keep}, float(sample_dt), rel,
        np.array([_std(_covariance(fishers[k])) for k in chosen]), correlation, worst,
        tuple(warnings), len(candidates), tuple(dropped), total)


def _parameters(params: Iterable[str | Parameter], spec: ManipulatorSpec) -> tuple[Parameter, ...]:
    items = list(params)
    given = [p for p in items if isinstance(p, Parameter)]
    texts = [p for p in items if isinstance(p, str)]
    return tuple(given) + (tuple(parse_parameters(texts, spec)) if texts or not given else ())


def _signals(signals: Iterable[str]) -> tuple[str, ...]:
    keep = tuple(dict.fromkeys([signals] if isinstance(signals, str) else signals))
    unknown = [s for s in keep if s not in MEASURABLE]
    if unknown or not keep:
        raise IdentificationError(f"unknown measured signal(s) {', '.join(unknown) or '(none)'}; "
                                  f"expected some of {', '.join(MEASURABLE)}")
    return keep


def _noise(noise: Mapping[str, float] | None) -> dict[str, float]:
    scales = dict(UNIT_SCALES)
    for signal, value in (noise or {}).items():
        if signal not in MEASURABLE:
            raise IdentificationError(f"noise of {signal!r}: not a measured signal; expected some "
                                      f"of {', '.join(MEASURABLE)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not (math.isfinite(value) and value > 0.0):
            raise IdentificationError(f"noise of {signal}: expected a positive number, got "
                                      f"{value!r}")
        scales[signal] = float(value)
    return scales


def _joints(joints: Iterable[str] | None, spec: ManipulatorSpec) -> list[str]:
    if joints is None:
        return list(spec.joint_names)
    chosen = [joints] if isinstance(joints, str) else list(joints)
    unknown = [j for j in chosen if j not in spec.joint_names]
    if unknown or not chosen:
        raise IdentificationError(f"joints to excite: {', '.join(unknown) or 'none given'} not in "
                                  f"{spec.name} (joints: {', '.join(spec.joint_names)})")
    return chosen


def _pose(spec: ManipulatorSpec) -> list[float]:
    """The middle of each joint's range (0 on a joint without limits)."""
    return [0.5 * (j.limits[0] + j.limits[1]) if j.limits else 0.0 for j in spec.joints]


def _candidates(spec: ManipulatorSpec, pose: Sequence[float], duration: float,
                joints: Sequence[str]) -> list[Candidate]:
    """Steps, up-and-down steps and sines on each joint (module docstring)."""
    from maniplab.sim.plant import Plant

    limits = Plant(spec).command_limit
    free = [k for k in range(spec.n) if not math.isfinite(limits[k])]
    gravity = _gravity(spec, pose) if free else np.zeros(spec.n)
    holds = {spec.joint_names[k]: float(gravity[k]) for k in free}
    middle = START + 0.5 * (duration - START)
    out = []
    for joint in joints:
        k = spec.joint_index(joint)
        scale = float(limits[k]) if math.isfinite(limits[k]) else max(abs(gravity[k]), 1.0)
        base = f"{holds[joint]:.6g}+" if joint in holds else ""
        others = tuple(f"{j}={g:.6g}" for j, g in holds.items() if j != joint)

        def make(kind: str, term: str, joint: str = joint, base: str = base,
                 others: tuple[str, ...] = others) -> Candidate:
            return Candidate(joint, kind, (f"{joint}={base}{term}", *others))

        for a in AMPLITUDES:
            for sign in (1.0, -1.0):
                out.append(make("step", f"step:{_num(sign * a * scale)}@{START:g}"))
        for a in AMPLITUDES:
            for sign in (1.0, -1.0):
                u = sign * a * scale
                out.append(make("up-down", f"step:{_num(u)}@{START:g}+step:{_num(-2 * u)}@"
                                           f"{_num(middle)}"))
        for a in SINE_AMPLITUDES:
            for f in FREQUENCIES:
                out.append(make("sine", f"sine:{_num(a * scale)},{f:g}@{START:g}"))
    return out


def _num(value: float) -> str:
    return f"{value:.4g}"


def _gravity(spec: ManipulatorSpec, pose: Sequence[float]) -> np.ndarray:
    """Gravity forces G(q) at the pose (MuJoCo's bias forces at rest), N·m or N, (n,)."""
    import mujoco

    from maniplab.mjcb import suspended
    from maniplab.sim.plant import Plant

    plant = Plant(spec)
    plant.set_state(q=list(pose))
    data = mujoco.MjData(plant.model)
    data.qpos[:] = plant.data.qpos
    with suspended():
        mujoco.mj_forward(plant.model, data)
    return np.array(data.qfrc_bias[: spec.n])


class _Study:
    """The candidates' simulations and their sensitivities."""

    def __init__(self, spec: ManipulatorSpec, parameters: tuple[Parameter, ...],
                 signals: tuple[str, ...], scales: dict[str, float], pose: list[float],
                 duration: float, sample_dt: float) -> None:
        self.spec, self.parameters, self.signals, self.scales = spec, parameters, signals, scales
        self.pose, self.duration, self.sample_dt = pose, duration, sample_dt
        self.steps = self._steps()
        self.pressures = any(s in ("dP", "pA", "pB") for s in signals)
        self.warnings: list[str] = []

    def _steps(self) -> list[tuple[float, ...]]:
        """Each parameter's moves (of its value divided by its start): :data:`MOVES` steps on
        each side, one side only at a bound."""
        out = []
        for p in self.parameters:
            lower, upper = sorted((p.lower / p.start, p.upper / p.start))
            moves = tuple(k * STEP * side for side in (1.0, -1.0) for k in MOVES)
            inside = tuple(h for h in moves if lower <= 1.0 + h <= upper)
            out.append(inside or moves[:2])
        return out

    def moved(self, i: int, h: float) -> dict[str, float]:
        """The override that moves parameter i by h of its start (i = -1: none)."""
        if i < 0:
            return {}
        p = self.parameters[i]
        return {p.path: float(p.start * (1.0 + h))}

    def simulate(self, candidate: Candidate, i: int, h: float, initial: dict[str, Any]) -> Any:
        """The run of ``candidate`` with parameter i moved by h (i = -1: none), or the error's
        text."""
        from maniplab.sim.simulate import simulate

        try:
            return simulate(self.spec, overrides=self.moved(i, h), inputs=candidate.signals(),
                            duration=self.duration, initial=initial, sample_dt=self.sample_dt,
                            progress=False)
        except ManiplabError as e:
            return str(e)

    def outputs(self, run: Any, columns: list[tuple[str, int]]) -> np.ndarray:
        """The measured signals of ``run`` at ``columns``, each divided by its noise, stacked."""
        return np.concatenate([np.asarray(run[s][:, k]) / self.scales[s] for s, k in columns]
                              or [np.zeros(0)])

    def columns(self, run: Any) -> list[tuple[str, int]]:
        """The (signal, joint index) pairs ``run`` has finite values of."""
        return [(s, k) for s in self.signals if s in run.signals for k in range(self.spec.n)
                if np.isfinite(run[s][:, k]).all()]

    def run(self, candidates: list[Candidate], workers: int,
            progress: bool | None) -> tuple[list[np.ndarray], list[Candidate], list[str]]:
        """Each candidate's Fisher information, the candidates kept, and why others were not."""
        from maniplab.friction.modes import FrictionMode

        p = len(self.parameters)
        shifts = [(i, h) for i in range(p) for h in self.steps[i]]
        starts = len([s for s in self.signals if s in OFFSETS]) * self.spec.n
        bar = Progress(len(candidates) * (len(shifts) + starts + 1),
                       f"suggest {self.spec.name}: {len(candidates)} candidates, {p} parameters",
                       progress)
        pool = Threads(workers)

        def map_runs(fn: Callable[..., Any], items: list[tuple[Any, ...]], what: str) -> list[Any]:
            return pool.map_results(fn, items, lambda: bar.step(what))

        try:
            bar.start("simulating the candidates")
            nominal = map_runs(self.simulate, [(c, -1, 0.0, {"q": self.pose, "dP": "gravity"})
                                               for c in candidates], "candidate")
            kept: list[tuple[Candidate, Any, list[tuple[str, int]]]] = []
            dropped: list[str] = []
            limit = (int(FrictionMode.AT_LOWER), int(FrictionMode.AT_UPPER))
            for c, run in zip(candidates, nominal):
                if isinstance(run, str):
                    dropped.append(f"{' '.join(c.inputs)}: fails ({run})")
                    continue
                hit = np.isin(run["mode"], limit)
                if hit.any():
                    row, k = (int(a[0]) for a in np.nonzero(hit))
                    side = "lower" if run["mode"][row, k] == limit[0] else "upper"
                    dropped.append(f"{' '.join(c.inputs)}: reaches {self.spec.joint_names[k]}'s "
                                   f"{side} limit at {run.t[row]:.3g} s")
                    continue
                kept.append((c, run, self.columns(run)))
            bar.start("sensitivities")
            jobs = []
            for c, run, columns in kept:
                start = self._initial(run)
                jobs += [(c, i, h, start) for i, h in shifts]
                jobs += [(c, -1, 0.0, self._offset(start, key)) for key in columns
                         if key[0] in OFFSETS]
            shifted = iter(map_runs(self.simulate, jobs, "sensitivity"))
        except BaseException:
            pool.stop()
            raise
        finally:
            pool.shutdown()
            bar.close()
        fishers, survivors = [], []
        missing = set(self.signals)
        for c, run, columns in kept:
            runs = [next(shifted) for _ in shifts]
            moved = [next(shifted) for key in columns if key[0] in OFFSETS]
            failed = next((r for r in runs + moved if isinstance(r, str)), None)
            if failed is not None:
                dropped.append(f"{' '.join(c.inputs)}: fails with a parameter or its start moved "
                               f"({failed})")
                continue
            missing -= {s for s, _ in columns}
            base = self.outputs(run, columns)
            outputs = {(i, h): self.outputs(r, columns) for r, (i, h) in zip(runs, shifts)}
            S = np.column_stack([_slope(base, {h: outputs[(i, h)] for h in self.steps[i]})
                                 for i in range(p)])
            Z = np.column_stack([self.outputs(r, columns) - base for r in moved]) if moved \
                else np.zeros((len(base), 0))
            fishers.append(_marginal(S, Z))
            survivors.append(c)
        for s in sorted(missing, key=self.signals.index):
            self.warnings.append(f"{s} is not a signal of {self.spec.name}'s simulation: left "
                                 "out of the design")
        return fishers, survivors, dropped

    def _offset(self, start: dict[str, Any], key: tuple[str, int]) -> dict[str, Any]:
        """``start`` with the measured first value ``key`` (signal, joint index) moved by its
        noise."""
        signal, k = key
        moved = dict(start)
        if signal == "q":
            q = list(self.pose)
            q[k] += self.scales["q"]
            moved["q"] = q
        elif signal == "qd":
            qd = np.zeros(self.spec.n)
            qd[k] = self.scales["qd"]
            moved["qd"] = qd
        elif isinstance(start["dP"], np.ndarray):
            dP = start["dP"].copy()
            dP[k] += self.scales["dP"]
            moved["dP"] = dP
        return moved

    def _initial(self, run: Any) -> dict[str, Any]:
        """The start of a perturbed run, as a fit would simulate it: the measured pose, and the
        measured pressures (the nominal run's) when pressures are measured."""
        if self.pressures and "dP" in run.signals and np.isfinite(run["dP"][0]).any():
            return {"q": self.pose, "dP": np.array(run["dP"][0])}
        return {"q": self.pose, "dP": "gravity"}


def _slope(base: np.ndarray, moved: dict[float, np.ndarray]) -> np.ndarray:
    """d outputs / d x from the outputs at moves h of x: the secants between neighbouring points
    on each side (0 to 1 %, 1 to 5 %), keeping the gentlest.

    Stick/slip makes the outputs jump as a parameter moves (a joint that sticks one step earlier
    or later), by about the same amount however small the move: a secant over 1 % reads such a
    jump as a steep slope. The longer secant dilutes it, one side may have none, and the gentlest
    secant is the dependence a fit can count on (slightly conservative when the outputs are
    smooth, the secants then agree up to their curvature)."""
    secants = []
    for side in (1.0, -1.0):
        points = [(0.0, base)] + sorted(((h, y) for h, y in moved.items() if h * side > 0),
                                        key=lambda item: abs(item[0]))
        secants += [(y1 - y0) / (h1 - h0) for (h0, y0), (h1, y1) in itertools.pairwise(points)]
    return min(secants, key=lambda v: float(v @ v))


def _marginal(S: np.ndarray, Z: np.ndarray) -> np.ndarray:
    """The information SᵀS the parameters keep when the start's offsets, whose sensitivities are
    Z's columns, are estimated too: S's part outside Z's span (the Schur complement of the joint
    information)."""
    if Z.shape[1]:
        U, sigma, _ = np.linalg.svd(Z, full_matrices=False)
        U = U[:, sigma > 1e-10 * max(float(sigma.max()), 1e-300)]
        S = S - U @ (U.T @ S)
    return np.asarray(S.T @ S)


def _logdet(F: np.ndarray) -> float:
    sign, value = np.linalg.slogdet(F + PRIOR * np.eye(len(F)))
    return float(value) if sign > 0 else -math.inf


def _choose(fishers: list[np.ndarray], count: int) -> tuple[list[int], np.ndarray]:
    """Greedy D-optimal choice of up to ``count`` candidates (module docstring)."""
    p = len(fishers[0])
    chosen: list[int] = []
    total = np.zeros((p, p))
    for _ in range(count):
        scores = [(_logdet(total + F), -k) for k, F in enumerate(fishers) if k not in chosen]
        if not scores:
            break
        best = -max(scores)[1]
        if chosen:
            before, after = _std(_covariance(total)), _std(_covariance(total + fishers[best]))
            better = np.where(np.isfinite(before), after < (1.0 - GAIN) * before,
                              np.isfinite(after))
            if not better.any():
                break
        chosen.append(best)
        total = total + fishers[best]
    return chosen, total


def _covariance(F: np.ndarray) -> np.ndarray:
    """F⁻¹, with 1e30 along the directions F does not determine."""
    values, vectors = np.linalg.eigh(0.5 * (F + F.T))
    floor = 1e-13 * max(float(values.max()), 0.0)
    inverse = np.where(values > max(floor, 1e-300), 1.0 / np.maximum(values, 1e-300), 1e30)
    return (vectors * inverse) @ vectors.T


def _std(cov: np.ndarray) -> np.ndarray:
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return np.where(std > 1e12, math.inf, std)


def _correlation(cov: np.ndarray) -> np.ndarray:
    scale = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
    return np.clip(cov / np.outer(scale, scale), -1.0, 1.0)


def _worst(names: list[str], correlation: np.ndarray) -> tuple[str, str, float] | None:
    pairs = [(abs(correlation[i, j]), i, j) for i in range(len(names))
             for j in range(i + 1, len(names))]
    if not pairs:
        return None
    _, i, j = max(pairs)
    return names[i], names[j], float(correlation[i, j])


def _warnings(names: list[str], rel: np.ndarray, correlation: np.ndarray, everything: np.ndarray,
              signals: tuple[str, ...]) -> list[str]:
    out = []
    measured = ", ".join(signals)
    for i, name in enumerate(names):
        if not everything[i, i] > 0.0:
            out.append(f"{name} has no effect on the measured signals ({measured}) in any "
                       "candidate experiment: it cannot be identified from them (measure others, "
                       "excite other joints, or fix it)")
        elif not rel[i] <= POOR:
            out.append(f"{name} stays poorly identifiable (predicted ± {_percent(rel[i])} from "
                       f"the best experiments): the measured signals ({measured}) hardly depend "
                       "on it; measure more signals or with less noise, or fix it")
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if abs(correlation[i, j]) > CORRELATED and np.isfinite(rel[[i, j]]).all():
                out.append(f"{names[i]} and {names[j]} stay correlated "
                           f"({correlation[i, j]:+.3f}): every candidate moves them alike; fit one "
                           "and fix the other")
    return out
