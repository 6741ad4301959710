"""Input shaping: a move that leaves a hanging tool without residual sway.

A move excites the pendulum of a tool hanging from the arm. Convolving the move's reference with a
sequence of impulses whose responses cancel at the pendulum's frequency removes the residual
sway whatever the move (Singer and Seering, "Preshaping command inputs to reduce system
vibration", J. Dyn. Sys., Meas., Control 112, 1990). The ZVD shaper (zero vibration and zero
derivative) has three impulses,

    A = (1, 2K, K²) / (1 + K)²  at  t = (0, T_d/2, T_d),    K = exp(-ζπ/√(1-ζ²)),

with T_d = 2π/(ω√(1-ζ²)) the damped period: it cancels the residual vibration at ω and its
slope with respect to ω, so a frequency off by ±20 % leaves a few percent of the unshaped sway.
The shaped move is longer by T_d. A minimum-jerk move along a line shaped this way is the same
line with the shaped timing law s(t) = Σ A_i s(t - t_i), so its orientation still turns about
one axis.
"""

from __future__ import annotations

import dataclasses
import math

from maniplab.control.kinematics import rotation_exp
from maniplab.control.trajectory import MinJerkMove, Pose, Reference, min_jerk


def zvd(frequency: float, damping: float = 0.0) -> tuple[tuple[float, float], ...]:
    """The ZVD shaper's impulses ((time s, amplitude), ...) for a mode of ``frequency`` rad/s
    and damping ratio ``damping`` (0 <= ζ < 1); the amplitudes sum to 1."""
    if not (frequency > 0.0 and math.isfinite(frequency)):
        raise ValueError(f"the shaper's frequency must be positive, got {frequency!r}")
    if not 0.0 <= damping < 1.0:
        raise ValueError(f"the shaper's damping ratio must be within [0, 1), got {damping!r}")
    root = math.sqrt(1.0 - damping * damping)
    k = math.exp(-damping * math.pi / root)
    period = 2.0 * math.pi / (frequency * root)
    total = (1.0 + k) ** 2
    return ((0.0, 1.0 / total), (0.5 * period, 2.0 * k / total), (period, k * k / total))


@dataclasses.dataclass(frozen=True, eq=False)
class ShapedMove:
    """A minimum-jerk move with its timing law shaped by impulses (:func:`zvd`).

    Attributes:
        move: the move as planned.
        impulses: ((time, amplitude), ...), times from 0, amplitudes summing to 1.
    """

    move: MinJerkMove
    impulses: tuple[tuple[float, float], ...]

    @property
    def t0(self) -> float:
        return self.move.t0

    @property
    def duration(self) -> float:
        """The shaped move's length: the plan's plus the last impulse's delay, s."""
        return self.move.duration + self.impulses[-1][0]

    @property
    def start(self) -> Pose:
        return self.move.start

    @property
    def goal(self) -> Pose:
        return self.move.goal

    @property
    def end(self) -> Pose:
        return self.move.goal

    def sample(self, t: float) -> Reference:
        """The reference at time t, s."""
        m = self.move
        s = ds = dds = 0.0
        for delay, amplitude in self.impulses:
            a, b, c = min_jerk((t - delay - m.t0) / m.duration)
            s, ds, dds = s + amplitude * a, ds + amplitude * b, dds + amplitude * c
        T, w, dpw = m.duration, m._w, m._dpw
        R = rotation_exp(s * w) @ m.start.rotation if s and w.any() else m.start.rotation
        return Reference(m.start.position + s * dpw[:3], R, (ds / T) * dpw, (dds / T**2) * dpw)
