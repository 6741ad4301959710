"""CascadeController: the paper's Fig. 8 cascade, composed from the blocks of this package.

Each controller sample (at ``rate`` Hz, zero-order hold in between):

1. G3: pose x = (p, R) and twist J q̇ from the joint sensors;
2. outer loop: a_x = ẍ_d + PID(x_d - x, ẋ_d - J q̇) on the task rows (position, or pose);
3. q̈_d = J⁺(a_x - J̇q̇) by damped least squares (+ null-space damping on a redundant arm);
4. G1: τ_d = M q̈_d + C q̇ + G + Fv q̇;
5. each joint's actuator drive turns τ_d into its command (:meth:`ActuatorPlugin.drive
   <maniplab.actuators.ActuatorPlugin.drive>`): on a hydraulic joint the paper's inner loop,
   ΔP_d = τ_d / A, the flow Φ from the pressure and speed errors plus the piston's flow, and G2,
   the valve inversion Φ -> i_v (clipped); a torque joint gets τ_d itself; another plugin its
   steady-state inversion, or the controller refuses it (naming the joint) when it declares none.

``mode="pid"`` is the baseline without feedback linearisation: the Cartesian error is mapped to
joint errors by the same damped least squares and a PID per joint commands a joint speed, which a
valve's drive turns into a current directly (a drive without a speed command gets the speed
times the joint's inertia as a force).

The sample runs in C (``maniplab_native/cascade.c``, through :mod:`~maniplab.control.native`),
a few microseconds on a 6-joint arm: the blocks above give it their settings, and the C code
computes what they compute. Joints whose drive is a plugin's Python (a drive without
:meth:`~maniplab.actuators.ForceDrive.compiled`) get their command from that drive, from the
desired forces (or joint speeds) the C sample leaves. :meth:`CascadeController.native` gives the
plant's run loop the sample as a C function, for runs with no Python per sample.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from maniplab.actuators import ActuatorPlugin, ForceDrive
from maniplab.clib import Functions
from maniplab.control.errors import ControlError
from maniplab.control.interface import TOLERANCES, Controller, with_reference
from maniplab.control.inverse_dynamics import InverseDynamics
from maniplab.control.kinematics import Kinematics, matrix_to_rpy
from maniplab.control.native import (
    AUX_INERTIA,
    AUX_QD_REF,
    AUX_SPEED,
    AUX_TAU,
    DRIVES,
    REF_SIZE,
    CompiledCascade,
    NativeController,
    pack_reference,
)
from maniplab.control.pid import PID
from maniplab.control.trajectory import Trajectory
from maniplab.control.tuning import resolve
from maniplab.model import AnalyticModel
from maniplab.spec import ControlSpec, ManipulatorSpec, models_of

MODES = ("cascade", "pid")

#: Signals the controller logs, one row per controller sample: name -> (description, unit).
LOG_SIGNALS: dict[str, tuple[str, str]] = {
    "x_d": ("reference pose [x, y, z, roll, pitch, yaw]", "m | rad"),
    "x": ("pose from the joint sensors (G3) [x, y, z, roll, pitch, yaw]", "m | rad"),
    "e_x": ("task error [p_d - p; rotation vector of R_d Rᵀ] (NaN off the task rows)", "m | rad"),
    "a_x": ("outer-loop Cartesian acceleration (6; NaN off the task rows)", "m/s² | rad/s²"),
    "qdd_d": ("desired joint accelerations", "rad/s² | m/s²"),
    "tau_d": ("G1 joint forces", "N·m | N"),
    "cmd": ("command: valve current i_v, or force at torque joints, or a plugin's command",
            "A | N·m | N | ..."),
}
"""The cascade's own log; the drives add theirs (e.g. the hydraulic ``dP_d`` and ``phi``)."""

_BUFFERS = {"x_d": "x_d", "x": "x", "e_x": "e", "a_x": "a_x", "qdd_d": "qdd", "tau_d": "tau",
            "dP_d": "dP_d", "pL_d": "dP_d", "phi": "phi", "cmd": "cmd"}
"""Signals the compiled sample logs -> its log buffer (:data:`~maniplab.control.native.LOG_FIELDS`)."""


def _read(state: Any, name: str) -> np.ndarray | None:
    """A state field by key or attribute (q, qd, dP, a plugin's state such as pA), or None when
    the state has none."""
    if isinstance(state, Mapping):
        value = state.get(name)
    else:
        value = getattr(state, name, None)
        states = getattr(state, "states", None)
        if value is None and isinstance(states, Mapping):  # a PlantState's plugin states
            value = states.get(name)
    return None if value is None else np.asarray(value, dtype=float)


