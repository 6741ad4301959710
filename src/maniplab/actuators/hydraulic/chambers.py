"""The two-chamber cylinder's equations, evaluated by the C code the engine plugin runs.

The equations are written once, in ``maniplab_native/chambers.h`` (see its comment for them):
the engine plugin ``maniplab.cylinder`` integrates them inside MuJoCo, and the functions here call
the same code for the actuator model's derivatives, steady state and checks.
"""

from __future__ import annotations

import ctypes
import math
from ctypes import c_double, c_void_p
from typing import TYPE_CHECKING

import numpy as np

from maniplab.actuators.hydraulic.params import HoldingValve, PinnedHydraulicActuator
from maniplab.clib import Functions

if TYPE_CHECKING:
    from maniplab.spec.arm import Supply

LAMINAR = 0.05
"""The orifices turn laminar (their flow linear in the drop) below this share of the valve's
nominal drop per edge: it keeps their slope, and so the step the arm needs, finite."""


POINTS = 16
"""The most points of a valve's opening characteristic (chambers.h's ML_VALVE_POINTS)."""


class ChambersLaw(ctypes.Structure):
    """``ml_chambers`` (chambers.h): one cylinder's parameters as the C law uses them."""

    _fields_ = [*((name, c_double) for name in (
        "area_a", "area_b", "dead_a", "dead_b", "min_length", "stroke", "bulk_modulus",
        "leakage", "gain_a", "gain_b", "laminar", "supply", "tank", "relief", "inv_tau",
        "inv_current", "out_a", "out_b", "margin", "ls_margin", "ls_others", "deadband",
        "points")), ("point_u", c_double * POINTS), ("point_x", c_double * POINTS),
        ("post", c_double), ("cushion_length", c_double), ("cushion_gain", c_double),
        *((name, c_double * 2) for name in (
            "hold_type", "hold_setting", "hold_ratio", "hold_gain", "hold_band", "hold_leakage",
            "burst", "burst_gain"))]


_D = c_double
_P = c_void_p
_LAW = ctypes.POINTER(ChambersLaw)
_C = Functions({
    "ml_chambers_rates": (None, [_LAW, _D, _D, _D, _D, _D, _D, _P]),
    "ml_chambers_force": (_D, [_LAW, _D, _D]),
    "ml_chambers_flows": (None, [_LAW, _D, _D, _D, _D, _P]),
    "ml_chambers_forces": (None, [_LAW, ctypes.c_int, _P, _P, _P]),
    "ml_chambers_flows_many": (None, [_LAW, ctypes.c_int, _P, _P]),
    "ml_chambers_hold_openings": (None, [_LAW, ctypes.c_int, _P, _P, _P]),
    "ml_chambers_spool_target": (_D, [_LAW, _D]),
    "ml_chambers_spool_command": (_D, [_LAW, _D]),
})
"""The C functions (``maniplab_native/chambers.c``)."""


def chambers_law(p: PinnedHydraulicActuator, pump: Supply | None = None) -> ChambersLaw:
    """The C law's parameters of a pinned cylinder's spec; on a load-sensing ``pump``, as the
    section sees it alone (its own load sets the pump's pressure: the others' at tank)."""
    c, v = p.cylinder, p.valve
    dead_a, dead_b = p.chamber_dead_volumes  # hoses included
    law = ChambersLaw(
        area_a=c.cap_area, area_b=c.rod_area, dead_a=dead_a, dead_b=dead_b,
        min_length=c.min_length, stroke=c.stroke, bulk_modulus=p.bulk_modulus,
        leakage=p.leakage, gain_a=v.gain_a, gain_b=v.gain_b, laminar=LAMINAR * v.edge_drop,
        supply=p.supply_pressure, tank=p.tank_pressure, relief=p.relief_pressure or 0.0,
        inv_tau=1.0 / v.tau, inv_current=1.0 / v.current_limit, out_a=v.out_a, out_b=v.out_b,
        margin=v.compensator_margin or 0.0, deadband=v.deadband, post=float(v.flow_sharing))
    for k, (command, opening) in enumerate(v.characteristic or ()):
        law.point_u[k], law.point_x[k] = command, opening
    law.points = len(v.characteristic or ())
    if c.cushions is not None:
        law.cushion_length, law.cushion_gain = c.cushions.length, c.cushions.gain
    for k, valve in enumerate(holding_valves(p)):
        if valve is not None:
            law.hold_type[k] = HOLD_TYPES[valve.type]
            law.hold_setting[k], law.hold_ratio[k] = valve.crack, valve.pilot_ratio
            law.hold_gain[k], law.hold_band[k] = valve.gain, valve.band
            law.hold_leakage[k] = valve.leakage
    law.burst_gain[:] = burst_gains(p)
    if pump is not None and pump.ls_margin is not None:
        law.ls_margin, law.ls_others = pump.ls_margin, p.tank_pressure
    return law


HOLD_TYPES = {"counterbalance": 1, "pilot_check": 2}
"""The C law's codes of the holding valves' types (chambers.h's ML_HOLD_*)."""

BURST_DIAMETER = 0.0127
"""The bore of a line that bursts where the spec gives no hose, m (half an inch)."""

BURST_DISCHARGE = 0.7
"""The discharge coefficient of a burst line's open end."""

OIL_DENSITY = 870.0
"""kg/m³, for a burst line's open end."""


def holding_valves(p: PinnedHydraulicActuator) -> tuple[HoldingValve | None, HoldingValve | None]:
    """The load-holding valves on chambers A and B (None where there is none)."""
    h = p.holding
    return (None, None) if h is None else (h.a, h.b)


