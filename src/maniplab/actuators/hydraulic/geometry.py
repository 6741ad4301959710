"""Where a cylinder is pinned: its length s(q) and moment arm r(q) = ds/dq, in closed form.

The pins are given from the joint's origin in base axes at q = 0: ``parent`` on the body before
the joint, ``child`` on the body the joint moves. With a the joint's unit axis:

- **rotational joint**: the child pin turns about a, so with α = p⊥·c⊥, β = a·(c × p),
  K = |c|² + |p|² - 2 (a·p)(a·c), ρ = √(α² + β²) and φ = atan2(β, α)::

      s(q)² = K - 2 ρ cos(q - φ),    r(q) = ρ sin(q - φ) / s(q)

  s is shortest at q = φ and longest at q = φ + π, its *dead points*, where the moment arm
  vanishes (the cylinder points at the joint's centre); between two of them it is monotonic;
- **prismatic joint**: the child pin slides along a, so with b = a·(c - p) and
  w² = |c - p|² - b²::

      s(q)² = w² + (q + b)²,         r(q) = (q + b) / s(q)

  with one dead point at q = -b.

A joint may only move within one monotonic *branch* (between dead points), and only as far as
the stroke lets the cylinder extend and retract: :meth:`PinGeometry.problem` says what is wrong
with limits that do not fit.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]

LENGTH_TOLERANCE = 1e-9
"""Relative tolerance on the cylinder's length at the joint's limits (limits computed from the
stroke land on its ends up to round-off)."""


class GeometryProblem(NamedTuple):
    """What is wrong with a cylinder's mounting: the field below ``actuator`` and the message."""

    field: str
    message: str


