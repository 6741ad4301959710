"""The cascade controller's sample as maniplab computed it in Python (frozen).

``CascadeController``'s sample now runs in C (``src/maniplab_native/cascade.c``); this is the
Python sample it replaced, composed from the public blocks that stay in maniplab (PID,
DampedLeastSquares, Kinematics, InverseDynamics, PressureLoop) with the frozen valve law
(tests/reference/valve_law.py) for G2, kept as an independent reference: fed the states of the
same closed-loop runs, both must agree to round-off (tests/test_cascade_native.py).

``ReferenceCascade(controller)`` takes a controller's resolved settings (gains, task, mode, model)
and keeps its own loop states and log; ``step(t, q, qd, dP=...)`` is one sample. It also records
each sample's least-squares damping λ² (``lam2``), to show which samples ran near a singularity.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from maniplab.actuators import ActuatorPlugin, ForceDrive, StaticDrive
from maniplab.actuators.hydraulic import PressureDrive
from maniplab.control.cascade import LOG_SIGNALS
from maniplab.control.inverse_dynamics import InverseDynamics
from maniplab.control.kinematics import DampedLeastSquares, Kinematics, matrix_to_rpy, rotation_log
from maniplab.control.pid import PID
from maniplab.spec import ControlSpec, model_of
from reference.valve_law import valve_current


class FrozenPressureDrive(PressureDrive):
    """PressureDrive.command as it was: ΔP_d = τ_d / A, the pressure loop, the frozen G2."""

    def command(self, force: np.ndarray, q: np.ndarray, qd: np.ndarray, qd_ref: np.ndarray,
                states: Mapping[str, np.ndarray]) -> np.ndarray:
        dP = states["dP"]
        dP_d = force / self.area
        phi = self.loop.flow(dP_d, dP, qd, qd_ref)
        self.log = {"dP_d": dP_d, "phi": phi}
        return valve_current(phi, dP, self.gain, self.supply, self.limit,
                             min_root=self.min_root, orifice=self.orifice)


class FrozenStaticDrive(StaticDrive):
    """StaticDrive.command as it was: each actuator's steady-state command, clipped."""

    def command(self, force: np.ndarray, q: np.ndarray, qd: np.ndarray, qd_ref: np.ndarray,
                states: Mapping[str, np.ndarray]) -> np.ndarray:
        u = np.array([a.steady(float(f), float(x), float(v)).u
                      for a, f, x, v in zip(self.actuators, force, q, qd)])
        return self.clip(u)


def _frozen(drive: ForceDrive, actuators: list[ActuatorPlugin], joints: list[int], dt: float,
            settings: ControlSpec) -> ForceDrive:
    """The built-in drives as they were; a plugin's own drive as it is (its code is its own)."""
    if isinstance(drive, PressureDrive):
        return FrozenPressureDrive(actuators, joints, dt=dt, settings=settings)
    if isinstance(drive, StaticDrive):
        return FrozenStaticDrive(actuators, joints, dt=dt, settings=settings)
    return drive


def _given(value: float | None) -> float:
    assert value is not None
    return value


class ReferenceCascade:
    """The frozen sample of a controller's settings.

    Args:
        controller: a ``CascadeController`` (its spec, resolved gains, mode, task and model).
    """

    def __init__(self, controller: Any) -> None:
        self.spec, self.trajectory = controller.spec, controller.trajectory
        self.gains, self.mode = controller.gains, controller.mode
        self.n = controller.n
        self.model = controller.model
        self.kin = Kinematics(self.model)
        self.actuators = [model_of(j) for j in self.spec.joints]
        self.dt = controller.dt
        self.rows = controller.rows
        self.joint_path = controller.joint_path
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
        self.lam2: list[float] = []

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
        self.lam2.append(dls.lam2)
        if self.mode == "pid":
            cmd, log = self._pid_only(q, qd, states, dls, e[:m], de, t)
        else:
            cmd, log = self._cascade(q, qd, states, ref, dls, e[:m], de, t)
        self._record(t, ref, p, R, e, log, cmd)
        return cmd

    def _cascade(self, q: np.ndarray, qd: np.ndarray, states: dict[str, np.ndarray], ref: Any,
                 dls: DampedLeastSquares, e: np.ndarray, de: np.ndarray, t: float
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
        if self._redundant and self.joint_path is not None:
            # the pull towards the planned joint path, its null-space part: (I - J⁺J) z
            q_p, qd_p = self.joint_path(t)
            damping = self.gains.null_damping
            z = (0.5 * damping) ** 2 * (q_p - q) + damping * qd_p
            qdd = qdd + z - dls.solve(dls.J @ z)
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
                  dls: DampedLeastSquares, e: np.ndarray, de: np.ndarray, t: float
                  ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        if self.joint_path is None:  # the task's error, rate and speed by least squares
            twist = self.trajectory.sample(t).twist[:len(e)]
            sol = dls.solve(np.stack([e, de, twist], axis=1))
            u = self.joint_pid.update(sol[:, 0], sol[:, 1], feedforward=sol[:, 2],
                                      freeze=bool(np.any(twist != 0.0)))
        else:  # each joint tracks the planned joint path, its speed fed forward, and
            q_p, qd_p = self.joint_path(t)  # integrates once the path has stopped
            u = self.joint_pid.update(q_p - q, qd_p - qd, feedforward=qd_p,
                                      freeze=bool(np.any(qd_p != 0.0)))
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
        """Sample times, s, (K,)."""
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


def _drives(actuators: list[ActuatorPlugin], *, dt: float,
            settings: ControlSpec) -> list[ForceDrive]:
    """One drive per actuator class, over the joints that have it (CapabilityError, naming the
    joints, where a class cannot be driven)."""
    groups: dict[type[ActuatorPlugin], list[int]] = {}
    for j, a in enumerate(actuators):
        groups.setdefault(type(a), []).append(j)
    out = []
    for cls, joints in groups.items():
        mine = [actuators[j] for j in joints]
        drive = cls.drive(mine, joints, dt=dt, settings=settings)
        out.append(_frozen(drive, mine, joints, dt, settings))
    return out
