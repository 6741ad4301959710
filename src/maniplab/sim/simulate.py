"""``simulate``: run a plant under input signals and/or a controller, and record a Run."""

from __future__ import annotations

import itertools
import json
import math
import platform
from collections.abc import Callable, Mapping
from importlib.metadata import PackageNotFoundError, version
from typing import Any

import mujoco
import numpy as np

from maniplab.actuators.base import STANDARD_COMMANDS, STANDARD_STATES
from maniplab.builtin import resolve_spec
from maniplab.mjcf_gen.names import END_EFFECTOR
from maniplab.progress import Progress
from maniplab.sim.errors import InputError
from maniplab.sim.plant import Plant, SpecLike, integrator_name
from maniplab.sim.run import Run
from maniplab.sim.signals import Signal, as_signal
from maniplab.sim.state import PlantState

Controller = Callable[[float, PlantState], Any]

MAX_SAMPLE_RATE = 1000.0
"""Default recording rate cap, samples per second (every step at the default dt)."""

PROGRESS_STEPS = 200_000
"""Runs of at least this many steps show a progress bar on a terminal by default."""


def simulate(spec_or_plant: SpecLike | Plant, *, inputs: Mapping[str | int, Any] | None = None,
             controller: Controller | None = None, duration: float, dt: float | None = None,
             overrides: Mapping[str, Any] | None = None, initial: Mapping[str, Any] | None = None,
             sample_dt: float | None = None, route: str | None = None,
             integrator: str | None = None, label: str | None = None,
             progress: bool | None = None) -> Run:
    """Simulate an arm and record its signals.

    Args:
        spec_or_plant: a spec, spec file or built-in name (a new Plant is built, starting at rest
            at q = 0), or a Plant (the run continues from its current state and time).
        inputs: joint name (or index) -> signal of time (``ml.signals``, a number, or any
            callable ``t -> value``): valve current (A) of a hydraulic joint, force (N) or torque
            (N·m) of a torque joint, or a plugin's command.
        controller: ``controller(t, state) -> commands`` with ``state`` a
            :class:`~maniplab.sim.state.PlantState` (q, qd, dP, Q, mode, states) and commands an
            array (n,) or a mapping joint -> value. It is called at its own sample time, its
            ``dt`` attribute (s; absent or None: every step), at the first step at or after each
            multiple of it, and its commands are held in between (zero-order hold). They add to
            ``inputs`` (e.g. feed-forward signals plus feedback).
        duration: simulated time, s (rounded to whole steps).
        dt: time step, s (default 1e-3; must match a given Plant's).
        overrides: dotted-path overrides of the spec (not with a Plant).
        initial: starting state, as :meth:`Plant.set_state` takes it (``q``, ``qd``, ``dP``,
            ``Q``, ``z``, plugin states; arrays (n,) or mappings joint -> value). ``"dP":
            "gravity"`` sets the pressures that hold the arm against gravity at the initial pose.
        sample_dt: recording interval, s (a multiple of dt; default every step, but at most
            1000 samples per second).
        route, integrator: see :class:`Plant` (defaults "native", "RK4"; not with a Plant).
        label: a name for legends, stored in ``meta["label"]``.
        progress: show a progress bar on stderr (None: on a terminal, for runs of at least
            ``PROGRESS_STEPS`` steps).

    Returns:
        The Run: ``t`` (N,), signals ``q``, ``qd``, ``tau_act``, ``tau_fric``, ``tau_limit``,
        ``ctrl``, ``iv``, ``dP``, ``Q``, ``mode`` (N, n), ``ee_pos`` (N, 3), plus ``z`` and plugin
        states when present (NaN at joints without them). Forces and commands of sample k are
        those held over [t_k, t_k + dt) (the last sample repeats the last step's). ``meta``
        records the inputs, controller, overrides, initial state, dt, integrator and versions.

    Raises:
        InputError: bad arguments (unknown joint, wrong shape, non-finite command...).
        InstabilityError: the run went unstable (says when, on which joint).
        PluginError: an actuator plugin raised.
        SpecError: the spec or an override is invalid.
    """
    plant = _plant(spec_or_plant, dt=dt, overrides=overrides, route=route, integrator=integrator)
    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0.0):
        raise InputError(f"duration must be a positive number of seconds, got {duration!r}")
    if initial:
        _set_initial(plant, initial)
    drive = _inputs(plant, inputs or {})
    steps = max(1, round(duration / plant.dt))
    every = _sample_every(plant.dt, sample_dt)
    recorder = _Recorder(plant)
    t0 = plant.t
    period = _controller_period(controller)
    held = [0.0] * plant.n
    next_call = t0
    dt, prepare, advance = plant.dt, plant.prepare, plant.advance
    ticks = min(100, steps)
    bar = Progress(ticks, f"simulating {plant.spec.name}",
                   enabled=progress if progress is not None else
                   (None if steps >= PROGRESS_STEPS else False))
    tick = steps // ticks
    with plant.scope():
        for k in range(steps + 1):
            t = t0 + k * dt
            if bar.enabled and k % tick == 0 and k:
                bar.step(f"t = {t:.3g} s")
            if controller is not None and k < steps and t >= next_call - 1e-9 * dt:
                held = _call(controller, t, plant)
                next_call = next_call + period if period else t
            u = list(held)
            for j, signal in drive:
                u[j] += signal(t)
            if not math.isfinite(math.fsum(u)):
                raise InputError(f"non-finite command at t = {t:.6g} s: "
                                 f"{dict(zip(plant.joint_names, u))}")
            prepare(u)
            record = k % every == 0 or k == steps
            if record:
                recorder.state(t)
            if k == steps:
                break
            advance()
            if record:
                recorder.forces()
    bar.close()
    recorder.forces()
    meta = _meta(plant, inputs or {}, controller, period, overrides, initial, steps, every, label)
    run = Run(t=recorder.times(), signals=recorder.signals(), spec=plant.spec, meta=meta)
    # a controller that logs its own signals adds them (any controller with annotate(run) -> Run)
    annotate = getattr(controller, "annotate", None)
    return annotate(run) if callable(annotate) else run


