"""G2: inversion of the valve in the paper's eq. (4), oil flow command Φ -> valve current i_v.

Eq. (4)'s valve: Q + τ dQ/dt = i_v C sqrt(1 - |ΔP|/Ps), the root's argument clipped at 0 and the
flow's direction following i_v. Its static map is inverted: i_v = Φ / (C sqrt(1 - |ΔP|/Ps)).
Where the root vanishes (|ΔP| → Ps) the valve cannot pass flow at any current: the root is
floored at ``min_root`` so the current stays finite, and the result is clipped at ±current_limit.
"""

from __future__ import annotations

from typing import Any

import numpy as np

ArrayLike = Any


def valve_flow(current: ArrayLike, dP: ArrayLike, gain: ArrayLike,
               supply_pressure: ArrayLike) -> np.ndarray:
    """Steady-state flow of eq. (4): i_v C sqrt(max(1 - |ΔP|/Ps, 0)), m³/s, element-wise."""
    root = np.sqrt(np.maximum(1.0 - np.abs(dP) / supply_pressure, 0.0))
    return np.asarray(current, dtype=float) * gain * root


def valve_current(flow: ArrayLike, dP: ArrayLike, gain: ArrayLike, supply_pressure: ArrayLike,
                  current_limit: ArrayLike, *, min_root: float = 0.05) -> np.ndarray:
    """G2: the valve current that passes ``flow`` at pressure ``dP``, clipped at the limit, A.

    Within the limits (|i_v| <= current_limit and 1 - |ΔP|/Ps >= min_root²) this inverts
    :func:`valve_flow` exactly.

    Args:
        flow: commanded flow Φ, m³/s, shape (k,).
        dP: measured load pressure ΔP, Pa, (k,).
        gain: valve gain C, m³/(s·A), (k,).
        supply_pressure: Ps, Pa, (k,).
        current_limit: largest |i_v|, A, (k,).
        min_root: floor of sqrt(1 - |ΔP|/Ps) (guards the division where the root vanishes).

    Returns:
        i_v, A, shape (k,).
    """
    root = np.sqrt(np.maximum(1.0 - np.abs(dP) / supply_pressure, min_root * min_root))
    current = np.asarray(flow, dtype=float) / (gain * root)
    return np.minimum(np.maximum(current, -current_limit), current_limit)