class CascadeController:
    """Feedback-linearised cascade controller (or the PID-only baseline) for one arm.

    Call it as ``controller(t, state) -> commands``; it is a valid ``controller`` for
    ``ml.simulate``. It samples at its own ``rate`` and holds its command in between, whatever
    rate it is called at; its internal signals are in :meth:`signals`.

    Args:
        spec: the arm as the controller knows it (its masses and payload are the controller's
            estimates; the plant may differ).
        trajectory: the Cartesian reference (see ``maniplab.control.trajectory``).
        gains: controller settings; default the spec's ``control`` section; what they leave out
            is derived from the arm (:mod:`~maniplab.control.tuning`).
        mode: "cascade" (feedback linearisation) or "pid" (the PID-only baseline).
        model: a ready analytic model of ``spec`` (saves building one).
        joint_path: the planned joint path, ``joint_path(t) -> (q, q̇)`` each (n,) (e.g. a
            :class:`~maniplab.control.point_to_point.MovePlan`'s ``joint_reference``): on a
            redundant arm the task's null space pulls the joints towards it (stiffness
            (null_damping/2)², damping null_damping), so they follow the path the planner
            checked instead of drifting onto a limit. None: null-space damping only. A path
            whose function has ``accepts_arrays = True`` (as ``joint_reference``) is evaluated
            at all of a run's samples in one call (times (K,) -> each (K, n)).
        **settings: fields of :class:`~maniplab.spec.ControlSpec` to replace, e.g. ``rate=500.0``.

    Attributes:
        dt: sample time, s.  rows: task rows of the Jacobian, e.g. [0, 1, 2].
        outer, joint_pid, g1, drives: the blocks (the outer PID, the baseline's joint PID, G1,
            one drive per actuator class) whose settings the compiled sample runs with.
    """

    def __init__(self, spec: ManipulatorSpec, trajectory: Trajectory, *,
                 gains: ControlSpec | None = None, mode: str = "cascade",
                 model: AnalyticModel | None = None,
                 joint_path: Callable[[float], tuple[np.ndarray, np.ndarray]] | None = None,
                 weight: np.ndarray | None = None, **settings: Any) -> None:
        if mode not in MODES:
            raise ControlError(f"unknown mode {mode!r}; expected 'cascade' or 'pid'")
        if settings:
            gains = dataclasses.replace(gains or spec.control or ControlSpec(), **settings)
        gains = resolve(spec, gains)
        self.spec, self.trajectory, self.gains, self.mode = spec, trajectory, gains, mode
        self.joint_path = joint_path
        self.weight = weight
        """The weight of a tool hanging at the end effector, N, base axes (3,), or None."""
        self.tolerances = TOLERANCES
        """(final, RMS) position error the run's health verdict allows, mm."""
        self.n = spec.n
        self.model = model or AnalyticModel(spec)
        _require_compiled(self.model)
        self.kin = Kinematics(self.model)
        self.actuators: list[ActuatorPlugin] = models_of(spec)
        self.rate = _given(gains.rate)
        self.dt = 1.0 / self.rate
        task = gains.task or ("pose" if spec.n >= 6 else "position")
        self.task = task
        self.rows = np.arange(6 if task == "pose" else 3)
        self._build_loops()
        self.reset()

    def _build_loops(self) -> None:
        g, m, n = self.gains, len(self.rows), self.n
        pos, ori = g.position, g.orientation
        pick = lambda a, b: np.array([a] * 3 + [b] * 3)[:m]
        self.outer = PID(pick(pos.kp, ori.kp), pick(pos.ki, ori.ki), pick(pos.kd, ori.kd),
                         dt=self.dt, filter_time=g.derivative_filter)
        self.g1 = InverseDynamics(self.model, coulomb=g.coulomb_feedforward, weight=self.weight)
        self.drives = _drives(self.actuators, dt=self.dt, settings=g)
        self.log_signals = {**LOG_SIGNALS, **{k: v for d in self.drives
                                               for k, v in d.signals.items()}}
        """Every signal the controller logs: the cascade's and its drives'."""
        self._needs = sorted({name for d in self.drives for name in d.needs})
        # baseline: joint speed limit = no-load speed at full command (inf where not limited)
        vmax = np.array([a.top_speed for a in self.actuators])
        b = g.pid_only
        self.joint_pid = PID(_given(b.kp), _given(b.ki), _given(b.kd), dt=self.dt, size=n,
                             limits=(-vmax, vmax))
        self._velocity_gain = _given(b.velocity_gain)
        self._limit = np.concatenate([d.limit for d in self.drives])[
            np.argsort(np.concatenate([d.joints for d in self.drives]))]
        self._redundant = n > m and g.null_damping > 0.0
        # joint weights of the least squares: each joint's top speed, relative (1 where unlimited)
        finite = np.isfinite(vmax)
        top = vmax[finite].max() if finite.any() else 1.0
        self.weights = (np.where(finite, vmax / top, 1.0) if g.capacity_weighting else None)
        self._c = CompiledCascade(self)
        self._python = self._c.python
        self._pinned = self._c.kinds == DRIVES["chambers"]
        """Joints whose drive is a pinned cylinder's (its desired load pressure in the log's
        dP_d buffer)."""
        self._extra = [k for k in self.log_signals if k not in _BUFFERS]
        """Signals only Python drives log (the C log has the others)."""

    def reset(self, state: Any = None) -> None:
        """Clear the loops' states, the held command and the log (``ml.simulate`` calls it at the
        start of every run; ``state``, the plant's state then, is not needed)."""
        self._c.reset()
        for drive in self.drives:
            drive.reset()
        self._next = -math.inf
        self._command = np.zeros(self.n)
        self._python_log: dict[str, list[np.ndarray | None]] = {k: [] for k in self._extra}

    def __deepcopy__(self, memo: dict[int, Any]) -> CascadeController:
        """A controller of the same settings with its own compiled state and log, reset; the
        analytic model (read-only) and the trajectory (frozen) are shared."""
        other = CascadeController(self.spec, self.trajectory, gains=self.gains, mode=self.mode,
                                  model=self.model, joint_path=self.joint_path,
                                  weight=self.weight)
        other.tolerances = self.tolerances
        return other

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled as its settings: unpickled (in a worker process) it rebuilds its compiled
        state, and its analytic model from the model cache, reset."""
        return (_rebuild, (self.spec, self.trajectory, self.gains, self.mode, self.tolerances,
                           self.joint_path, self.weight))

    @property
    def reference(self) -> Trajectory:
        """The Cartesian reference tracked (the controller interface's name of the trajectory)."""
        return self.trajectory

    def output(self, t: float, state: Any) -> np.ndarray:
        """The command at sample time t (the controller interface; as calling the controller)."""
        return self(t, state)

    # --- the control law ---------------------------------------------------------------------
    def __call__(self, t: float, state: Any) -> np.ndarray:
        """The command at time t for the plant state (fields q, qd and the actuator states its
        drives need, e.g. dP; a missing state reads as zeros), shape (n,).

        Between samples the last command is returned unchanged (zero-order hold).
        """
        if t < self._next - 1e-9 * self.dt:
            return self._command
        self._next = (t if self._next == -math.inf else self._next) + self.dt
        if self._next <= t:  # called late (a coarse caller): stay on the caller's clock
            self._next = t + self.dt
        q, qd = _read(state, "q"), _read(state, "qd")
        if q is None or qd is None:
            raise TypeError("the controller needs a state with fields q and qd (and dP)")
        states = {}
        for name in self._needs:
            value = _read(state, name)
            states[name] = np.zeros(self.n) if value is None else value
        self._command = self.step(t, q, qd, **states)
        return self._command

    def step(self, t: float, q: np.ndarray, qd: np.ndarray, **states: np.ndarray) -> np.ndarray:
        """One controller sample (no hold): the command for state (q, q̇, actuator states by
        name, each (n,)), shape (n,)."""
        ref = self.trajectory.sample(t)
        dP = states.get("dP")
        if dP is None and "dP" in self._needs:
            raise TypeError("the controller's hydraulic joints need the state dP")
        pB = None
        if self._pinned.any():  # a pinned cylinder's cap side goes where a lumped one's ΔP does
            dP = np.where(self._pinned, states["pA"], 0.0 if dP is None else dP)
            pB = np.where(self._pinned, states["pB"], 0.0)
        cmd = self._c.sample(t, ref, q, qd, dP, pB, self._posture(t))
        if not self._python:
            self._c.commit(cmd)
            return cmd
        rows = self._python_commands(cmd, np.asarray(q, dtype=float),
                                     np.asarray(qd, dtype=float), states)
        self._c.commit(cmd)
        self._record_python(rows)
        return cmd

    def _python_commands(self, cmd: np.ndarray, q: np.ndarray, qd: np.ndarray,
                         states: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The commands of the joints whose drive is Python's (into ``cmd``), from the forces or
        speeds the compiled sample left; returns their drives' log rows (cascade mode)."""
        aux = self._c.aux
        log: dict[str, np.ndarray] = {}
        for drive in self._python:
            j = drive.joints
            mine = {k: np.asarray(v)[j] for k, v in states.items()}
            if self.mode == "pid":  # a joint speed, or a velocity loop's force
                speed = drive.speed_command(aux[AUX_SPEED, j])
                if speed is None:
                    force = aux[AUX_INERTIA, j] * self._velocity_gain * (aux[AUX_SPEED, j] - qd[j])
                    speed = drive.command(force, q[j], qd[j], qd[j], mine)
                cmd[j] = speed
                continue
            cmd[j] = drive.command(aux[AUX_TAU, j], q[j], qd[j], aux[AUX_QD_REF, j], mine)
            for name, values in drive.log.items():
                log.setdefault(name, np.full(self.n, np.nan))[j] = values
        return log

    def _record_python(self, rows: dict[str, np.ndarray]) -> None:
        """The Python drives' signals of the sample just committed (NaN in pid mode)."""
        row = self._c.count - 1
        for name, values in rows.items():
            if name in _BUFFERS:  # a signal the C sample logs too: the Python joints' part
                buffer = self._c.log[_BUFFERS[name]]
                known = ~np.isnan(values)
                buffer[row, known] = values[known]
        for name in self._extra:
            self._python_log[name].append(rows.get(name))

    # --- the plant's run loop ----------------------------------------------------------------
    def native(self, plant: Any, times: np.ndarray) -> NativeController | None:
        """The controller as a C function the plant's run loop calls at ``times`` with no Python.

        Args:
            plant: the plant the loop steps (its joints must be this controller's).
            times: the exact sample times the loop calls the function at, s, ascending, (K,).

        Returns:
            A :class:`~maniplab.control.native.NativeController` (``function`` and ``context``
            addresses; it keeps every buffer alive), or None when a joint's drive runs in Python
            (then call the controller itself). After the run, :meth:`signals`, :attr:`times`,
            :meth:`signals_at` and :meth:`annotate` show the samples it made, after any made
            since the last :meth:`reset` (as calling the controller at those times would).

        Raises:
            ControlError: the plant has other joints than the controller's arm.
        """
        if self._python:
            return None
        n = getattr(plant, "n", self.n)
        if n != self.n:
            raise ControlError(f"the plant has {n} joints; the controller's arm has {self.n}")
        times = np.ascontiguousarray(times, dtype=float).reshape(-1)
        refs = np.empty((len(times), REF_SIZE))
        for k, t in enumerate(times):
            pack_reference(self.trajectory.sample(float(t)), refs[k])
        postures = self._postures(times)
        self._c.reserve(len(times))
        return NativeController(self._c, times, refs, postures)

    def _postures(self, times: np.ndarray) -> np.ndarray | None:
        """:meth:`_posture` at each of ``times`` (K,), (K, 2n); in one call when the joint path
        takes arrays of times (a planned move's)."""
        if self.joint_path is None:
            return None
        if getattr(self.joint_path, "accepts_arrays", False):
            q, qd = self.joint_path(times)  # type: ignore[arg-type]
            return np.concatenate([np.asarray(q, dtype=float), np.asarray(qd, dtype=float)],
                                  axis=1)
        return np.array([self._posture(float(t)) for t in times]).reshape(len(times), -1)

    def _posture(self, t: float) -> np.ndarray | None:
        """The planned joint path's (q, q̇) at t, (2n,), or None without one."""
        if self.joint_path is None:
            return None
        q, qd = self.joint_path(t)
        return np.concatenate([np.asarray(q, dtype=float), np.asarray(qd, dtype=float)])

    # --- the log -----------------------------------------------------------------------------
    @property
    def times(self) -> np.ndarray:
        """Sample times of the log, s, shape (K,)."""
        return self._c.rows_of("t")

    def signals(self) -> dict[str, np.ndarray]:
        """The logged signals (see ``LOG_SIGNALS``), name -> array (K, k), one row per sample."""
        n = self.n
        out = {}
        for k in self.log_signals:
            if k in ("x_d", "x"):  # logged as (p, R): written as [x, y, z, roll, pitch, yaw]
                rows = self._c.rows_of(_BUFFERS[k])
                out[k] = np.array([np.concatenate([r[:3], matrix_to_rpy(r[3:].reshape(3, 3))])
                                   for r in rows]).reshape(len(rows), 6)
            elif k in ("dP_d", "pL_d"):  # one buffer: ΔP_d at lumped joints, p_Ld at pinned
                rows = self._c.rows_of("dP_d")
                rows[:, self._pinned if k == "dP_d" else ~self._pinned] = np.nan
                out[k] = rows
            elif k in _BUFFERS:
                out[k] = self._c.rows_of(_BUFFERS[k])
            else:
                v = self._python_log[k]
                nan = np.full(n, np.nan)
                out[k] = (np.stack([nan if x is None else x for x in v]) if v
                          else np.zeros((0, n)))
        return out

    def signals_at(self, t: np.ndarray) -> dict[str, np.ndarray]:
        """The logged signals resampled at times ``t`` (zero-order hold), name -> (len(t), k).

        Names are ``ctrl.<signal>``; rows before the first controller sample are NaN.
        """
        times = self.times
        idx = np.searchsorted(times, np.asarray(t) + 1e-12, side="right") - 1
        out = {}
        for k, v in self.signals().items():
            rows = v[np.clip(idx, 0, None)] if len(v) else np.full((len(idx), v.shape[1]), np.nan)
            rows = rows.astype(float, copy=True)
            rows[idx < 0] = np.nan
            out[f"ctrl.{k}"] = rows
        return out

    def settings(self) -> dict[str, Any]:
        """What the controller was (JSON-friendly): mode, task, rate and every gain."""
        return {
            "mode": self.mode, "task": self.task, "rate": self.rate,
            "model_payload": self.spec.end_effector.mass,
            "gains": _plain(dataclasses.asdict(self.gains)),
        }

    def annotate(self, run: Any) -> Any:
        """The run with the controller's log added: a new Run of the same type.

        Signals ``x_d``, ``x``, ``e_x``, ``a_x``, ``qdd_d``, ``tau_d``, ``dP_d``, ``phi`` (see
        ``LOG_SIGNALS``; the command is the run's own ``ctrl``) are resampled onto ``run.t``
        (zero-order hold), ``p_ref`` is the trajectory's position at every sample, and
        ``meta["control"]`` records :meth:`settings`, ``meta["reference"]`` the move's window and
        :attr:`tolerances` (which the run's health verdict checks).
        """
        extra = {k.removeprefix("ctrl."): v for k, v in self.signals_at(run.t).items()
                 if k != "ctrl.cmd"}
        units = {k: unit for k, (_, unit) in self.log_signals.items() if k in extra}
        try:
            out = with_reference(run, self.trajectory, self.tolerances, extra, units)
        except ValueError as exc:
            raise ControlError(str(exc)) from None
        return type(out)(t=out.t, signals=out.signals, spec=out.spec,
                         meta={**dict(out.meta), "control": self.settings()})


Controller.register(CascadeController)


def _rebuild(spec: ManipulatorSpec, trajectory: Trajectory, gains: ControlSpec, mode: str,
             tolerances: tuple[float, float], joint_path: Any = None,
             weight: np.ndarray | None = None) -> CascadeController:
    """A pickled :class:`CascadeController` back (``CascadeController.__reduce__``)."""
    controller = CascadeController(spec, trajectory, gains=gains, mode=mode,
                                   joint_path=joint_path, weight=weight)
    controller.tolerances = tolerances
    return controller


def _require_compiled(model: AnalyticModel) -> None:
    """The cascade's sample is C: a model on the Python backend (no C compiler) cannot serve it.

    Raises:
        ModelError: no C compiler (the native library cannot be built), one line.
        ControlError: the model was made with ``backend="python"``.
    """
    if model.backend == "c":
        return
    Functions({})()  # without a compiler: the library's one-line error
    raise ControlError(f"the cascade controller runs compiled: its model of {model.spec.name} "
                       f"must have the C backend, not {model.backend!r}")


def _given(value: Any) -> Any:
    """A gain that :func:`~maniplab.control.tuning.resolve` has filled in."""
    assert value is not None, "resolve() fills in every gain"
    return value


def _drives(actuators: list[ActuatorPlugin], *, dt: float,
            settings: ControlSpec) -> list[ForceDrive]:
    """One drive per actuator class, over the joints that have it (CapabilityError, naming the
    joints, where a class cannot be driven)."""
    groups: dict[type[ActuatorPlugin], list[int]] = {}
    for j, a in enumerate(actuators):
        groups.setdefault(type(a), []).append(j)
    return [cls.drive([actuators[j] for j in joints], joints, dt=dt, settings=settings)
            for cls, joints in groups.items()]


def _plain(value: Any) -> Any:
    """Enums, tuples and numpy scalars to JSON-friendly values."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "value") and not isinstance(value, (int, float, str)):
        return value.value
    return value
