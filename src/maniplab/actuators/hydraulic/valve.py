"""The servo-valve's flow law, its inversion (the controller's G2) and the relief valve.

Steady flow Q* into the cylinder at valve current i_v and load pressure ΔP, normalised so that the
no-load flow is i_v C (C the valve gain, Ps the supply pressure):

- ``orifice`` (the default; Merritt's critically lapped valve): Q* = i_v C sqrt(max(0, 1 -
  sign(i_v) ΔP / Ps)). Oil flows through the metering edges at the pressure drop across them:
  pushing against the load (i_v and ΔP of one sign) the drop, and the flow, fall as ΔP nears Ps;
  letting a load down (opposite signs) the load adds to the drop and the flow rises. A lowered load
  is thus braked by the valve, and the energy goes to heat;
- ``paper``: the paper's eq. (4), Q* = i_v C sqrt(max(0, 1 - |ΔP| / Ps)): the flow falls with the
  load whichever way it acts. Lowering a load, the harder the load pushes oil out the less the
  valve lets through, i.e. negative damping: kept to reproduce the paper.

A relief valve across the cylinder (``relief_pressure`` p_r) passes Q_r = K_r (|ΔP| - p_r) sign(ΔP)
above its setting, with K_r sized so that it passes the valve's full no-load flow C i_max at 1 %
above the setting (:func:`relief_gain`).

The law is written once, in C (``maniplab_native/valve.h``): the hydraulic engine plugin, the
compiled cascade's G2 and, through the functions here, the cylinder model's derivatives, steady
state and Jacobians, the linearisation and the controller's blocks all evaluate that code.
"""

from __future__ import annotations

import ctypes
from ctypes import c_double, c_int, c_void_p
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from maniplab.clib import Functions

LAWS = ("orifice", "paper")
"""The valve laws, by name (``valve_law`` of a hydraulic actuator)."""

RELIEF_OVERRIDE = 0.01
"""The relief passes the valve's full no-load flow this far (relative) above its setting."""


class CylinderLaw(ctypes.Structure):
    """``ml_cylinder`` (valve.h): one cylinder's parameters as the C law uses them."""

    _fields_ = [
        ("area", c_double), ("stiffness", c_double), ("leakage", c_double),
        ("valve_gain", c_double), ("inv_supply", c_double), ("inv_tau", c_double),
        ("relief", c_double), ("relief_gain", c_double), ("orifice", c_int),
    ]


_D = c_double
_P = c_void_p
_CYLINDER = ctypes.POINTER(CylinderLaw)
_C = Functions({
    "ml_valve_root": (_D, [_D, _D, _D, c_int]),
    "ml_valve_flow": (_D, [_D, _D, _D, _D, c_int]),
    "ml_valve_slopes": (None, [_D, _D, _D, _D, c_int, _P]),
    "ml_relief_flow": (_D, [_D, _D, _D]),
    "ml_valve_flows": (None, [c_int, _P, _P, _P, _P, _P, _P]),
    "ml_valve_currents": (None, [c_int, _P, _P, _P, _P, _P, _D, _P, _P]),
    "ml_cylinder_rates": (None, [_CYLINDER, _D, _D, _D, _D, _P]),
    "ml_cylinder_partials": (None, [_CYLINDER, _D, _D, _P]),
    "ml_cylinder_steady": (None, [_CYLINDER, _D, _D, _P]),
})
"""The valve law's C functions (``maniplab_native/valve.c``)."""


def root(current: float, dP: float, inv_supply: float, orifice: bool) -> float:
    """The share of the no-load flow the valve passes at ΔP: sqrt(max(0, 1 - s ΔP/Ps)) with
    s = sign(i_v) (orifice law) or s = sign(ΔP) (paper law); ``inv_supply`` = 1/Ps, 1/Pa."""
    return float(_C().ml_valve_root(current, dP, inv_supply, bool(orifice)))


def flow(current: float, dP: float, gain: float, inv_supply: float, orifice: bool) -> float:
    """Steady valve flow Q* = i_v C root, m³/s (see :func:`root`)."""
    return float(_C().ml_valve_flow(current, dP, gain, inv_supply, bool(orifice)))


def slopes(current: float, dP: float, gain: float, inv_supply: float,
           orifice: bool) -> tuple[float, float]:
    """(∂Q*/∂i_v, ∂Q*/∂ΔP) of :func:`flow`, m³/(s·A) and m³/(s·Pa).

    Where the orifice law's flow is not differentiable in i_v (at i_v = 0 under load, where the
    pressure drop jumps from one edge to the other) the mean of its two one-sided slopes is given.
    Where the root vanishes both are 0.
    """
    out = (c_double * 2)()
    _C().ml_valve_slopes(current, dP, gain, inv_supply, bool(orifice), ctypes.addressof(out))
    return out[0], out[1]


