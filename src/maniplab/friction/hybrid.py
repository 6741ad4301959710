"""Hybrid stick/slip friction (the paper's eqs. 5-8), vectorised over the arm's joints.

SLIP: the friction force opposes the motion,
``f = -(Fc + Fs exp(-(v/vs)²)) sign(v) - Fv v`` (Fc ``coulomb``, Fs ``static``, the stiction above
Coulomb, vs ``stribeck_velocity``, Fv ``viscous``). SLIP -> STICK when |v| falls below
``stick_velocity`` while decelerating, or v changes sign within a step: the velocity is reset to
zero and the joint is held. STICK: the friction is whatever holds the joint still (computed by the
plant from the constrained dynamics of all held joints); STICK -> SLIP when that holding force
exceeds the break-away force Fc + Fs. A joint with Fc + Fs = 0 has only viscous friction and never
sticks. The mode logic that couples friction with the joint limits is in
:mod:`~maniplab.actuators.automaton`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

from maniplab.friction.params import Friction, FrictionModel


def slip_force(v: float, direction: float, coulomb: float, static: float,
               stribeck_velocity: float) -> float:
    """Coulomb + Stribeck force on a slipping joint (no viscous part), N or N·m.

    Args:
        v: joint velocity, m/s or rad/s.
        direction: ±1, the sign of the motion when v is exactly 0 (a joint that just broke away).
        coulomb: the spec's Coulomb force Fc, N or N·m.
        static: the spec's stiction above Coulomb Fs, N or N·m.
        stribeck_velocity: the spec's Stribeck velocity vs, m/s or rad/s.
    """
    r = v / stribeck_velocity
    magnitude = coulomb + static * math.exp(-r * r)
    if v > 0.0:
        return -magnitude
    if v < 0.0:
        return magnitude
    return -magnitude * direction


def sticks(v0: float, v1: float, stick_velocity: float) -> bool:
    """Whether a slipping joint sticks after a step from velocity v0 to v1.

    It sticks when its velocity changed sign, or fell below ``stick_velocity`` in magnitude while
    decelerating.
    """
    a1 = abs(v1)
    return v0 * v1 < 0.0 or (a1 < stick_velocity and a1 < abs(v0))


@dataclasses.dataclass(frozen=True)
class HybridJoint:
    """The hybrid friction of one joint (index ``joint``), with its break-away force Fc + Fs."""

    joint: int
    coulomb: float
    static: float
    stribeck_velocity: float
    stick_velocity: float

    @property
    def breakaway(self) -> float:
        """Fc + Fs, N or N·m: the largest force stiction holds."""
        return self.coulomb + self.static

    @property
    def can_stick(self) -> bool:
        """Only a joint with a positive break-away force sticks (else it is purely viscous)."""
        return self.breakaway > 0.0


class HybridFriction:
    """The hybrid-friction joints of an arm.

    Attributes:
        joints: one :class:`HybridJoint` per joint with the hybrid model.
        breakaway: Fc + Fs per joint of the arm (0 without hybrid friction), N or N·m, (n,).
        can_stick: per joint of the arm, whether it can stick, (n,).
    """

    def __init__(self, frictions: Sequence[Friction]) -> None:
        self.joints = [
            HybridJoint(i, f.coulomb, f.static, f.stribeck_velocity, f.stick_velocity)
            for i, f in enumerate(frictions) if f.model is FrictionModel.hybrid
        ]
        self.breakaway = [0.0] * len(frictions)
        self.can_stick = [False] * len(frictions)
        for h in self.joints:
            self.breakaway[h.joint] = h.breakaway
            self.can_stick[h.joint] = h.can_stick
        self.sticky = [h for h in self.joints if h.can_stick]
