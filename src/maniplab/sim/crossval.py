"""Model cross-validation: the analytic model integrated by scipy's standard ODE solvers against
the MuJoCo plant, from the same spec, initial state and inputs, with ideal actuators.

This is the evidence that the MJCF and the analytic model describe the same arm: they are built
by independent code (mjcf_gen from MjSpec, the model's own recursive algorithms) and integrated by independent solvers.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Mapping
from typing import Literal

import numpy as np
from scipy.integrate import solve_ivp

from maniplab.actuators.registry import IDEAL_SOURCE
from maniplab.errors import ManiplabError
from maniplab.model import AnalyticModel
from maniplab.progress import Progress
from maniplab.sim.errors import InputError
from maniplab.sim.run import Run
from maniplab.spec import ManipulatorSpec

Signal = Callable[[float], float]

Solver = Literal["RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA"]
SOLVERS: dict[str, Solver] = {name: name for name in
                              ("RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA")}
"""scipy's ``solve_ivp`` methods by name."""


def ideal(spec: ManipulatorSpec) -> ManipulatorSpec:
    """The arm with an ideal torque/force source on every joint, no friction and no limits (and
    no shared ``supply:``, which only pinned cylinders draw from)."""
    overrides: dict[str, object] = {} if spec.supply is None else {"supply": None}
    for joint in spec.joints:
        overrides[f"joints.{joint.name}.actuator"] = {"type": IDEAL_SOURCE}
        overrides[f"joints.{joint.name}.friction"] = {"model": "none"}
        overrides[f"joints.{joint.name}.limits"] = None
    return spec.with_overrides(overrides)


def integrate_analytic(spec: ManipulatorSpec, inputs: Mapping[str, Signal], t: np.ndarray, *,
                       q0: np.ndarray | None = None, hold: float | None = None,
                       method: str = "DOP853", rtol: float = 1e-10, atol: float = 1e-12,
                       progress: bool | None = None) -> Run:
    """Integrate M(q) q̈ + C q̇ + G = τ(t) with ``scipy.integrate.solve_ivp``.

    Args:
        spec: the arm (its actuators are taken as ideal: ``τ_j = inputs[j](t)``).
        inputs: joint name -> force or torque signal of time, N or N·m (missing joints: 0).
        t: output times, s, shape (N,), starting at the initial time.
        q0: initial positions, shape (n,) (default zeros); the arm starts at rest.
        hold: when given, each input is held constant over [k·hold, (k+1)·hold), s, as a plant
            stepping with dt = hold applies it (the solver restarts at every hold boundary);
            otherwise inputs are continuous.
        method: solve_ivp's method, one of :data:`SOLVERS`.
        rtol: solve_ivp's relative tolerance.
        atol: solve_ivp's absolute tolerance.
        progress: show progress (None: a bar on a terminal, lines in a log when it lasts).

    Returns:
        A Run with q, qd (shape (N, n)) and ee_pos (N, 3); meta records the solver.

    Raises:
        InputError: an unknown ``method``.
    """
    solver = SOLVERS.get(method)
    if solver is None:
        raise InputError(f"unknown scipy solver {method!r}; expected one of {', '.join(SOLVERS)}")
    model = AnalyticModel(spec, progress=progress)
    n = spec.n
    forces = [inputs.get(name) for name in spec.joint_names]

    def tau(time: float) -> np.ndarray:
        return np.array([f(time) if f is not None else 0.0 for f in forces])

    def rhs(time: float, x: np.ndarray, force: np.ndarray | None) -> np.ndarray:
        q, qd = x[:n], x[n:]
        m, bias = model.mass_and_bias(q, qd)
        return np.concatenate([qd, np.linalg.solve(m, (tau(time) if force is None else force) - bias)])

    t = np.asarray(t, dtype=float)
    x = np.concatenate([np.zeros(n) if q0 is None else np.asarray(q0, float), np.zeros(n)])
    held = hold is not None and any(f is not None for f in forces)
    edges = _edges(t[0], t[-1], hold if held else None)
    states = []
    bar = Progress(len(edges) - 1, f"crossval {spec.name}: scipy {method} on the analytic model",
                   progress)
    try:
        for k, (start, stop) in enumerate(itertools.pairwise(edges)):
            sol = solve_ivp(rhs, (start, stop), x, method=solver, rtol=rtol, atol=atol,
                            args=(tau(start) if held else None,), dense_output=True)
            if not sol.success:
                raise ManiplabError(f"scipy {method} failed on the analytic model of {spec.name} "
                                    f"at t = {start:.4g} s: {sol.message}")
            last = k == len(edges) - 2
            inside = t[(t >= start - 1e-12) & ((t < stop - 1e-12) | last)]
            if inside.size:
                assert sol.sol is not None, "solve_ivp gives the dense solution with dense_output"
                states.append(sol.sol(inside))
            x = sol.y[:, -1]
            bar.step(f"t = {stop:.4g} s")
    finally:
        bar.close()
    y = np.hstack(states)
    q, qd = y[:n].T, y[n:].T
    ee = model.fk(q)[:, :3, 3]
    meta = {"label": f"analytic ({method})", "solver": method, "rtol": rtol, "atol": atol,
            "hold": hold}
    return Run(t=t, signals={"q": q, "qd": qd, "ee_pos": ee}, spec=spec, meta=meta)