def _plant(spec_or_plant: SpecLike | Plant, *, dt: float | None, overrides: Any,
           route: str | None, integrator: str | None) -> Plant:
    if isinstance(spec_or_plant, Plant):
        plant = spec_or_plant
        if overrides:
            raise InputError("overrides apply to a spec; build the Plant from "
                             "spec.with_overrides(...) instead")
        if dt is not None and not math.isclose(dt, plant.dt, rel_tol=1e-12):
            raise InputError(f"the plant steps with dt={plant.dt:g}; got dt={dt!r} (build "
                             f"Plant(spec, dt={dt!r}) for another step)")
        for name, value, have in (("route", route, plant.route),
                                  ("integrator", integrator, integrator_name(plant.integrator))):
            if value is not None and value != have:
                raise InputError(f"the plant's {name} is {have!r}; got {name}={value!r}")
        return plant
    spec = resolve_spec(spec_or_plant)
    if overrides:
        spec = spec.with_overrides(overrides)
    return Plant(spec, dt=dt, route=route or "native", integrator=integrator or "RK4")


def _set_initial(plant: Plant, initial: Mapping[str, Any]) -> None:
    values = dict(initial)
    balance = isinstance(values.get("dP"), str)
    if balance:
        if values["dP"] != "gravity":
            raise InputError(f"initial dP: expected values or 'gravity', got {values['dP']!r}")
        del values["dP"]
    try:
        plant.set_state(**values)
    except TypeError as exc:
        raise InputError(f"initial: {exc}") from None
    if balance:
        plant.balance_pressures()


def _inputs(plant: Plant, inputs: Mapping[str | int, Any]) -> list[tuple[int, Signal]]:
    if not isinstance(inputs, Mapping):
        raise InputError(f"inputs must map joint names to signals, got {type(inputs).__name__}")
    drive = []
    for key, value in inputs.items():
        if isinstance(key, int) and 0 <= key < plant.n:
            j = key
        elif key in plant.joint_names:
            j = plant.joint_names.index(key)
        else:
            raise InputError(f"inputs: no joint {key!r}; expected one of "
                             f"{', '.join(plant.joint_names)}")
        try:
            drive.append((j, as_signal(value)))
        except TypeError as exc:
            raise InputError(f"inputs[{key!r}]: {exc}") from None
    return drive


def _sample_every(dt: float, sample_dt: float | None) -> int:
    if sample_dt is None:
        return max(1, round(1.0 / (MAX_SAMPLE_RATE * dt)))
    if not (math.isfinite(sample_dt) and sample_dt > 0.0):
        raise InputError(f"sample_dt must be a positive number of seconds, got {sample_dt!r}")
    return max(1, round(sample_dt / dt))


def _controller_period(controller: Controller | None) -> float | None:
    if controller is None:
        return None
    if not callable(controller):
        raise InputError(f"controller must be callable (t, state) -> commands, got {controller!r}")
    period = getattr(controller, "dt", None)
    if period is None:
        return None
    if not (isinstance(period, (int, float)) and math.isfinite(period) and period > 0.0):
        raise InputError(f"controller.dt must be a positive number of seconds, got {period!r}")
    return float(period)


def _call(controller: Controller, t: float, plant: Plant) -> list[float]:
    commands = controller(t, plant.state())
    try:
        if isinstance(commands, Mapping):
            return plant.command_vector(commands).tolist()
        values = np.asarray(commands, dtype=float)
        if values.shape != (plant.n,):
            raise InputError(f"expected {plant.n} commands (or a mapping joint -> command), "
                             f"got shape {values.shape}")
        return values.tolist()
    except (InputError, TypeError, ValueError) as exc:
        raise InputError(f"controller at t = {t:.6g} s: {exc}") from None


