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
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from maniplab.actuators import ActuatorPlugin, ForceDrive
from maniplab.control.errors import ControlError
from maniplab.control.inverse_dynamics import InverseDynamics
from maniplab.control.kinematics import DampedLeastSquares, Kinematics, matrix_to_rpy, rotation_log
from maniplab.control.pid import PID
from maniplab.control.trajectory import Trajectory
from maniplab.control.tuning import resolve
from maniplab.model import AnalyticModel
from maniplab.spec import ControlSpec, ManipulatorSpec, model_of

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


def _read(state: Any, name: str) -> np.ndarray | None:
    """A state field by attribute or key (q, qd, dP), or None when the state has none."""
    value = state.get(name) if isinstance(state, Mapping) else getattr(state, name, None)
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
        **settings: fields of :class:`~maniplab.spec.ControlSpec` to replace, e.g. ``rate=500.0``.

    Attributes:
        dt: sample time, s.  rows: task rows of the Jacobian, e.g. [0, 1, 2].
    """

    def __init__(self, spec: ManipulatorSpec, trajectory: Trajectory, *,
                 gains: ControlSpec | None = None, mode: str = "cascade",
                 model: AnalyticModel | None = None, **settings: Any) -> None:
        if mode not in MODES:
            raise ControlError(f"unknown mode {mode!r}; expected 'cascade' or 'pid'")
        if settings:
            gains = dataclasses.replace(gains or spec.control or ControlSpec(), **settings)
        gains = resolve(spec, gains)
        self.spec, self.trajectory, self.gains, self.mode = spec, trajectory, gains, mode
        self.n = spec.n
        self.model = model or AnalyticModel(spec)
        self.kin = Kinematics(self.model)
        self.actuators: list[ActuatorPlugin] = [model_of(j) for j in spec.joints]
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
        self.g1 = InverseDynamics(self.model, coulomb=g.coulomb_feedforward)
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
        self._nan_n, self._nan_6 = np.full(n, np.nan), np.full(6, np.nan)
        self._redundant = n > m and g.null_damping > 0.0
        # joint weights of the least squares: each joint's top speed, relative (1 where unlimited)
        finite = np.isfinite(vmax)
        top = vmax[finite].max() if finite.any() else 1.0
        self.weights = (np.where(finite, vmax / top, 1.0) if g.capacity_weighting else None)

    def reset(self) -> None:
        """Clear the loops' states, the held command and the log."""
        self.outer.reset()
        for drive in self.drives:
            drive.reset()
        self.joint_pid.reset()
        self._next = -math.inf
        self._command = np.zeros(self.n)
        self._saturated = False
        self._log: dict[str, list[Any]] = {k: [] for k in ("t", *self.log_signals)}

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
        p, R = self.kin.pose(q)
        J = self.kin.jacobian(q)
        rows = self.rows
        m = len(rows)
        e = self._nan_6.copy()  # logged; the orientation part only on a pose task
        e[:3] = ref.position - p
        if m == 6:
            e[3:] = rotation_log(ref.rotation @ R.T)
        Js = J[:m]
        de = ref.twist[:m] - Js @ qd
        dls = DampedLeastSquares(Js, damping=self.gains.dls_damping,
                                 threshold=self.gains.dls_threshold, weights=self.weights)
        if self.mode == "pid":
            cmd, log = self._pid_only(q, qd, states, dls, e[:m], de)
        else:
            cmd, log = self._cascade(q, qd, states, ref, dls, e[:m], de)
        self._record(t, ref, p, R, e, log, cmd)
        return cmd

    def _cascade(self, q: np.ndarray, qd: np.ndarray, states: dict[str, np.ndarray], ref: Any,
                 dls: DampedLeastSquares, e: np.ndarray, de: np.ndarray
                 ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        m = len(self.rows)
        a_x = ref.accel[:m] + self.outer.update(e, de, freeze=self._saturated)
        rhs = np.empty((m, 3))
        rhs[:, 0] = a_x - self.kin.bias_acceleration(q, qd)[:m]
        rhs[:, 1] = ref.twist[:m]
        rhs[:, 2] = dls.J @ qd
        sol = dls.solve(rhs)
        qdd, qd_ref = sol[:, 0], sol[:, 1]
        if self._redundant:  # null-space damping: (I - J⁺J) q̇ = q̇ - J⁺(J q̇)
            qdd = qdd - self.gains.null_damping * (qd - sol[:, 2])
        tau = self.g1.torque(q, qd, qdd, qd_ref)
        cmd = np.empty(self.n)
        log: dict[str, np.ndarray] = {}
        for drive in self.drives:
            j = drive.joints
            cmd[j] = drive.command(tau[j], q[j], qd[j], qd_ref[j],
                                   {k: v[j] for k, v in states.items()})
            for name, values in drive.log.items():
                log.setdefault(name, self._nan_n.copy())[j] = values
        self._saturated = bool((np.abs(cmd) >= self._limit).any())
        a_full = self._nan_6.copy()
        a_full[:m] = a_x
        return cmd, {"a_x": a_full, "qdd_d": qdd, "tau_d": tau, **log}

    def _pid_only(self, q: np.ndarray, qd: np.ndarray, states: dict[str, np.ndarray],
                  dls: DampedLeastSquares, e: np.ndarray, de: np.ndarray
                  ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        sol = dls.solve(np.stack([e, de], axis=1))
        u = self.joint_pid.update(sol[:, 0], sol[:, 1])  # joint speeds
        cmd = np.empty(self.n)
        inertia = None
        for drive in self.drives:
            j = drive.joints
            speed = drive.speed_command(u[j])
            if speed is None:  # not a speed source: a velocity loop gives it a force
                inertia = np.diagonal(self.model.M(q)) if inertia is None else inertia
                force = inertia[j] * self._velocity_gain * (u[j] - qd[j])
                speed = drive.command(force, q[j], qd[j], qd[j],
                                      {k: v[j] for k, v in states.items()})
            cmd[j] = speed
        nan6, nan = np.full(6, np.nan), np.full(self.n, np.nan)
        return cmd, {"a_x": nan6, "qdd_d": nan, "tau_d": nan,
                     **{k: nan for d in self.drives for k in d.signals}}

    # --- the log -----------------------------------------------------------------------------
    def _record(self, t: float, ref: Any, p: np.ndarray, R: np.ndarray, e: np.ndarray,
                log: dict[str, np.ndarray], cmd: np.ndarray) -> None:
        L = self._log
        L["t"].append(t)
        L["x_d"].append((ref.position, ref.rotation))
        L["x"].append((p, R))
        L["e_x"].append(e)
        for k in self.log_signals:
            if k not in ("x_d", "x", "e_x", "cmd"):
                L[k].append(log.get(k))
        L["cmd"].append(cmd.copy())

    @property
    def times(self) -> np.ndarray:
        """Sample times of the log, s, shape (K,)."""
        return np.array(self._log["t"], dtype=float)

    def signals(self) -> dict[str, np.ndarray]:
        """The logged signals (see ``LOG_SIGNALS``), name -> array (K, k), one row per sample."""
        n = self.n
        width = {"x_d": 6, "x": 6, "e_x": 6, "a_x": 6}
        nan = np.full(n, np.nan)
        out = {}
        for k, v in self._log.items():
            if k == "t":
                continue
            if not v:
                out[k] = np.zeros((0, width.get(k, n)))
            elif k in ("x_d", "x"):  # stored as (p, R): written as [x, y, z, roll, pitch, yaw]
                out[k] = np.array([np.concatenate([p, matrix_to_rpy(R)]) for p, R in v])
            else:
                out[k] = np.stack([nan if x is None else x for x in v])
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
        (zero-order hold) and ``meta["control"]`` records :meth:`settings`.
        """
        extra = {k.removeprefix("ctrl."): v for k, v in self.signals_at(run.t).items()
                 if k != "ctrl.cmd"}
        clash = sorted(set(extra) & set(run.signals))
        if clash:
            raise ControlError(f"the run already has signals {clash}")
        meta = {**dict(run.meta), "control": self.settings()}
        return type(run)(t=run.t, signals={**run.signals, **extra}, spec=run.spec, meta=meta)


def _given(value: float | None) -> float:
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
