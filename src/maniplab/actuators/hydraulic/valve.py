"""The servo-valve's flow law of the paper's eq. (4), and its inversion (the controller's G2).

Steady flow at valve current i_v and load pressure ΔP: Q* = i_v C sqrt(max(0, 1 - |ΔP|/Ps)), the
flow's direction following i_v. Every part of maniplab that evaluates the valve (the cylinder
model, the plant's native update, the linearisation, the controller's inversion) calls these.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray


def root(dP: float, inv_supply: float) -> float:
    """sqrt(max(0, 1 - |ΔP|/Ps)): the share of the no-load flow the valve passes at ΔP."""
    r = 1.0 - abs(dP) * inv_supply
    return math.sqrt(r) if r > 0.0 else 0.0


def flow(current: float, dP: float, gain: float, inv_supply: float) -> float:
    """Steady valve flow i_v C sqrt(max(0, 1 - |ΔP|/Ps)), m³/s (``inv_supply`` = 1/Ps, 1/Pa)."""
    return current * gain * root(dP, inv_supply)


def root_slope(dP: float, inv_supply: float) -> float:
    """d root / dΔP, 1/Pa (0 where the root vanishes)."""
    r = root(dP, inv_supply)
    return -math.copysign(1.0, dP) * inv_supply / (2.0 * r) if r > 0.0 else 0.0


def valve_flow(current: ArrayLike, dP: ArrayLike, gain: ArrayLike,
               supply_pressure: ArrayLike) -> NDArray[np.float64]:
    """:func:`flow` element-wise over arrays (broadcast), m³/s."""
    law = np.frompyfunc(lambda i, p, c, ps: flow(i, p, c, 1.0 / ps), 4, 1)
    return np.asarray(law(current, dP, gain, supply_pressure), dtype=float)


def valve_current(flow_: ArrayLike, dP: ArrayLike, gain: ArrayLike, supply_pressure: ArrayLike,
                  current_limit: ArrayLike, *, min_root: float = 0.05) -> NDArray[np.float64]:
    """G2: the valve current that passes ``flow_`` at pressure ``dP``, clipped at the limit, A.

    Within the limits (|i_v| <= current_limit and 1 - |ΔP|/Ps >= min_root²) this inverts
    :func:`flow` exactly; where the root vanishes (|ΔP| -> Ps) no current passes flow, so the root
    is floored at ``min_root`` to keep the current finite.

    Args:
        flow_: commanded flow Φ, m³/s, shape (k,).
        dP: measured load pressure ΔP, Pa, (k,).
        gain: valve gain C, m³/(s·A), (k,).
        supply_pressure: Ps, Pa, (k,).
        current_limit: largest |i_v|, A, (k,).
        min_root: floor of the root (guards the division where it vanishes).

    Returns:
        i_v, A, shape (k,).
    """
    law = np.frompyfunc(lambda p, ps: max(root(p, 1.0 / ps), min_root), 2, 1)
    r = np.asarray(law(dP, supply_pressure), dtype=float)
    current = np.asarray(flow_, dtype=float) / (np.asarray(gain) * r)
    return np.minimum(np.maximum(current, -np.asarray(current_limit)), current_limit)