def relief_gain(gain: float, current_limit: float, relief_pressure: float) -> float:
    """K_r, m³/(s·Pa): the relief passes C i_max at (1 + RELIEF_OVERRIDE) p_r."""
    return gain * current_limit / (RELIEF_OVERRIDE * relief_pressure)


def relief_flow(dP: float, relief_pressure: float, relief_gain_: float) -> float:
    """Q_r = K_r (|ΔP| - p_r) sign(ΔP) above the setting, else 0, m³/s (out of the high side)."""
    return float(_C().ml_relief_flow(dP, relief_pressure, relief_gain_))


def _flat(values: Any, dtype: Any = np.float64) -> np.ndarray:
    """A contiguous 1-D copy (or view) of a broadcast array, for a C loop."""
    return np.ascontiguousarray(np.asarray(values).ravel(), dtype=dtype)


def _flags(values: Any) -> np.ndarray:
    """Truth values (e.g. ``orifice``) as C ints, 1-D."""
    return _flat(np.asarray(values).astype(bool), np.intc)


def valve_flow(current: ArrayLike, dP: ArrayLike, gain: ArrayLike, supply_pressure: ArrayLike,
               *, orifice: ArrayLike = True) -> NDArray[np.float64]:
    """:func:`flow` element-wise over arrays (broadcast), m³/s."""
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float)
                                   for a in (current, dP, gain, supply_pressure)),
                                 np.asarray(orifice))
    shape = arrays[0].shape
    i, p, c, ps = (_flat(a) for a in arrays[:4])
    law = _flags(arrays[4])
    out = np.empty(i.size)
    _C().ml_valve_flows(i.size, i.ctypes.data, p.ctypes.data, c.ctypes.data, ps.ctypes.data,
                       law.ctypes.data, out.ctypes.data)
    return out.reshape(shape)


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
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float)
                                   for a in (flow_, dP, gain, supply_pressure, current_limit)),
                                 np.asarray(orifice))
    shape = arrays[0].shape
    q, p, c, ps, limit = (_flat(a) for a in arrays[:5])
    law = _flags(arrays[5])
    out = np.empty(q.size)
    _C().ml_valve_currents(q.size, q.ctypes.data, p.ctypes.data, c.ctypes.data, ps.ctypes.data,
                          limit.ctypes.data, float(min_root), law.ctypes.data, out.ctypes.data)
    return out.reshape(shape)


# --- the cylinder's equations (eq. 4), for HydraulicCylinder ---------------------------------------
def cylinder_law(params: Any) -> CylinderLaw:
    """The C law's parameters (``ml_cylinder``) of a cylinder's
    :class:`~maniplab.actuators.hydraulic.params.HydraulicActuator`: E/V, 1/Ps and 1/τ computed as
    the engine plugin computes them."""
    relief = params.relief_pressure
    return CylinderLaw(
        area=params.area, stiffness=params.bulk_modulus / params.volume,
        leakage=params.leakage, valve_gain=params.valve_gain,
        inv_supply=1.0 / params.supply_pressure, inv_tau=1.0 / params.valve_tau,
        relief=0.0 if relief is None else relief,
        relief_gain=0.0 if relief is None else params.relief_gain,
        orifice=int(params.orifice))


def cylinder_rates(law: CylinderLaw, dP: float, Q: float, u: float, v: float) -> np.ndarray:
    """(dΔP/dt, dQ/dt) of eq. (4) with the relief's flow, Pa/s and m³/s², shape (2,).

    Args:
        law: the cylinder (:func:`cylinder_law`).
        dP: ΔP, Pa.  Q: valve flow, m³/s.  u: valve current (clipped), A.
        v: joint speed, rad/s or m/s.
    """
    out = np.empty(2)
    _C().ml_cylinder_rates(ctypes.byref(law), dP, Q, u, v, out.ctypes.data)
    return out


def cylinder_partials(law: CylinderLaw, dP: float, u: float) -> np.ndarray:
    """The exact partial derivatives of :func:`cylinder_rates` (the relief's slope above its
    setting), shape (6,): ∂(dΔP/dt)/∂ΔP, ∂(dΔP/dt)/∂Q, ∂(dQ/dt)/∂ΔP, ∂(dQ/dt)/∂Q, ∂(dQ/dt)/∂u,
    ∂(dΔP/dt)/∂v (the others are 0)."""
    out = np.empty(6)
    _C().ml_cylinder_partials(ctypes.byref(law), dP, u, out.ctypes.data)
    return out


def cylinder_steady(law: CylinderLaw, force: float, v: float) -> tuple[float, float, float]:
    """(ΔP, Q, i_v) that hold ``force`` (N or N·m) at joint speed v: ΔP = f/A,
    Q = A v + Le ΔP + Q_r, i_v the law inverted exactly (±inf where no current passes Q)."""
    out = np.empty(3)
    _C().ml_cylinder_steady(ctypes.byref(law), force, v, out.ctypes.data)
    return float(out[0]), float(out[1]), float(out[2])
