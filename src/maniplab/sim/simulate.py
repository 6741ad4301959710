"""``simulate``: run a plant under input signals and/or a controller, and record a Run."""

from __future__ import annotations

import contextlib
import ctypes
import functools
import json
import math
import os
import platform
from collections.abc import Callable, Iterator, Mapping
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from maniplab.atomic import atomic_path, check_target
from maniplab.builtin import resolve_spec
from maniplab.mjcf_gen.builder import arm_accuracy
from maniplab.mjcf_gen.names import END_EFFECTOR
from maniplab.progress import Progress
from maniplab.sim import budget, native, recorder, store
from maniplab.sim import bursts as burst_lines
from maniplab.sim.claim import claimed
from maniplab.sim.errors import InputError
from maniplab.sim.plant import Plant, SpecLike, integrator_name
from maniplab.sim.run import UNITS, Run
from maniplab.sim.signals import Signal, as_signal
from maniplab.sim.state import PlantState
from maniplab.sim.stream import RunWriter
from maniplab.workers import check_cancelled

Controller = Callable[[float, PlantState], Any]

MAX_SAMPLE_RATE = 1000.0
"""Default recording rate cap, samples per second (every step at the default dt)."""

PROGRESS_STEPS = 200_000
"""Runs of at least this many steps show a progress bar on a terminal by default."""


