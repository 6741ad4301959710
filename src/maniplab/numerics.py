"""Small numerical helpers shared by the exact exponential updates of several models."""

from __future__ import annotations

import math


def phi1(x: float) -> float:
    """(1 - e^-x) / x, with its limit 1 at x = 0 (x >= 0): the weight of a constant input over a
    step of an exponentially decaying state."""
    return -math.expm1(-x) / x if x > 1e-12 else 1.0 - 0.5 * x
