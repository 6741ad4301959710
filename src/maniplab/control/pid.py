"""PID with filtered derivative, output limits and back-calculation anti-windup (eqs. 9-10).

The discrete law, for a vector error e_k (one PID per component, gains broadcast), sample time h:

    P_k = Kp e_k
    D_k = Tf/(Tf + h) D_{k-1} + Kd/(Tf + h) (e_k - e_{k-1})      (filtered derivative, eq. 9)
          or, when the error rate ė_k is measured:  D_k = Kd d_k,  d_k = d_{k-1} + h/(Tf + h)(ė_k - d_{k-1})
    v_k = P_k + I_k + D_k + F_k,  u_k = clip(v_k, lo, hi)                        (output limits)
    I_{k+1} = I_k + h (Ki e_k + (u_k - v_k)/Tt)               (back-calculation anti-windup, eq. 10)

F_k is an optional feed-forward (e.g. the planned speed of a joint that tracks a path): it is
part of the output the limits and the anti-windup see. The derivative is the backward-Euler discretisation of Kd s/(1 + Tf s); Tf = 0 is the plain
difference quotient. The first sample has no derivative kick (e_{-1} = e_0). The tracking time Tt
defaults to sqrt(Ti Td) = sqrt(Kd/Ki) when there is a derivative, else Ti = Kp/Ki (Åström and
Hägglund's rule), and never below h; while the output is inside its limits the anti-windup term is 0.
A component with Ki = 0 has no integrator (I stays 0). With a measured rate, the derivative filter
starts at the first measured value.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from maniplab.control.errors import ControlError


class PID:
    """A discrete vector PID controller.

    Args:
        kp: proportional gain, scalar or shape (m,).
        ki: integral gain, scalar or (m,); 0 disables the integrator.
        kd: derivative gain, scalar or (m,).
        dt: sample time h, s.
        filter_time: derivative filter time constant Tf, s (0: no filter).
        limits: output limits (lo, hi), scalars or (m,) each, or None for no limit.
        tracking_time: anti-windup tracking time Tt, s; None for the default rule above.
        size: number of components m (default: from the gains, else 1).

    Example:
        >>> pid = PID(2.0, 1.0, 0.1, dt=0.01, filter_time=0.02, limits=(-1, 1))
        >>> u = pid.update(np.array([0.3]))
    """

    def __init__(self, kp: ArrayLike, ki: ArrayLike = 0.0, kd: ArrayLike = 0.0, *, dt: float,
                 filter_time: float = 0.0, limits: tuple[ArrayLike, ArrayLike] | None = None,
                 tracking_time: ArrayLike | None = None, size: int | None = None) -> None:
        if not dt > 0.0:
            raise ControlError(f"dt must be > 0, got {dt!r}")
        if filter_time < 0.0:
            raise ControlError(f"filter_time must be >= 0, got {filter_time!r}")
        m = size if size is not None else max(np.size(kp), np.size(ki), np.size(kd), 1)
        self.kp = np.broadcast_to(np.asarray(kp, dtype=float), (m,)).copy()
        self.ki = np.broadcast_to(np.asarray(ki, dtype=float), (m,)).copy()
        self.kd = np.broadcast_to(np.asarray(kd, dtype=float), (m,)).copy()
        self.dt = float(dt)
        self.filter_time = float(filter_time)
        if limits is None:
            self.lo = np.full(m, -np.inf)
            self.hi = np.full(m, np.inf)
        else:
            self.lo = np.broadcast_to(np.asarray(limits[0], dtype=float), (m,)).copy()
            self.hi = np.broadcast_to(np.asarray(limits[1], dtype=float), (m,)).copy()
            if np.any(self.lo > self.hi):
                raise ControlError(f"limits {limits!r} are not ordered (lo <= hi)")
        self.tracking_time = self._tracking_time(tracking_time, m)
        self._a = self.filter_time / (self.filter_time + self.dt)  # filter pole
        self._b = self.dt / (self.filter_time + self.dt)
        self._limited = bool(np.isfinite(self.lo).any() or np.isfinite(self.hi).any())
        self._integrates = self.ki > 0.0
        self._any_integral = bool(self._integrates.any())
        self.reset()

    def _tracking_time(self, tracking_time: ArrayLike | None, m: int) -> np.ndarray:
        if tracking_time is not None:
            tt = np.broadcast_to(np.asarray(tracking_time, dtype=float), (m,)).copy()
            if np.any(tt <= 0.0):
                raise ControlError(f"tracking_time must be > 0, got {tracking_time!r}")
            return tt
        with np.errstate(divide="ignore", invalid="ignore"):
            rule = np.where(self.kd > 0.0, np.sqrt(self.kd / self.ki), self.kp / self.ki)
        rule = np.where(np.isfinite(rule) & (rule > 0.0), rule, self.dt)
        return np.maximum(rule, self.dt)

    @property
    def size(self) -> int:
        """Number of components m."""
        return self.kp.shape[0]

    def reset(self) -> None:
        """Clear the integrator, the derivative filter and the stored previous error."""
        m = self.size
        self.integral = np.zeros(m)
        """Integrator state I (in output units), shape (m,)."""
        self._d = np.zeros(m)
        self._e_prev: np.ndarray | None = None
        self.saturated = np.zeros(m, dtype=bool)
        """Components whose last output was clipped, shape (m,)."""
        self.unclipped = np.zeros(m)
        """The last output before clipping (v_k), shape (m,)."""

    def update(self, error: ArrayLike, rate: ArrayLike | None = None, *,
               freeze: ArrayLike | bool = False, feedforward: ArrayLike = 0.0) -> np.ndarray:
        """One sample: the output u_k for the error e_k (and optionally its measured rate).

        Args:
            error: e_k, shape (m,).
            rate: measured ė_k, shape (m,), used for the derivative term instead of the
                difference quotient (it is still low-pass filtered with Tf).
            freeze: hold the integrator this sample (all components, or a mask (m,)):
                conditional integration, for anti-windup when a downstream loop saturates.
            feedforward: F_k, added to the output before the limits, scalar or (m,).

        Returns:
            u_k, clipped to the limits, shape (m,).
        """
        e = np.asarray(error, dtype=float)
        first = self._e_prev is None
        if rate is None:  # self._d is the filtered error rate; the D term is Kd times it
            prev = e if first else self._e_prev
            self._d = self._a * self._d + (e - prev) / (self.filter_time + self.dt)
        else:  # the filter starts at the first measured rate
            r = np.asarray(rate, dtype=float)
            self._d = r.copy() if first else self._a * self._d + self._b * r
        self._e_prev = e.copy()
        v = self.kp * e + self.integral + self.kd * self._d + np.asarray(feedforward, dtype=float)
        if self._limited:
            u = np.minimum(np.maximum(v, self.lo), self.hi)
            self.saturated = u != v
            step = self.ki * e + (u - v) / self.tracking_time
        else:
            u = v
            step = self.ki * e
        self.unclipped = v
        if self._any_integral and freeze is not True:
            hold = ~self._integrates if freeze is False else ~self._integrates | np.asarray(freeze)
            step[hold] = 0.0
            self.integral = self.integral + self.dt * step
        return u
