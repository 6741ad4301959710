"""Joint limits as discrete modes: a joint that reaches a limit is held there.

The MuJoCo model of a spec carries the limits as soft constraints (for MuJoCo's own tools); the
plant switches those off and uses this automaton instead, as the paper does: when a step ends
beyond a limit the joint is put back on it with zero velocity (an inelastic stop) and its mode
becomes AT_LOWER or AT_UPPER; it stays there, held by whatever force that takes, until the net
force on it points back inside (see :mod:`~maniplab.actuators.automaton`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from maniplab.spec import Joint


class JointLimits:
    """Lower and upper limits of the n joints (±inf where a joint has none), rad or m.

    Attributes:
        lower, upper: lists (n,).
        limited: indices of the joints with at least one limit.
    """

    def __init__(self, joints: Sequence[Joint]) -> None:
        self.lower = [j.limits[0] if j.limits else -math.inf for j in joints]
        self.upper = [j.limits[1] if j.limits else math.inf for j in joints]
        self.limited = [i for i, j in enumerate(joints) if j.limits]

    def clip(self, q: Sequence[float]) -> list[float]:
        """q moved onto the limits where it is beyond them."""
        return [min(max(x, lo), hi) for x, lo, hi in zip(q, self.lower, self.upper)]