class PinGeometry:
    """A cylinder between two pins across one joint.

    Args:
        parent: the pin on the body before the joint, from the joint's origin, m, (3,).
        child: the pin on the body the joint moves, at q = 0, m, (3,).
        axis: the joint's unit axis, (3,).
        prismatic: a sliding joint (else rotational).
    """

    def __init__(self, parent: ArrayLike, child: ArrayLike, axis: ArrayLike,
                 prismatic: bool) -> None:
        p, c, a = (np.asarray(v, dtype=float) for v in (parent, child, axis))
        self.prismatic = prismatic
        self.unit = "m" if prismatic else "rad"
        if prismatic:
            d = c - p
            self._b = float(a @ d)
            self._w2 = max(float(d @ d) - self._b**2, 0.0)
        else:
            self._k = float(c @ c + p @ p - 2.0 * (a @ p) * (a @ c))
            alpha = float(p @ c - (a @ p) * (a @ c))
            beta = float(a @ np.cross(c, p))
            self._rho = math.hypot(alpha, beta)
            self._phi = math.atan2(beta, alpha)

    @property
    def constants(self) -> tuple[float, float, float]:
        """The closed form's constants: (K, ρ, φ) on a rotational joint, s² = K - 2ρ cos(q - φ);
        (w², b, 0) on a prismatic one, s² = w² + (q + b)²."""
        if self.prismatic:
            return self._w2, self._b, 0.0
        return self._k, self._rho, self._phi

    # --- s, r and dr/dq -----------------------------------------------------------------------
    def _offset(self, q: Array) -> Array:
        """q + b (prismatic) or q - φ (rotational)."""
        return q + self._b if self.prismatic else q - self._phi

    def length(self, q: ArrayLike) -> Array:
        """s(q), pin to pin, m; same shape as q."""
        x = self._offset(np.asarray(q, dtype=float))
        if self.prismatic:
            return np.sqrt(self._w2 + x**2)
        return np.sqrt(np.maximum(self._k - 2.0 * self._rho * np.cos(x), 0.0))

    def arm(self, q: ArrayLike) -> Array:
        """r(q) = ds/dq, m (rotational: m per rad; prismatic: dimensionless)."""
        x = self._offset(np.asarray(q, dtype=float))
        s = self.length(q)
        return (x if self.prismatic else self._rho * np.sin(x)) / s

    def arm_slope(self, q: ArrayLike) -> Array:
        """dr/dq: w²/s³ (prismatic) or (ρ cos(q - φ) - r²)/s (rotational)."""
        s, r = self.length(q), self.arm(q)
        if self.prismatic:
            return self._w2 / s**3
        return (self._rho * np.cos(self._offset(np.asarray(q, dtype=float))) - r**2) / s

    # --- where the cylinder can move the joint -------------------------------------------------
    def dead_points(self, lower: float, upper: float) -> list[float]:
        """The joint positions in [lower, upper] where the moment arm vanishes."""
        if self.prismatic:
            return [-self._b] if lower <= -self._b <= upper else []
        first = math.ceil((lower - self._phi) / math.pi)
        last = math.floor((upper - self._phi) / math.pi)
        return [self._phi + k * math.pi for k in range(first, last + 1)]

    def reach(self, near: float) -> tuple[float, float]:
        """The shortest and longest s on the branch (between dead points) that holds ``near``, m."""
        if self.prismatic:
            return math.sqrt(self._w2), math.inf
        return math.sqrt(max(self._k - 2.0 * self._rho, 0.0)), math.sqrt(self._k + 2.0 * self._rho)

    def position(self, s: float, near: float) -> float:
        """The joint position where the cylinder is ``s`` long, on the branch of ``near`` (s is
        clipped to what that branch reaches)."""
        if self.prismatic:
            root = math.sqrt(max(s**2 - self._w2, 0.0))
            return -self._b + (root if near >= -self._b else -root)
        k = math.floor((near - self._phi) / math.pi)
        cosine = (self._k - s**2) / (2.0 * self._rho)
        theta = math.acos(min(max(cosine, -1.0), 1.0))
        return self._phi + (k * math.pi + theta if k % 2 == 0 else (k + 1) * math.pi - theta)

    def span(self, shortest: float, longest: float, near: float) -> tuple[float, float]:
        """The joint range over which the cylinder's length stays within [shortest, longest], on
        the branch of ``near``, as (lower, upper)."""
        a, b = self.position(shortest, near), self.position(longest, near)
        return (a, b) if a <= b else (b, a)

    def problem(self, limits: tuple[float, float] | None, shortest: float,
                longest: float) -> GeometryProblem | None:
        """What keeps this cylinder, ``shortest`` to ``longest`` m pin to pin, from moving the
        joint within ``limits``; None when it can."""
        if not self.prismatic and self._rho <= 1e-12 * max(self._k, 1e-300):
            return GeometryProblem("cylinder.pins", "the moment arm is zero at every angle: a pin "
                                   "lies on the joint's axis (or both pins in line with it)")
        near = 0.0 if limits is None else 0.5 * (limits[0] + limits[1])
        low, high = self.reach(near)
        if longest < low or shortest > high:
            return GeometryProblem("cylinder.min_length", (
                f"the cylinder spans {shortest:.6g} to {longest:.6g} m (min_length to min_length "
                f"+ stroke), but these pins are {low:.6g} to {high:.6g} m apart"))
        allowed = self.span(shortest, longest, near)
        low_text, high_text = _inward(*allowed)  # limits copied from the message are accepted
        text = f"[{low_text}, {high_text}] {self.unit}"
        if limits is None:
            return GeometryProblem("cylinder", "a joint driven by a cylinder needs limits within "
                                   f"the range its stroke allows, {text}")
        dead = self.dead_points(*limits)
        if dead:
            return GeometryProblem("cylinder.pins", (
                f"the moment arm vanishes at q = {dead[0]:.6g} {self.unit}, within the limits "
                f"[{limits[0]:g}, {limits[1]:g}] (the cylinder points at the joint's centre "
                "there)"))
        s = self.length(np.asarray(limits))
        slack = LENGTH_TOLERANCE * longest
        if s.min() < shortest - slack or s.max() > longest + slack:
            return GeometryProblem("cylinder.stroke", (
                f"the limits [{limits[0]:g}, {limits[1]:g}] {self.unit} need the cylinder "
                f"{s.min():.6g} to {s.max():.6g} m long; it spans {shortest:.6g} to "
                f"{longest:.6g} m (min_length to min_length + stroke), which allows {text}"))
        return None


def _inward(low: float, high: float, digits: int = 6) -> tuple[str, str]:
    """``low`` and ``high`` written with ``digits`` significant digits, each rounded towards the
    inside of [low, high], so that the written range lies within the true one."""
    def written(x: float, towards: float) -> str:
        text = f"{x:.{digits}g}"
        if (float(text) - x) * (towards - x) >= 0.0:  # rounded inwards (or exact)
            return text
        step = 10.0 ** (math.floor(math.log10(abs(x))) - digits + 1) if x else 10.0 ** -digits
        return f"{float(text) + math.copysign(step, towards - x):.{digits}g}"

    return written(low, high), written(high, low)
