"""The valve law, its inversion (G2), the relief valve and the cylinder's equations as maniplab
computed them in Python (frozen).

The law is now C (``src/maniplab_native/valve.h``), called by the engine plugin, the compiled
cascade and, through ctypes, ``maniplab.actuators.hydraulic.valve`` and ``.cylinder``; this is the
Python code it replaced, kept as an independent reference (tests/test_valve_native.py: C equals
it to 1e-15 relative).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

RELIEF_OVERRIDE = 0.01
"""The relief passes the valve's full no-load flow this far (relative) above its setting."""


def root(current: float, dP: float, inv_supply: float, orifice: bool) -> float:
    """The share of the no-load flow the valve passes at ΔP: sqrt(max(0, 1 - s ΔP/Ps)) with
    s = sign(i_v) (orifice law) or s = sign(ΔP) (paper law); ``inv_supply`` = 1/Ps, 1/Pa."""
    drop = (dP if current >= 0.0 else -dP) if orifice else abs(dP)
    r = 1.0 - drop * inv_supply
    return math.sqrt(r) if r > 0.0 else 0.0


def flow(current: float, dP: float, gain: float, inv_supply: float, orifice: bool) -> float:
    """Steady valve flow Q* = i_v C root, m³/s (see :func:`root`)."""
    return current * gain * root(current, dP, inv_supply, orifice)


def slopes(current: float, dP: float, gain: float, inv_supply: float,
           orifice: bool) -> tuple[float, float]:
    """(∂Q*/∂i_v, ∂Q*/∂ΔP) of :func:`flow`, m³/(s·A) and m³/(s·Pa).

    Where the orifice law's flow is not differentiable in i_v (at i_v = 0 under load, where the
    pressure drop jumps from one edge to the other) the mean of its two one-sided slopes is given.
    Where the root vanishes both are 0.
    """
    if orifice and current == 0.0:
        up = root(1.0, dP, inv_supply, True)
        down = root(-1.0, dP, inv_supply, True)
        return gain * 0.5 * (up + down), 0.0
    r = root(current, dP, inv_supply, orifice)
    if r == 0.0:
        return 0.0, 0.0
    sign = (1.0 if current >= 0.0 else -1.0) if orifice else math.copysign(1.0, dP)
    return gain * r, -current * gain * sign * inv_supply / (2.0 * r)


def relief_gain(gain: float, current_limit: float, relief_pressure: float) -> float:
    """K_r, m³/(s·Pa): the relief passes C i_max at (1 + RELIEF_OVERRIDE) p_r."""
    return gain * current_limit / (RELIEF_OVERRIDE * relief_pressure)


def relief_flow(dP: float, relief_pressure: float, relief_gain_: float) -> float:
    """Q_r = K_r (|ΔP| - p_r) sign(ΔP) above the setting, else 0, m³/s (out of the high side)."""
    excess = abs(dP) - relief_pressure
    return math.copysign(relief_gain_ * excess, dP) if excess > 0.0 else 0.0


def valve_flow(current: ArrayLike, dP: ArrayLike, gain: ArrayLike, supply_pressure: ArrayLike,
               *, orifice: ArrayLike = True) -> NDArray[np.float64]:
    """:func:`flow` element-wise over arrays (broadcast), m³/s."""
    law = np.frompyfunc(lambda i, p, c, ps, o: flow(i, p, c, 1.0 / ps, bool(o)), 5, 1)
    return np.asarray(law(current, dP, gain, supply_pressure, orifice), dtype=float)


def valve_current(flow_: ArrayLike, dP: ArrayLike, gain: ArrayLike, supply_pressure: ArrayLike,
                  current_limit: ArrayLike, *, min_root: float = 0.05,
                  orifice: ArrayLike = True) -> NDArray[np.float64]:
    """G2: the valve current that passes ``flow_`` at pressure ``dP``, clipped at the limit, A.

    The current takes the flow's sign, and the root is that of the law for it; within the limits
    (|i_v| <= current_limit and root >= min_root) this inverts :func:`flow` exactly. Where the
    root vanishes no current passes flow, so it is floored at ``min_root`` to keep the current
    finite.

    Args:
        flow_: commanded flow Φ, m³/s, shape (k,).
        dP: measured load pressure ΔP, Pa, (k,).
        gain: valve gain C, m³/(s·A), (k,).
        supply_pressure: Ps, Pa, (k,).
        current_limit: largest |i_v|, A, (k,).
        min_root: floor of the root (guards the division where it vanishes).
        orifice: per valve, True for the orifice law, False for the paper's, (k,) or a scalar.

    Returns:
        i_v, A, shape (k,).
    """
    law = np.frompyfunc(lambda q, p, ps, o: max(root(q, p, 1.0 / ps, bool(o)), min_root), 4, 1)
    r = np.asarray(law(flow_, dP, supply_pressure, orifice), dtype=float)
    current = np.asarray(flow_, dtype=float) / (np.asarray(gain) * r)
    return np.minimum(np.maximum(current, -np.asarray(current_limit)), current_limit)


# --- HydraulicCylinder's methods, as functions of its parameters ----------------------------------
def _relief(p: Any, dP: float) -> float:
    if p.relief_pressure is None:
        return 0.0
    return relief_flow(dP, p.relief_pressure, p.relief_gain)


def derivatives(p: Any, x: np.ndarray, u: float, q: float, v: float) -> np.ndarray:
    """(dΔP/dt, dQ/dt), Pa/s and m³/s² (``p``: a HydraulicActuator)."""
    dP, Q = float(x[0]), float(x[1])
    target = flow(u, dP, p.valve_gain, 1.0 / p.supply_pressure, p.orifice)
    relief = _relief(p, dP)
    return np.array([p.bulk_modulus / p.volume * (Q - p.leakage * dP - relief - p.area * v),
                     (target - Q) / p.valve_tau])


def steady(p: Any, force: float, q: float, v: float) -> tuple[np.ndarray, float]:
    """(x, u): ΔP = f/A, Q = A v + Le ΔP + Q_r, i_v from the valve law."""
    dP = force / p.area
    Q = p.area * v + p.leakage * dP + _relief(p, dP)
    r = root(Q, dP, 1.0 / p.supply_pressure, p.orifice)
    u = Q / (p.valve_gain * r) if r > 0.0 else math.copysign(math.inf, Q)
    return np.array([dP, Q]), u


def jacobians(p: Any, x: np.ndarray, u: float, q: float, v: float) -> dict[str, np.ndarray]:
    """The exact partial derivatives (the relief's slope K_r above its setting)."""
    c = p.bulk_modulus / p.volume
    dP = float(x[0])
    du, dp = slopes(u, dP, p.valve_gain, 1.0 / p.supply_pressure, p.orifice)
    relieving = p.relief_pressure is not None and abs(dP) > p.relief_pressure
    leak = p.leakage + (p.relief_gain if relieving else 0.0)
    return {"dxdot_dx": np.array([[-c * leak, c], [dp / p.valve_tau, -1.0 / p.valve_tau]]),
            "dxdot_du": np.array([0.0, du / p.valve_tau]),
            "dxdot_dv": np.array([-c * p.area, 0.0])}