class _Recorder:
    """Collects what the plant publishes each step (:class:`~maniplab.sim.plant.StepRecord`) as
    Python lists (cheaper per step than numpy rows) and builds the Run's arrays."""

    def __init__(self, plant: Plant) -> None:
        self.plant = plant
        self._t: list[float] = []
        self._q: list[list[float]] = []
        self._qd: list[list[float]] = []
        self._act: list[list[float]] = []
        self._ctrl: list[list[float]] = []
        self._mode: list[list[int]] = []
        self._fric: list[list[float]] = []
        self._limit: list[list[float]] = []

    def state(self, t: float) -> None:
        """Record the prepared step's start."""
        r = self.plant.record
        self._t.append(t)
        self._q.append(r.q)
        self._qd.append(r.qd)
        self._act.append(r.act)
        self._ctrl.append(r.u)
        self._mode.append(r.mode)

    def forces(self) -> None:
        """Record the forces of the last advanced step for the samples that lack them."""
        r = self.plant.record
        while len(self._fric) < len(self._t):
            self._fric.append(r.fric)
            self._limit.append(r.limit)

    def times(self) -> np.ndarray:
        return np.array(self._t)

    def signals(self) -> dict[str, np.ndarray]:
        p = self.plant
        q, qd, ctrl = _matrix(self._q, p.n), _matrix(self._qd, p.n), _matrix(self._ctrl, p.n)
        act = _matrix(self._act, p.model.na)
        out: dict[str, np.ndarray] = {"q": q, "qd": qd}
        nan = np.full((len(self._t), p.n), np.nan)
        out.update({name: nan.copy() for name in STANDARD_STATES})
        out.update(p.layout.read(act))
        out["ctrl"] = ctrl
        for name in dict.fromkeys((*STANDARD_COMMANDS, *(a.command for a in p.actuators))):
            mine = [a.command == name for a in p.actuators]
            out[name] = np.where(mine, ctrl, np.nan)
        out["tau_act"] = p.actuator_forces_at(q, qd, act, ctrl)
        out["tau_fric"] = _matrix(self._fric, p.n) - p.viscous * qd  # applied + viscous at t_k
        out["tau_limit"] = _matrix(self._limit, p.n)
        out["mode"] = _matrix(self._mode, p.n).astype(np.int8)
        out["ee_pos"] = _end_effector(p.model, q)
        return out


def _matrix(rows: list, width: int) -> np.ndarray:
    """(N, width) float array from N rows of numbers (several times faster than np.array)."""
    flat = np.fromiter(itertools.chain.from_iterable(rows), dtype=float, count=len(rows) * width)
    return flat.reshape(len(rows), width)


def _end_effector(model: mujoco.MjModel, q: np.ndarray) -> np.ndarray:
    """Position of the end-effector (payload point) for each row of q, m, (N, 3)."""
    data = mujoco.MjData(model)
    body = model.body(END_EFFECTOR).id
    out = np.empty((len(q), 3))
    for r, row in enumerate(q):
        data.qpos[:] = row
        mujoco.mj_kinematics(model, data)
        out[r] = data.xpos[body]
    return out


def _meta(plant: Plant, inputs: Mapping[Any, Any], controller: Controller | None,
          period: float | None, overrides: Any, initial: Any, steps: int, every: int,
          label: str | None) -> dict[str, Any]:
    meta: dict[str, Any] = {
        "dt": plant.dt,
        "integrator": integrator_name(plant.integrator),
        "route": plant.route,
        "steps": steps,
        "sample_dt": every * plant.dt,
        "inputs": {str(k): repr(as_signal(v)) for k, v in inputs.items()},
        "controller": None if controller is None else {"repr": _describe(controller),
                                                       "dt": period},
        "overrides": _jsonable(dict(overrides or {})),
        "initial": _jsonable(dict(initial or {})),
        "versions": {
            "maniplab": _version("maniplab"), "mujoco": mujoco.__version__,
            "numpy": np.__version__, "python": platform.python_version(),
        },
    }
    if label is not None:
        meta["label"] = label
    return meta


def _describe(obj: Any) -> str:
    text = repr(obj)
    if " at 0x" in text:  # default object repr: the class (or function) name says more
        text = getattr(obj, "__qualname__", type(obj).__qualname__)
    return text[:200]


def _jsonable(value: Any) -> Any:
    return json.loads(json.dumps(value, default=lambda v: np.asarray(v).tolist()
                                 if isinstance(v, (np.ndarray, np.generic)) else repr(v)))


def _version(package: str) -> str:
    try:
        return version(package)
    except PackageNotFoundError:
        return "unknown"