def simulate(spec_or_plant: SpecLike | Plant, *, inputs: Mapping[str | int, Any] | None = None,
             controller: Controller | None = None, duration: float, dt: float | None = None,
             overrides: Mapping[str, Any] | None = None, initial: Mapping[str, Any] | None = None,
             sample_dt: float | None = None, integrator: str | None = None, label: str | None = None,
             progress: bool | None = None, stream: str | os.PathLike[str] | None = None,
             supply: Any = None, bursts: Any = None) -> Run:
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
            ``inputs`` (e.g. feed-forward signals plus feedback). Its ``reset(state)`` (or
            ``reset()``), when it has one, is called before the first sample with the plant's
            state, so no state carries over from an earlier run; a controller another thread's
            run is using at the time is copied for this run (:mod:`~maniplab.sim.claim`).
        duration: simulated time, s (rounded to whole steps).
        dt: time step, s (default 1e-3; must match a given Plant's).
        overrides: dotted-path overrides of the spec (not with a Plant).
        initial: starting state, as :meth:`Plant.set_state` takes it (``q``, ``qd``, ``dP``,
            ``Q``, ``z``, plugin states; arrays (n,) or mappings joint -> value). ``"dP":
            "gravity"`` sets the pressures that hold the arm against gravity at the initial pose.
        sample_dt: recording interval, s (a multiple of dt; default every step, but at most
            1000 samples per second). A longer interval records less: the run's memory (or
            file) is its samples × bytes per sample.
        integrator: see :class:`Plant` (default "RK4"; not with a Plant).
        label: a name for legends, stored in ``meta["label"]``.
        progress: show a progress bar on stderr (None: on a terminal, for runs of at least
            ``PROGRESS_STEPS`` steps).
        stream: a run file (.npz) to write the samples to as the run goes, in chunks, instead
            of keeping them in memory: memory stays bounded whatever the duration. The file
            appears complete when the run ends (nothing under its name if the run fails or is
            interrupted); the Run returned reads it memory-mapped. Not with a controller that
            adds signals to the run (``annotate``).
        supply: a measured supply pressure, Pa, as a signal of time (as ``inputs`` take them;
            e.g. ``ml.signals.held(t, p)`` of a rig's log): every pinned cylinder's valve is fed
            at it instead of at its pump's (the pump's model, flow limit and load sensing are
            left out), to validate the arm against rig data. Lumped cylinders keep their own.
        bursts: hose bursts, a scenario (:mod:`~maniplab.sim.bursts`): ``"JOINT:LINE@TIME"``
            or a list of them, e.g. ``"lift:a@1.5"``: the cap-side line of the lift's pinned
            cylinder opens to the atmosphere at 1.5 s; the health verdict reports a load that
            moved more than 1 mm after it.

    Returns:
        The Run: ``t`` (N,), signals ``q``, ``qd``, ``tau_act``, ``tau_fric``, ``tau_limit``,
        ``ctrl``, ``iv``, ``dP``, ``Q``, ``mode`` (N, n), ``ee_pos`` (N, 3), plus ``z`` and plugin
        states when present (NaN at joints without them). Forces and commands of sample k are
        those held over [t_k, t_k + dt) (the last sample repeats the last step's). ``meta``
        records the inputs, controller, overrides, initial state, dt, integrator and versions.

    Raises:
        InputError: bad arguments (unknown joint, wrong shape, non-finite command...), or a run
            whose samples would not fit in the memory available (or, streamed, on the disk):
            refused before its first step, naming the size and the ``sample_dt`` that fits.
        OutputError: ``stream`` names a device, fifo or folder.
        InstabilityError: the run went unstable (says when, on which joint).
        PluginError: an actuator plugin raised.
        SpecError: the spec or an override is invalid.
    """
    plant = _plant(spec_or_plant, dt=dt, overrides=overrides, integrator=integrator)
    scenario = burst_lines.checked(plant.spec, burst_lines.from_any(bursts))
    steps = budget.steps_of(duration, plant.dt)
    drive = _inputs(plant, inputs or {})
    if supply is not None:
        drive.append((plant.n, _supply_signal(supply)))
    every = _sample_every(plant.dt, sample_dt)
    period = _controller_period(controller)
    target = _stream_target(stream, controller)
    signals = recorder.layout(plant)
    rows = budget.rows_of(steps, min(every, steps))
    _check_budget(plant, duration, every, signals, rows, target)  # before a given plant changes
    if initial:
        _set_initial(plant, initial)
    with claimed(controller, plant.state()) as own, _recording(target, signals, rows) as sink:
        loop = _Loop(plant, steps, every, drive, own, period, sink)
        burst_lines.write(plant, scenario)
        _go(loop, plant, steps, progress)
        meta = _meta(plant, inputs or {}, own, period, overrides, initial, steps, every, label)
        if supply is not None:
            meta["supply"] = repr(as_signal(supply))
        if scenario:
            meta["bursts"] = burst_lines.describe(scenario)
        if isinstance(sink, RunWriter):
            sink.finish(store.header_body(plant.spec, meta,
                                          {k: UNITS[k] for k in signals if k in UNITS}))
            run = None
        else:
            assert sink.complete()
            run = Run(t=sink.t, signals=sink.signals, spec=plant.spec, meta=meta)
            # a controller that logs its own signals adds them (annotate(run) -> Run)
            annotate = getattr(own, "annotate", None)
            run = annotate(run) if callable(annotate) else run
    if target is not None:
        return store.load(target, Run, mmap=True, verify=False)
    assert run is not None
    return run


def _go(loop: _Loop, plant: Plant, steps: int, progress: bool | None) -> None:
    """Run ``loop`` to its end, with a progress bar (see ``simulate``'s ``progress``)."""
    bar = Progress(math.ceil(steps / loop.CHUNK), f"simulating {plant.spec.name}",
                   enabled=progress if progress is not None else
                   (None if steps >= PROGRESS_STEPS else False))
    try:
        while loop.go():
            check_cancelled()  # Ctrl-C reaches only the main thread; a sweep's threads stop here
            bar.step(f"t = {plant.t:.3g} s")
    finally:
        bar.close()
        plant.data.userdata[:] = 0.0  # a measured supply ends with its run


def _stream_target(stream: str | os.PathLike[str] | None,
                   controller: Controller | None) -> Path | None:
    """The run file of ``stream=``, checked before the run (None: record in memory)."""
    if stream is None:
        return None
    if not isinstance(stream, (str, os.PathLike)) or not str(stream):
        raise InputError(f"stream must be the path of a run file (.npz), got {stream!r}")
    if callable(getattr(controller, "annotate", None)):
        raise InputError("stream=: the controller adds its own signals to the run (annotate), "
                         "which needs the run in memory; record less with sample_dt= instead")
    check_target(stream)
    return Path(stream)


def _check_budget(plant: Plant, duration: float, every: int, signals: recorder.Layout,
                  rows: int, target: Path | None) -> None:
    """Refuse, before the first step, a run whose samples fit neither in memory nor (streamed) on
    the disk (:mod:`~maniplab.sim.budget`)."""
    per_sample = recorder.bytes_per_sample(signals)
    if target is None:
        budget.check_memory(rows * per_sample, duration=duration, dt=plant.dt, every=every,
                            bytes_per_sample=per_sample,
                            overhead=recorder.overhead(plant, per_sample))
    else:
        budget.check_disk(rows * per_sample, target, duration=duration, dt=plant.dt, every=every,
                          bytes_per_sample=per_sample)


@contextlib.contextmanager
def _recording(target: Path | None, signals: recorder.Layout,
               rows: int) -> Iterator[recorder.Arrays | RunWriter]:
    """Where the samples go: arrays in memory, or (``target``) a run file written through a
    temporary file that becomes ``target`` only when the block completes."""
    if target is None:
        yield recorder.Arrays(signals, rows)
        return
    with atomic_path(target) as tmp:
        writer = RunWriter(tmp, signals, rows)
        try:
            yield writer
        finally:
            writer.close()


def _plant(spec_or_plant: SpecLike | Plant, *, dt: float | None, overrides: Any,
           integrator: str | None) -> Plant:
    if isinstance(spec_or_plant, Plant):
        plant = spec_or_plant
        if overrides:
            raise InputError("overrides apply to a spec; build the Plant from "
                             "spec.with_overrides(...) instead")
        if dt is not None and not math.isclose(dt, plant.dt, rel_tol=1e-12):
            raise InputError(f"the plant steps with dt={plant.dt:g}; got dt={dt!r} (build "
                             f"Plant(spec, dt={dt!r}) for another step)")
        have = integrator_name(plant.integrator)
        if integrator is not None and integrator != have:
            raise InputError(f"the plant's integrator is {have!r}; got integrator={integrator!r}")
        return plant
    spec = resolve_spec(spec_or_plant)
    known = None
    if overrides:  # a variant runs at its arm's step: one measurement for a whole sweep
        known = arm_accuracy(spec)
        spec = spec.with_overrides(overrides)
    return Plant(spec, dt=dt, integrator=integrator or "RK4", accuracy=known)


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


def _supply_signal(supply: Any) -> Signal:
    """``simulate``'s ``supply`` as a signal."""
    try:
        return as_signal(supply)
    except TypeError as exc:
        raise InputError(f"supply: {exc}") from None


def _sample_every(dt: float, sample_dt: float | None) -> int:
    if sample_dt is None:
        return max(1, round(1.0 / (MAX_SAMPLE_RATE * dt)))
    if isinstance(sample_dt, bool) or not (isinstance(sample_dt, (int, float)) and
                                           math.isfinite(sample_dt) and sample_dt > 0.0):
        raise InputError(f"sample_dt must be a positive number of seconds, got {sample_dt!r}")
    return max(1, round(min(sample_dt / dt, budget.MAX_STEPS)))


def _controller_period(controller: Controller | None) -> float | None:
    if controller is None:
        return None
    if not callable(controller) and not callable(getattr(controller, "output", None)):
        raise InputError(f"controller must be callable (t, state) -> commands or have an "
                         f"output(t, state) method, got {controller!r}")
    period = getattr(controller, "dt", None)
    if period is None:
        return None
    if not (isinstance(period, (int, float)) and math.isfinite(period) and period > 0.0):
        raise InputError(f"controller.dt must be a positive number of seconds, got {period!r}")
    return float(period)


def _call(controller: Controller, t: float, plant: Plant) -> list[float]:
    commands = (controller if callable(controller) else controller.output)(t, plant.state())
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


def _call_times(t0: float, dt: float, steps: int, period: float | None) -> np.ndarray:
    """The times the run loop calls the controller at (as ``ml_plant_run`` decides them)."""
    out, next_call = [], t0
    for k in range(steps):
        t = t0 + k * dt
        if t >= next_call - 1e-9 * dt:
            out.append(t)
            next_call = next_call + period if period else t
    return np.array(out)


class _Loop:
    """One run of the plant in C (``ml_plant_run``): its inputs, controller and record buffers.

    The C loop pauses every ``CHUNK`` steps (:meth:`go` returns True), so that a progress bar
    moves and Ctrl-C is answered; at each pause the rows recorded go, as signals, to the sink and
    the next chunk's inputs are sampled, so the loop's own memory is one chunk's, whatever the
    run's length. A controller written in Python is called back at its samples, one that has a
    native form (``controller.native(plant, times)``) runs inside the loop.
    """

    CHUNK = recorder.CHUNK

    def __init__(self, plant: Plant, steps: int, every: int, drive: list[tuple[int, Signal]],
                 controller: Controller | None, period: float | None,
                 sink: recorder.Sink) -> None:
        self.plant, self.steps, self.drive, self.sink = plant, steps, drive, sink
        self.t0, self.dt = t0, dt = plant.t, plant.dt
        self.buffers = recorder.buffers(plant, self.CHUNK // every + 2)
        plant.energy.zero(plant.data)
        self.table: np.ndarray | None = None  # the inputs of samples table_k0, table_k0 + 1, ...
        self.table_k0 = 0
        self.held = np.zeros(plant.n)
        self.error: BaseException | None = None
        self._native: Any = None
        self.columns = plant.n + any(j == plant.n for j, _ in drive)  # a measured supply last
        plant.data.userdata[:] = 0.0  # no measured supply unless this run gives one
        function, context = self._controller(controller, steps, period)
        self.run = native.RunStruct(
            steps=steps, t0=t0, dt=dt, k=0, max_steps=self.CHUNK, inputs=None, inputs_k0=0,
            held=native.pointer(self.held), controller=function, controller_context=context,
            period=period or 0.0, next_call=t0, every=min(every, steps), rows=0,
            ee_body=plant.model.body(END_EFFECTOR).id, columns=self.columns)
        self.buffers.bind(self.run)

    def _controller(self, controller: Controller | None, steps: int,
                    period: float | None) -> tuple[int | None, int | None]:
        """The C function and context that the loop calls the controller through."""
        if controller is None:
            return None, None
        make = getattr(controller, "native", None)
        if callable(make):
            times = _call_times(self.plant.t, self.plant.dt, steps, period)
            self._native = make(self.plant, times)
            if self._native is not None:
                return int(self._native.function), int(self._native.context)
        self._trampoline = native.CONTROLLER(self._call)
        self._python = controller
        return ctypes.cast(self._trampoline, ctypes.c_void_p).value, None

    def _call(self, context: Any, t: float, m: Any, d: Any, u: Any) -> int:
        try:
            held = _call(self._python, t, self.plant)
            for j, x in enumerate(held):
                u[j] = x
            return 0
        except BaseException as exc:  # noqa: BLE001 - raised by go() after the loop stops
            self.error = exc
            return 1

    def _window(self) -> None:
        """Sample the inputs of the samples the next call can reach: k to k + CHUNK."""
        if not self.drive:
            return
        k0 = self.run.k
        times = self.t0 + np.arange(k0, min(k0 + self.CHUNK, self.steps) + 1) * self.dt
        table = np.zeros((len(times), self.columns))
        for j, signal in self.drive:
            table[:, j] += signal.sample(times)
        if self.columns > self.plant.n:
            _check_supply(table[:, -1], times)
        self.table, self.table_k0 = table, k0
        self.run.inputs, self.run.inputs_k0 = native.pointer(table), k0

    def _take(self) -> None:
        """Hand the rows recorded since the last pause to the sink; empty the buffers."""
        raw = self.buffers.head(self.run.rows)
        self.sink.put(raw["t"], recorder.derive(self.plant, raw))
        self.run.rows = 0

    def go(self) -> bool:
        """Run on; True when the loop paused (call again), False when the run is done.

        Raises:
            InputError: a non-finite command (of the inputs or a controller).
            InstabilityError, PluginError: the plant's errors (:meth:`Plant.check`).
            Any exception the Python controller, an input signal or the sink raised.
        """
        self._window()
        status = self.plant._c.run(self.run)
        if status in (native.OK, native.PAUSED):
            self._take()
        if status == native.PAUSED:
            return True
        if status == native.CONTROLLER_ERROR:
            if self.error is not None:
                raise self.error
            error = self.plant._c.error()
            message = getattr(self._native, "message", lambda: None)()
            raise InputError(f"controller at t = {error.time:.6g} s: "
                             f"{message or 'its command is not finite (NaN or infinity)'}")
        if status == native.BAD_COMMAND:
            k = self.run.k
            inputs = self.table[k - self.table_k0, :self.plant.n] if self.table is not None else 0.0
            t = self.plant._c.error().time
            raise InputError(f"non-finite command at t = {t:.6g} s: "
                             f"{dict(zip(self.plant.joint_names, (self.held + inputs).tolist()))}")
        self.plant.check(status)
        return False


def _check_supply(pressures: np.ndarray, times: np.ndarray) -> None:
    """A measured supply pressure is positive and finite at every sample (Pa)."""
    bad = ~(np.isfinite(pressures) & (pressures > 0.0))
    if bad.any():
        k = int(np.argmax(bad))
        raise InputError(f"supply: the measured supply pressure is {pressures[k]:.6g} Pa at "
                         f"t = {times[k]:.6g} s; it must be a positive number of pascals")


def _meta(plant: Plant, inputs: Mapping[Any, Any], controller: Controller | None,
          period: float | None, overrides: Any, initial: Any, steps: int, every: int,
          label: str | None) -> dict[str, Any]:
    meta: dict[str, Any] = {
        "dt": plant.dt,
        "integrator": integrator_name(plant.integrator),
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


@functools.cache
def _version(package: str) -> str:
    try:
        return version(package)
    except PackageNotFoundError:
        return "unknown"