def _edges(start: float, stop: float, hold: float | None) -> np.ndarray:
    """Restart times of the solver: every hold boundary, or just the two ends."""
    if hold is None:
        return np.array([start, stop])
    edges = start + hold * np.arange(round((stop - start) / hold) + 1)
    edges[-1] = stop
    return edges


@dataclasses.dataclass(frozen=True)
class CrossValidation:
    """MuJoCo plant and analytic model on the same arm and inputs.

    Attributes:
        mujoco: the MuJoCo plant's run.
        analytic: the scipy integration of the analytic model, at the same times.
        max_deviation: largest |q_mujoco - q_analytic| over time and joints, rad or m.
        joint: the joint where it occurs.
        time: when it occurs, s.
    """

    mujoco: Run
    analytic: Run
    max_deviation: float
    joint: str
    time: float


def compare_runs(mujoco: Run, analytic: Run) -> CrossValidation:
    """The largest joint-position deviation between two runs sampled at the same times."""
    if mujoco.t.shape != analytic.t.shape or not np.allclose(mujoco.t, analytic.t):
        raise ManiplabError("the runs to compare are not sampled at the same times")
    deviation = np.abs(mujoco.q - analytic.q)
    k, j = np.unravel_index(np.argmax(deviation), deviation.shape)
    return CrossValidation(mujoco, analytic, float(deviation[k, j]),
                           mujoco.spec.joint_names[j], float(mujoco.t[k]))


def crossvalidate(spec: ManipulatorSpec | str, *, inputs: Mapping[str, Signal] | None = None,
                  duration: float = 5.0, q0: np.ndarray | None = None, dt: float | None = None,
                  sample_dt: float = 0.01, method: str = "DOP853") -> CrossValidation:
    """Simulate the arm with ideal actuators on the MuJoCo plant and as the analytic model
    integrated by scipy, from rest at ``q0``, and compare joint positions.

    Args:
        spec: the arm (spec, file or built-in name); actuators become ideal force/torque sources,
            friction and limits are removed (:func:`ideal`).
        inputs: joint name -> force/torque signal (default none: the arm moves under gravity).
        duration: simulated time, s.
        q0: initial joint positions, shape (n,) (default zeros).
        dt: the plant's step, s (default the plant's); inputs are held over each step on both sides.
        sample_dt: comparison interval, s.
        method: scipy solver (DOP853, Radau, RK45, LSODA, ...).
    """
    from maniplab.builtin import resolve_spec
    from maniplab.sim.simulate import simulate

    arm = ideal(resolve_spec(spec))
    q0 = np.zeros(arm.n) if q0 is None else np.asarray(q0, dtype=float)
    inputs = dict(inputs or {})
    # the same signals for the plant, keyed as simulate's inputs are typed (by name or index)
    plant_inputs: dict[str | int, Signal] = {name: f for name, f in inputs.items()}
    plant_run = simulate(arm, inputs=plant_inputs, duration=duration, dt=dt, sample_dt=sample_dt,
                         initial={"q": q0}, label="MuJoCo plant")
    hold = float(plant_run.meta["dt"])
    analytic_run = integrate_analytic(arm, inputs, plant_run.t, q0=q0, hold=hold, method=method)
    return compare_runs(plant_run, analytic_run)
