"""The valve-controlled hydraulic cylinder of the paper's eq. (4) as an actuator plugin.

States ΔP (differential pressure, Pa) and Q (valve flow, m³/s); command i_v (valve current, A):

    (V/E) dΔP/dt + Le ΔP + Q_r(ΔP) + A v = Q     (cylinder: compressibility, leakage, relief,
                                                   piston)
    Q + τ dQ/dt = Q*(i_v, ΔP)                     (valve: first-order lag to its steady flow)

with the valve law Q* (orifice or the paper's, :mod:`.valve`) and the relief flow Q_r (0 without a
relief valve); the joint force is A ΔP (N, or N·m with A in m³/rad).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, ClassVar

import mujoco
import numpy as np

from maniplab.actuators.base import ActuatorPlugin, Bound, Jacobians, Steady, set_command_range
from maniplab.actuators.hydraulic import valve
from maniplab.actuators.hydraulic.drive import PressureDrive
from maniplab.actuators.hydraulic.params import HydraulicActuator
from maniplab.actuators.plugin_mjcf import EnginePlugin

if TYPE_CHECKING:
    from maniplab.actuators.drive import ForceDrive
    from maniplab.spec import ControlSpec

HYDRAULIC_STATES = 2
"""Activation states of a hydraulic actuator: ΔP (Pa) and Q (m³/s), in that order."""

MUJOCO_PLUGIN = "maniplab.hydraulic"
"""The MuJoCo engine plugin (C, :mod:`maniplab_native`) that integrates eq. (4) in MuJoCo."""

PRESSURE_LIMIT = 10.0
"""A run whose |ΔP| exceeds this many times the supply pressure is declared unstable."""


def pressure_bound(params: HydraulicActuator) -> float:
    """|ΔP| beyond which a run is declared unstable: PRESSURE_LIMIT times the larger of the supply
    and relief pressures, Pa."""
    return PRESSURE_LIMIT * max(params.supply_pressure, params.relief_pressure or 0.0)


def pressure_problem(dP: float, params: HydraulicActuator) -> str | None:
    """What is wrong with a pressure beyond :func:`pressure_bound` (or NaN), else None."""
    if abs(dP) <= pressure_bound(params):
        return None
    advice = ("" if params.relief_pressure else
              "; nothing bounds it: give the cylinder a relief_pressure, or check its "
              "valve_gain, volume and area")
    return (f"ΔP = {dP:.4g} Pa is beyond {PRESSURE_LIMIT:g} times the supply pressure "
            f"({params.supply_pressure:.4g} Pa){advice}")


class HydraulicCylinder(ActuatorPlugin):
    """Eq. (4) on one joint: states (ΔP, Q), command i_v clipped at ±current_limit."""

    Params: ClassVar[type] = HydraulicActuator
    states: ClassVar[tuple[str, ...]] = ("dP", "Q")
    state_units: ClassVar[tuple[str, ...]] = ("Pa", "m³/s")
    command: ClassVar[str] = "iv"
    command_unit: ClassVar[str] = "A"
    spring_name: ClassVar[str] = "oil spring"
    energy: ClassVar[str | None] = "unaccounted"
    params: HydraulicActuator

    @property
    def command_limit(self) -> float:
        """``current_limit``, A."""
        return self.params.current_limit

    @functools.cached_property
    def law(self) -> valve.CylinderLaw:
        """The cylinder's parameters as the C law (``maniplab_native/valve.h``) takes them."""
        return valve.cylinder_law(self.params)

    def derivatives(self, x: np.ndarray, u: float, q: float, v: float) -> np.ndarray:
        """(dΔP/dt, dQ/dt), Pa/s and m³/s² (the C law, :func:`.valve.cylinder_rates`)."""
        return valve.cylinder_rates(self.law, float(x[0]), float(x[1]), float(u), float(v))

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        """A ΔP, N or N·m."""
        return float(self.params.area * x[0])

    def forces(self, x: np.ndarray, u: np.ndarray, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """A ΔP at N samples, (N,)."""
        return np.asarray(self.params.area * x[:, 0], dtype=float)

    def holding_range(self, q: float) -> tuple[float, float]:
        """±A p_max with the valve closed: p_max the relief's setting (the relief opens above it),
        else the supply pressure."""
        p = self.params
        return self.rated_holding_range(q, p.relief_pressure or p.supply_pressure)

    def rated_holding_range(self, q: float, pressure: float) -> tuple[float, float]:
        """±A p with ΔP up to the rating p (Pa)."""
        force = self.params.area * pressure
        return -force, force

    def bounds(self) -> list[Bound]:
        """ΔP within the supply pressure, and never beyond the relief's setting plus its
        override."""
        p = self.params
        out = [Bound("dP", p.supply_pressure, "supply pressure")]
        if p.relief_pressure is not None:
            out.append(Bound("dP", p.relief_pressure * (1.0 + valve.RELIEF_OVERRIDE),
                             "relief pressure", hard=True))
        return out

    def check_state(self, x: np.ndarray) -> str | None:
        """A pressure beyond PRESSURE_LIMIT times the supply (or relief) pressure, or NaN, is
        unstable."""
        return pressure_problem(float(x[0]), self.params)

    def state_limits(self) -> tuple[float, ...]:
        """(:func:`pressure_bound`, inf): ΔP as :meth:`check_state` judges it, Q any finite
        value."""
        return (pressure_bound(self.params), math.inf)

    def steady(self, force: float, q: float, v: float) -> Steady:
        """ΔP = f/A, Q = A v + Le ΔP + Q_r (the piston's flow, the leakage and what the relief
        lets by), i_v from the valve law (infinite where no current passes Q at that load)."""
        dP, Q, u = valve.cylinder_steady(self.law, float(force), float(v))
        return Steady(np.array([dP, Q]), u)

    def holding(self, force: float, q: float) -> np.ndarray:
        """ΔP = f/A with the valve's flow at zero (a run "held against gravity" starts so)."""
        return np.array([force / self.params.area, 0.0])

    def jacobians(self, x: np.ndarray, u: float, q: float, v: float) -> Jacobians:
        """Exact partial derivatives (the relief's slope K_r above its setting; the C law's,
        :func:`.valve.cylinder_partials`)."""
        d = valve.cylinder_partials(self.law, float(x[0]), float(u))
        return Jacobians(
            dxdot_dx=np.array([[d[0], d[1]], [d[2], d[3]]]),
            dxdot_du=np.array([0.0, d[4]]),
            dxdot_dq=np.zeros(2), dxdot_dv=np.array([d[5], 0.0]),
            df_dx=np.array([self.params.area, 0.0]), df_du=0.0, df_dq=0.0, df_dv=0.0,
        )

    @property
    def top_speed(self) -> float:
        """C i_max / A: the piston speed the valve's full flow gives, rad/s or m/s."""
        p = self.params
        return p.valve_gain * p.current_limit / p.area

    @property
    def lag(self) -> float:
        """The valve's time constant τ, s."""
        return self.params.valve_tau

    def stiffness(self, q: float) -> float:
        """The oil spring A²E/V, N/m or N·m/rad."""
        return self.spring

    def rates(self, native: bool = False) -> dict[str, float]:
        """The valve-pressure loop sqrt((E/V) g / τ), the frequency of ΔP and Q ringing against
        each other with the piston held, g = C i_max / (2 Ps r) the valve's flow change per pascal
        at full current where the law's root r is 1/4 (|ΔP| = 15/16 Ps; it grows without bound as
        the root vanishes, where the flow does); the valve's lag 1/τ; and the pressure decay of
        the leakage, Le E/V, and of the relief, (Le + K_r) E/V, unless ``native`` (the engine
        plugin solves the relief's regime exactly at each stage of MuJoCo's step and at its end,
        so it sets no step); all 1/s."""
        p = self.params
        c = p.bulk_modulus / p.volume
        slope = p.valve_gain * p.current_limit / (2.0 * p.supply_pressure * 0.25)
        relief = 0.0 if native else p.relief_gain
        return {"valve-pressure loop": math.sqrt(c * slope / p.valve_tau),
                "valve lag": 1.0 / p.valve_tau,
                "leakage and relief" if relief else "leakage": (p.leakage + relief) * c}

    @property
    def capacitance(self) -> float:
        """V/E, m³/Pa."""
        return self.params.volume / self.params.bulk_modulus

    @property
    def spring(self) -> float:
        """The oil spring A²E/V, N/m or N·m/rad."""
        p = self.params
        return p.area**2 * p.bulk_modulus / p.volume

    @classmethod
    def drive(cls, actuators: Sequence[ActuatorPlugin], joints: Sequence[int], *, dt: float,
              settings: ControlSpec) -> ForceDrive:
        """The paper's inner pressure loop with the valve inversion G2 (:class:`PressureDrive`)."""
        return PressureDrive(actuators, joints, dt=dt, settings=settings)

    def mujoco_plugin(self) -> EnginePlugin:
        """MuJoCo's engine plugin ``maniplab.hydraulic`` with the two states (ΔP, Q) and every
        parameter: MuJoCo integrates eq. (4) itself, in maniplab's plant and in any MuJoCo tool
        that loads the exported file (``import mujoco`` registers the plugin)."""
        p = self.params
        config: dict[str, float | str] = {
            "area": p.area, "bulk_modulus": p.bulk_modulus, "volume": p.volume,
            "leakage": p.leakage, "valve_gain": p.valve_gain, "supply_pressure": p.supply_pressure,
            "valve_tau": p.valve_tau, "valve_law": p.valve_law}
        if p.relief_pressure is not None:
            config |= {"relief_pressure": p.relief_pressure, "relief_gain": p.relief_gain}
        return EnginePlugin(MUJOCO_PLUGIN, HYDRAULIC_STATES, config)

    def configure_mjcf(self, act: mujoco.MjsActuator) -> None:
        """The valve current's range ±current_limit (the plugin, :meth:`mujoco_plugin`, is the
        rest)."""
        set_command_range(act, self.command_limit)

    def describe(self) -> str:
        """``hydraulic A=... Ps=... MPa``."""
        unit = "m²" if self.joint.prismatic else "m³/rad"
        p = self.params
        relief = f" relief {p.relief_pressure / 1e6:g} MPa" if p.relief_pressure else ""
        return (f"hydraulic A={p.area:g} {unit} Ps={p.supply_pressure / 1e6:g} MPa "
                f"{p.valve_law}{relief}")
