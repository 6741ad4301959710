"""The inner pressure loop: desired ΔP_d -> oil-flow command Φ per hydraulic joint.

From eq. (4), (V/E) dΔP/dt = Q - Le ΔP - A q̇. The flow command makes ΔP follow ΔP_d:

    Φ = A q̇ + Le ΔP + (V/E) dΔP_d/dt                      (flow the moving piston needs, leakage,
                                                            compressibility)
        + Kp_P (ΔP_d - ΔP) + Ki_P ∫(ΔP_d - ΔP) dt        (pressure error; PID with anti-windup)
        + k_v A (q̇_ref - q̇)                              (speed error)

With Kp_P = ω_P V/E the pressure error decays at the loop's bandwidth ω_P (rad/s) on every joint,
whatever its size; Ki_P = ω_I Kp_P. dΔP_d/dt is the backward difference of ΔP_d, low-pass
filtered with time constant ``rate_filter``. The speed term feeds part of the velocity error
straight into flow, as a hydraulic servo does: at k_v = 1 the piston flow is A q̇_ref.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from maniplab.control.actuation import ActuatorArrays
from maniplab.control.pid import PID

ArrayLike = Any


class PressureLoop:
    """Inner loop of the cascade, one PID per hydraulic joint.

    Args:
        actuators: the arm's actuator arrays.
        dt: sample time, s.
        bandwidth: ω_P, rad/s.
        integral: ω_I (Ki_P = ω_I Kp_P), 1/s; 0 for none.
        speed_gain: k_v, dimensionless.
        rate_filter: time constant of the dΔP_d/dt filter, s.
        compressibility: include the (V/E) dΔP_d/dt term.
    """

    def __init__(self, actuators: ActuatorArrays, *, dt: float, bandwidth: float = 60.0,
                 integral: float = 0.0, speed_gain: float = 0.0, rate_filter: float = 0.005,
                 compressibility: bool = True) -> None:
        self.act = actuators
        h = actuators.hydraulic
        self.index = np.flatnonzero(h)
        cap = actuators.capacitance[h]
        self._cap = cap
        self._area = actuators.area[h]
        self._leak = actuators.leakage[h]
        self.speed_gain = float(speed_gain)
        self.compressibility = compressibility
        self.pid = PID(bandwidth * cap, integral * bandwidth * cap, 0.0, dt=dt,
                       size=len(self.index))
        self._kp = self.pid.kp
        self._proportional = integral == 0.0  # no integrator: Kp e, without the PID object
        self.dt = dt
        self._alpha = dt / (rate_filter + dt)
        self.reset()

    def reset(self) -> None:
        """Clear the integrator and the ΔP_d rate filter."""
        self.pid.reset()
        self._prev: np.ndarray | None = None
        self._rate = np.zeros(len(self.index))

    def update(self, dP_d: ArrayLike, dP: ArrayLike, qd: ArrayLike,
               qd_ref: ArrayLike | None = None) -> np.ndarray:
        """One sample of the loop.

        Args:
            dP_d: desired ΔP, Pa, shape (n,) (entries of torque joints ignored).
            dP: measured ΔP, Pa, (n,).
            qd: joint velocities, rad/s or m/s, (n,).
            qd_ref: reference joint velocities for the speed error, (n,) (default ``qd``).

        Returns:
            Φ, m³/s, shape (n,), NaN at torque joints.
        """
        i = self.index
        ref = None if qd_ref is None else np.asarray(qd_ref, dtype=float)[i]
        flow = self.flow(np.asarray(dP_d, dtype=float)[i], np.asarray(dP, dtype=float)[i],
                         np.asarray(qd, dtype=float)[i], ref)
        out = np.full(self.act.n, np.nan)
        out[i] = flow
        return out

    def flow(self, dP_d: np.ndarray, dP: np.ndarray, qd: np.ndarray,
             qd_ref: np.ndarray | None = None) -> np.ndarray:
        """:meth:`update` on the hydraulic joints only: arrays of shape (k,), k hydraulic joints."""
        if self._prev is not None:
            self._rate += self._alpha * ((dP_d - self._prev) / self.dt - self._rate)
        self._prev = dP_d
        error = dP_d - dP
        feedback = self._kp * error if self._proportional else self.pid.update(error)
        flow = self._area * qd + self._leak * dP + feedback
        if self.compressibility:
            flow += self._cap * self._rate
        if qd_ref is not None and self.speed_gain:
            flow += self.speed_gain * self._area * (qd_ref - qd)
        return flow