def burst_gains(p: PinnedHydraulicActuator) -> tuple[float, float]:
    """K of each line's open end if it bursts, m³/(s·√Pa): C_d π d²/4 √(2/ρ), d its hose's
    inner diameter (:data:`BURST_DIAMETER` without one)."""
    hoses = p.cylinder.hoses
    bores = [getattr(getattr(hoses, side, None), "inner_diameter", None) or BURST_DIAMETER
             for side in "ab"]
    return tuple(BURST_DISCHARGE * math.pi / 4.0 * d**2 * math.sqrt(2.0 / OIL_DENSITY)
                 for d in bores)  # type: ignore[return-value]


def plugin_config(p: PinnedHydraulicActuator) -> dict[str, float | str]:
    """The engine plugin's config (the names ``cylinder.c`` reads)."""
    law = chambers_law(p)
    config: dict[str, float | str] = {name: getattr(law, name) for name in (
        "area_a", "area_b", "dead_a", "dead_b", "min_length", "stroke", "bulk_modulus",
        "leakage", "gain_a", "gain_b", "laminar", "out_a", "out_b")}
    config |= {"supply_pressure": p.supply_pressure, "tank_pressure": p.tank_pressure,
               "valve_tau": p.valve.tau, "current_limit": p.valve.current_limit}
    if p.relief_pressure is not None:
        config["relief_pressure"] = p.relief_pressure
    if p.valve.compensator_margin is not None:
        config["compensator_margin"] = p.valve.compensator_margin
    if p.valve.deadband > 0.0:
        config["deadband"] = p.valve.deadband
    if p.valve.flow_sharing:
        config["flow_sharing"] = 1.0
    if p.cylinder.cushions is not None:
        config["cushion"] = f"{p.cylinder.cushions.length!r} {p.cylinder.cushions.gain!r}"
    for side, valve in zip("ab", holding_valves(p), strict=True):
        if valve is not None:
            config[f"holding_{side}"] = " ".join(repr(float(v)) for v in (
                HOLD_TYPES[valve.type], valve.crack, valve.pilot_ratio, valve.gain, valve.band,
                valve.leakage))
    config["burst_gain"] = " ".join(repr(float(g)) for g in burst_gains(p))
    if p.valve.characteristic is not None:
        config["characteristic"] = " ".join(repr(float(v)) for point in p.valve.characteristic
                                            for v in point)
    return config


def rates(law: ChambersLaw, x: np.ndarray, u: float, s: float, sdot: float) -> np.ndarray:
    """(dpA/dt, dpB/dt, dx/dt) at states x = (pA, pB, spool), current u (A, clipped), length s
    (m) and its rate (m/s): Pa/s, Pa/s, 1/s, shape (3,)."""
    out = np.empty(3)
    _C().ml_chambers_rates(ctypes.byref(law), float(x[0]), float(x[1]), float(x[2]), float(u),
                           float(s), float(sdot), out.ctypes.data)
    return out


def force(law: ChambersLaw, pa: float, pb: float) -> float:
    """pA A_A - pB A_B with the pressures within [Pt, p_r], N."""
    return float(_C().ml_chambers_force(ctypes.byref(law), float(pa), float(pb)))


def forces(law: ChambersLaw, pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """:func:`force` at N samples: pA, pB (N,) -> (N,), N."""
    a, b = (np.ascontiguousarray(v, dtype=float) for v in (pa, pb))
    out = np.empty(a.size)
    _C().ml_chambers_forces(ctypes.byref(law), a.size, a.ctypes.data, b.ctypes.data,
                            out.ctypes.data)
    return out


def hold_openings(law: ChambersLaw, pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """The load-holding valves' openings at N samples: pA, pB (N,) -> (N, 2), 0..1, NaN where a
    chamber has none (the pilot at the other chamber's pressure)."""
    a, b = (np.ascontiguousarray(v, dtype=float) for v in (pa, pb))
    out = np.empty((a.size, 2))
    _C().ml_chambers_hold_openings(ctypes.byref(law), a.size, a.ctypes.data, b.ctypes.data,
                                   out.ctypes.data)
    return out


def flows(law: ChambersLaw, x: np.ndarray, s: float) -> np.ndarray:
    """(Q_A, Q_B, V_A, V_B): the valve's flows into the chambers (m³/s) at states x and the
    chamber volumes at length s (m³)."""
    out = np.empty(4)
    _C().ml_chambers_flows(ctypes.byref(law), float(x[0]), float(x[1]), float(x[2]), float(s),
                           out.ctypes.data)
    return out


def valve_flows(law: ChambersLaw, x: np.ndarray) -> np.ndarray:
    """The valve's flows into the chambers (Q_A, Q_B) at K states x = (pA, pB, spool), (K, 3)
    -> (K, 2), m³/s: :func:`flows`' first two at many states in one call."""
    states = np.ascontiguousarray(x, dtype=float).reshape(-1, 3)
    out = np.empty((len(states), 2))
    _C().ml_chambers_flows_many(ctypes.byref(law), len(states), states.ctypes.data,
                                out.ctypes.data)
    return out


def spool_target(law: ChambersLaw, command: float) -> float:
    """The spool's steady opening (-1..1) at the valve command (its deadband or characteristic)."""
    return float(_C().ml_chambers_spool_target(ctypes.byref(law), float(command)))


def spool_command(law: ChambersLaw, opening: float) -> float:
    """The command nearest neutral that asks for ``opening`` (clipped to -1..1)."""
    return float(_C().ml_chambers_spool_command(ctypes.byref(law), float(opening)))
