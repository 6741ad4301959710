"""CascadeController: the paper's Fig. 8 cascade, composed from the blocks of this package.

Each controller sample (at ``rate`` Hz, zero-order hold in between):

1. G3: pose x = (p, R) and twist J q̇ from the joint sensors;
2. outer loop: a_x = ẍ_d + PID(x_d - x, ẋ_d - J q̇) on the task rows (position, or pose);
3. q̈_d = J⁺(a_x - J̇q̇) by damped least squares (+ null-space damping on a redundant arm);
4. G1: τ_d = M q̈_d + C q̇ + G + Fv q̇, then ΔP_d = τ_d / A at hydraulic joints;
5. inner loop: flow Φ from the pressure and speed errors plus the piston's flow;
6. G2: valve inversion Φ -> i_v (clipped). Torque joints get τ_d directly.

``mode="pid"`` is the baseline without feedback linearisation: the Cartesian error is mapped to
joint errors by the same damped least squares and a PID per joint commands the valve directly.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from maniplab.control.actuation import ActuatorArrays
from maniplab.control.inverse_dynamics import InverseDynamics
from maniplab.control.kinematics import DampedLeastSquares, Kinematics, matrix_to_rpy, rotation_log
from maniplab.control.pid import PID
from maniplab.control.pressure import PressureLoop
from maniplab.control.trajectory import Trajectory
from maniplab.control.valve import valve_current
from maniplab.model import AnalyticModel
from maniplab.spec import ControlSpec, ManipulatorSpec

MODES = ("cascade", "pid")

#: Signals the controller logs, one row per controller sample: name -> (description, unit).
LOG_SIGNALS: dict[str, tuple[str, str]] = {
    "x_d": ("reference pose [x, y, z, roll, pitch, yaw]", "m | rad"),
    "x": ("pose from the joint sensors (G3) [x, y, z, roll, pitch, yaw]", "m | rad"),
    "e_x": ("task error [p_d - p; rotation vector of R_d Rᵀ] (NaN off the task rows)", "m | rad"),
    "a_x": ("outer-loop Cartesian acceleration (6; NaN off the task rows)", "m/s² | rad/s²"),
    "qdd_d": ("desired joint accelerations", "rad/s² | m/s²"),
    "tau_d": ("G1 joint forces", "N·m | N"),
    "dP_d": ("desired differential pressure (NaN at torque joints)", "Pa"),
    "phi": ("flow command Φ (NaN at torque joints)", "m³/s"),
    "cmd": ("command: valve current i_v, or force at torque joints", "A | N·m | N"),
}


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
        gains: controller settings; default the spec's ``control`` section, else the defaults.
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
            raise ValueError(f"unknown mode {mode!r}; expected 'cascade' or 'pid'")
        gains = gains or spec.control or ControlSpec()
        if settings:
            gains = dataclasses.replace(gains, **settings)
        self.spec, self.trajectory, self.gains, self.mode = spec, trajectory, gains, mode
        self.n = spec.n
        self.model = model or AnalyticModel(spec)
        self.kin = Kinematics(self.model)
        self.act = ActuatorArrays.from_spec(spec)
        self.rate = gains.rate
        self.dt = 1.0 / gains.rate
        task = gains.task or ("pose" if spec.n >= 6 else "position")
        self.task = task
        self.rows = np.arange(6 if task == "pose" else 3)
        self._build_loops()
        self.reset()

    def _build_loops(self) -> None:
        g, m, n = self.gains, len(self.rows), self.n
        pos, ori = g.position, g.orientation
        pick = lambda a, b: np.array([a] * 3 + [b] * 3)[:m]  # noqa: E731
        self.outer = PID(pick(pos.kp, ori.kp), pick(pos.ki, ori.ki), pick(pos.kd, ori.kd),
                         dt=self.dt, filter_time=g.derivative_filter)
        self.g1 = InverseDynamics(self.model, coulomb=g.coulomb_feedforward)
        p = g.pressure
        self.pressure = PressureLoop(self.act, dt=self.dt, bandwidth=p.bandwidth,
                                     integral=p.integral, speed_gain=p.speed_gain,
                                     rate_filter=p.rate_filter)
        # baseline: joint speed limit = no-load speed at full current (none at torque joints)
        vmax = np.where(self.act.hydraulic, self.act.current_limit * self.act.valve_gain
                        / self.act.area, np.inf)
        b = g.pid_only
        self.joint_pid = PID(b.kp, b.ki, b.kd, dt=self.dt, size=n, limits=(-vmax, vmax))
        self._limit = self.act.command_limit
        hyd = np.flatnonzero(self.act.hydraulic)
        self._h: Any = slice(None) if len(hyd) == n else hyd  # a view when every joint is
        self._has_h = len(hyd) > 0
        self._torque = np.flatnonzero(~self.act.hydraulic)
        self._nan_n, self._nan_6 = np.full(n, np.nan), np.full(6, np.nan)
        self._area = self.act.area[self._h]
        self._cv = self.act.valve_gain[self._h]
        self._ps = self.act.supply_pressure[self._h]
        self._imax = self.act.current_limit[self._h]
        self._redundant = n > m and g.null_damping > 0.0
        # joint weights of the least squares: each joint's top speed, relative (1 at torque joints)
        speed = np.where(self.act.hydraulic, vmax, np.nan)
        top = np.nanmax(speed) if self.act.hydraulic.any() else 1.0
        self.weights = (np.where(self.act.hydraulic, speed / top, 1.0)
                        if g.capacity_weighting else None)

    def reset(self) -> None:
        """Clear the loops' states, the held command and the log."""
        self.outer.reset()
        self.pressure.reset()
        self.joint_pid.reset()
        self._next = -math.inf
        self._command = np.zeros(self.n)
        self._saturated = False
        self._log: dict[str, list[np.ndarray]] = {k: [] for k in ("t", *LOG_SIGNALS)}

    # --- the control law ---------------------------------------------------------------------
    def __call__(self, t: float, state: Any) -> np.ndarray:
        """The command at time t for the plant state (fields q, qd, dP), shape (n,).

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
        dP = _read(state, "dP")
        if dP is None:
            dP = np.zeros(self.n)
        self._command = self.step(t, q, qd, dP)
        return self._command

    def step(self, t: float, q: np.ndarray, qd: np.ndarray, dP: np.ndarray) -> np.ndarray:
        """One controller sample (no hold): the command for state (q, q̇, ΔP), shape (n,)."""
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
            cmd, log = self._pid_only(q, dls, e[:m], de)
        else:
            cmd, log = self._cascade(q, qd, dP, ref, dls, e[:m], de)
        self._record(t, ref, p, R, e, log, cmd)
        return cmd

    def _cascade(self, q: np.ndarray, qd: np.ndarray, dP: np.ndarray, ref: Any,
                 dls: DampedLeastSquares, e: np.ndarray, de: np.ndarray
                 ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        m, act, h = len(self.rows), self.act, self._h
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
        cmd = np.clip(tau, -act.torque_limit, act.torque_limit) if self._torque.size else tau.copy()
        dP_d, phi = self._nan_n.copy(), self._nan_n.copy()
        if self._has_h:
            dPd_h = tau[h] / self._area
            dP_h = dP[h]
            phi_h = self.pressure.flow(dPd_h, dP_h, qd[h], qd_ref[h])
            cmd[h] = valve_current(phi_h, dP_h, self._cv, self._ps, self._imax,
                                   min_root=self.gains.valve_min_root)
            dP_d[h], phi[h] = dPd_h, phi_h
        self._saturated = bool((np.abs(cmd) >= self._limit).any())
        a_full = self._nan_6.copy()
        a_full[:m] = a_x
        return cmd, {"a_x": a_full, "qdd_d": qdd, "tau_d": tau, "dP_d": dP_d, "phi": phi}

    def _pid_only(self, q: np.ndarray, dls: DampedLeastSquares, e: np.ndarray, de: np.ndarray
                  ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        act = self.act
        sol = dls.solve(np.stack([e, de], axis=1))
        u = self.joint_pid.update(sol[:, 0], sol[:, 1])
        iv = np.clip(u * act.area / act.valve_gain, -act.current_limit, act.current_limit)
        inertia = np.diagonal(self.model.M(q)) if not act.hydraulic.all() else 1.0
        tau = np.clip(u * inertia, -act.torque_limit, act.torque_limit)
        cmd = np.where(act.hydraulic, iv, tau)
        nan6, nan = np.full(6, np.nan), np.full(self.n, np.nan)
        return cmd, {"a_x": nan6, "qdd_d": nan, "tau_d": nan, "dP_d": nan, "phi": nan}

    # --- the log -----------------------------------------------------------------------------
    def _record(self, t: float, ref: Any, p: np.ndarray, R: np.ndarray, e: np.ndarray,
                log: dict[str, np.ndarray], cmd: np.ndarray) -> None:
        L = self._log
        L["t"].append(t)
        L["x_d"].append((ref.position, ref.rotation))
        L["x"].append((p, R))
        L["e_x"].append(e)
        for k, v in log.items():
            L[k].append(v)
        L["cmd"].append(cmd.copy())

    @property
    def times(self) -> np.ndarray:
        """Sample times of the log, s, shape (K,)."""
        return np.array(self._log["t"], dtype=float)

    def signals(self) -> dict[str, np.ndarray]:
        """The logged signals (see ``LOG_SIGNALS``), name -> array (K, k), one row per sample."""
        n = self.n
        width = {"x_d": 6, "x": 6, "e_x": 6, "a_x": 6}
        out = {}
        for k, v in self._log.items():
            if k == "t":
                continue
            if not v:
                out[k] = np.zeros((0, width.get(k, n)))
            elif k in ("x_d", "x"):  # stored as (p, R): written as [x, y, z, roll, pitch, yaw]
                out[k] = np.array([np.concatenate([p, matrix_to_rpy(R)]) for p, R in v])
            else:
                out[k] = np.stack(v)
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
            raise ValueError(f"the run already has signals {clash}")
        meta = {**dict(run.meta), "control": self.settings()}
        return type(run)(t=run.t, signals={**run.signals, **extra}, spec=run.spec, meta=meta)


def _plain(value: Any) -> Any:
    """Enums, tuples and numpy scalars to JSON-friendly values."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "value") and not isinstance(value, (int, float, str)):
        return value.value
    return value
