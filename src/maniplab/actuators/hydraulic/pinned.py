"""A two-chamber cylinder pinned across its joint, fed by a four-edge valve, as an actuator plugin.

States pA, pB (cap- and rod-side pressures, Pa) and the spool's opening x; command i_v (valve
current, A). The equations are ``maniplab_native/chambers.h``'s (:mod:`.chambers`); the
cylinder's length s(q) and moment arm r(q) are :mod:`.geometry`'s. The joint force is
(pA A_A - pB A_B) r(q).

In the arm's MuJoCo model the cylinder is a spatial tendon between two sites at its pins, driven
by the engine plugin ``maniplab.cylinder``: MuJoCo computes s, ds/dt and the moment arm itself
and draws the cylinder.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, ClassVar

import mujoco
import numpy as np

from maniplab.actuators.base import (
    ActuatorPlugin,
    Bound,
    JointFrame,
    Mount,
    ParameterProblem,
    Steady,
    set_command_range,
)
from maniplab.actuators.hydraulic import chambers
from maniplab.actuators.hydraulic.chamber_steady import SteadyFlows
from maniplab.actuators.hydraulic.cylinder import PRESSURE_LIMIT
from maniplab.actuators.hydraulic.geometry import PinGeometry
from maniplab.actuators.hydraulic.hose import P_ATM
from maniplab.actuators.hydraulic.params import PinnedHydraulicActuator
from maniplab.actuators.plugin_mjcf import EnginePlugin

if TYPE_CHECKING:
    from maniplab.actuators.drive import ForceDrive
    from maniplab.spec import ControlSpec
    from maniplab.spec.arm import Supply

MUJOCO_PLUGIN = "maniplab.cylinder"
"""The MuJoCo engine plugin (C, :mod:`maniplab_native`) that integrates the two chambers."""

TENDON_SUFFIX = "/cylinder"
"""The tendon of joint j's cylinder is ``<j>/cylinder``; its pins are sites ``<j>/cylinder_base``
(on the body before the joint) and ``<j>/cylinder_rod`` (on the body it moves)."""

COLOUR = (0.85, 0.65, 0.13, 1.0)
"""The cylinders' colour in renders: hydraulic yellow."""


def geometry_of(params: PinnedHydraulicActuator, joint: JointFrame) -> PinGeometry:
    """The cylinder's pin geometry on ``joint``."""
    pins = params.cylinder.pins
    return PinGeometry(pins.parent, pins.child, joint.axis, joint.prismatic)


class PinnedCylinder(ActuatorPlugin):
    """A pinned two-chamber cylinder: states (pA, pB, spool), command i_v clipped at the valve's
    ``current_limit``."""

    Params: ClassVar[type] = PinnedHydraulicActuator
    variant_key: ClassVar[str | None] = "cylinder"
    states: ClassVar[tuple[str, ...]] = ("pA", "pB", "spool")
    state_units: ClassVar[tuple[str, ...]] = ("Pa", "Pa", "")
    command: ClassVar[str] = "iv"
    spring_name: ClassVar[str] = "oil spring"
    outputs: ClassVar[dict[str, str]] = {"stroke": "m", "cylinder_force": "N", "hold_a": "",
                                         "hold_b": ""}
    energy: ClassVar[str | None] = "plugin"
    lines: ClassVar[tuple[str, ...]] = ("a", "b")
    params: PinnedHydraulicActuator

    @classmethod
    def check_joint(cls, params: Any, joint: JointFrame) -> None:
        """The pins must give a moment arm that does not vanish within the joint's limits, and
        the stroke must span the lengths those limits need.

        Raises:
            ParameterProblem: naming ``cylinder.pins``, ``cylinder.stroke``, ...
        """
        c = params.cylinder
        problem = geometry_of(params, joint).problem(joint.limits, c.min_length, c.max_length)
        if problem is not None:
            raise ParameterProblem(problem.field, problem.message)

    @functools.cached_property
    def geometry(self) -> PinGeometry:
        """s(q) and r(q) on this joint."""
        j = self.joint
        return geometry_of(self.params, JointFrame(j.prismatic, j.axis_vector, j.limits))

    pump: Supply | None = None
    """The spec's shared pump, when a controller has told this cylinder of it (:meth:`on_pump`)."""

    @functools.cached_property
    def law(self) -> chambers.ChambersLaw:
        """The parameters as the C law takes them (with the load-sensing pump it is on, if any:
        its own load sets the pump's pressure)."""
        return chambers.chambers_law(self.params, self.pump)

    def on_pump(self, supply: Supply | None) -> None:
        """This cylinder is fed by the spec's shared pump ``supply``: a controller's view of its
        valve (:attr:`law`) takes a load-sensing pump's pressure as its own load plus the
        margin, not the cut-off."""
        self.pump = supply
        self.__dict__.pop("law", None)

    @property
    def command_unit(self) -> str:  # type: ignore[override]
        """The valve command's unit, as its datasheet gives it (``valve.command_unit``)."""
        return self.params.valve.command_unit

    @property
    def command_limit(self) -> float:
        """The valve's ``current_limit``, A."""
        return self.params.valve.current_limit

    # --- the model ------------------------------------------------------------------------------
    def initial_state(self) -> np.ndarray:
        """Both chambers at tank pressure, the spool closed."""
        t = self.params.tank_pressure
        return np.array([t, t, 0.0])

    def derivatives(self, x: np.ndarray, u: float, q: float, v: float) -> np.ndarray:
        """(dpA/dt, dpB/dt, dx/dt) with s = s(q) and ds/dt = r(q) v."""
        s, r = float(self.geometry.length(q)), float(self.geometry.arm(q))
        return chambers.rates(self.law, x, u, s, r * v)

    def cylinder_force(self, x: np.ndarray) -> float:
        """pA A_A - pB A_B along the pins (the pressures within [Pt, p_r]), N."""
        return chambers.force(self.law, float(x[0]), float(x[1]))

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        """(pA A_A - pB A_B) r(q), N·m or N."""
        return self.cylinder_force(x) * float(self.geometry.arm(q))

    def output_values(self, x: np.ndarray, q: np.ndarray) -> dict[str, np.ndarray]:
        """``stroke``: the piston's travel s(q) - min_length, m; ``cylinder_force``: pA A_A -
        pB A_B along the pins, N (positive pushing them apart); ``hold_a``, ``hold_b``: the
        load-holding valves' openings, 0..1 (NaN without one; the pilot at the other chamber's
        pressure)."""
        travel = self.geometry.length(q) - self.params.cylinder.min_length
        force = chambers.forces(self.law, x[:, 0], x[:, 1])
        hold = chambers.hold_openings(self.law, x[:, 0], x[:, 1])
        return {"stroke": np.asarray(travel, dtype=float), "cylinder_force": force,
                "hold_a": hold[:, 0], "hold_b": hold[:, 1]}

    def forces(self, x: np.ndarray, u: np.ndarray, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """:meth:`force` at N samples, (N,)."""
        return chambers.forces(self.law, x[:, 0], x[:, 1]) * self.geometry.arm(q)

    def holding_range(self, q: float) -> tuple[float, float]:
        """The joint forces held with the valve closed: one chamber at the relief's setting (or
        the supply's), the other at tank, times r(q)."""
        return self.rated_holding_range(q, self.params.holding_pressure)

    def rated_holding_range(self, q: float, pressure: float) -> tuple[float, float]:
        """The holding range with one chamber up to the rating ``pressure`` (Pa), or to its
        counterbalance valve's setting where that is lower (the valve opens there with its
        pilot at tank), the other at tank, times r(q)."""
        c = self.params.cylinder
        low = self.params.tank_pressure
        top_a, top_b = (min(pressure, low + valve.crack)
                        if valve is not None and valve.type == "counterbalance" else pressure
                        for valve in chambers.holding_valves(self.params))
        push, pull = top_a * c.cap_area - low * c.rod_area, low * c.cap_area - top_b * c.rod_area
        r = float(self.geometry.arm(q))
        return (pull * r, push * r) if r > 0.0 else (push * r, pull * r)

    def holding(self, force: float, q: float) -> np.ndarray:
        """Pressures that hold ``force`` with the spool closed and the lower one at tank."""
        c, tank = self.params.cylinder, self.params.tank_pressure
        f = force / float(self.geometry.arm(q))
        pa = (f + tank * c.rod_area) / c.cap_area
        if pa >= tank:
            return np.array([pa, tank, 0.0])
        return np.array([tank, (tank * c.cap_area - f) / c.rod_area, 0.0])

    def steady(self, force: float, q: float, v: float) -> Steady:
        """The pressures and spool that hold ``force`` at joint speed v (the valve's flows
        balancing the piston's and the leakage, or an overrunning load's chamber at tank: see
        :mod:`.chamber_steady`), and the current that opens the spool so far (infinite where no
        opening within ±1 does)."""
        p = self.params
        if v == 0.0 and p.leakage == 0.0:
            return Steady(self.holding(force, q), 0.0)
        x = SteadyFlows(self, force, q, v).solve()
        if x is None:
            x = self.holding(force, q)
            return Steady(x, math.copysign(math.inf, float(self.geometry.arm(q)) * v or 1.0))
        if abs(x[2]) > 1.0:
            return Steady(x, math.copysign(math.inf, x[2]))
        return Steady(x, chambers.spool_command(self.law, float(x[2])))

    # --- what bounds it -------------------------------------------------------------------------
    def bounds(self) -> list[Bound]:
        """Each chamber within the supply pressure, or its counterbalance valve's setting where
        that is higher (the valve brakes a load up to it); never beyond the relief's setting."""
        p = self.params
        out = []
        for name, valve in zip(("pA", "pB"), chambers.holding_valves(p), strict=True):
            braked = valve is not None and valve.type == "counterbalance" and (
                p.tank_pressure + valve.crack > p.supply_pressure)
            out.append(Bound(name, p.tank_pressure + valve.crack, "counterbalance setting")
                       if braked and valve is not None else
                       Bound(name, p.supply_pressure, "supply pressure"))
        if p.relief_pressure is not None:
            out += [Bound(name, p.relief_pressure * (1.0 + 1e-9), "relief pressure", hard=True)
                    for name in ("pA", "pB")]
        return out

    def _pressure_bound(self) -> float:
        p = self.params
        return PRESSURE_LIMIT * max(p.supply_pressure, p.relief_pressure or 0.0)

    def check_state(self, x: np.ndarray) -> str | None:
        """A chamber pressure beyond PRESSURE_LIMIT times the supply (or relief) pressure, or
        NaN, is unstable."""
        bound = self._pressure_bound()
        for name, value in zip(("pA", "pB"), x[:2]):
            if not abs(value) <= bound:
                return (f"{name} = {value:.4g} Pa is beyond {PRESSURE_LIMIT:g} times the supply "
                        f"pressure ({self.params.supply_pressure:.4g} Pa)")
        return None

    def state_limits(self) -> tuple[float, ...]:
        """(bound, bound, inf): the pressures as :meth:`check_state` judges them."""
        bound = self._pressure_bound()
        return (bound, bound, math.inf)

    # --- speed, stiffness and rates -------------------------------------------------------------
    def piston_speed(self) -> float:
        """The slower of the piston's no-load extension and retraction speeds at full opening,
        m/s: each edge passes K sqrt(drop), and the chamber pressures balance (pA A_A = pB A_B);
        a compensated meter-in edge passes at most K sqrt(margin)."""
        p, c, law = self.params, self.params.cylinder, self.law
        ps, pt, a, b = p.supply_pressure, p.tank_pressure, c.cap_area, c.rod_area
        out = (a * ps - b * pt) / (a**3 / law.gain_a**2 + b**3 / law.out_b**2)
        back = (b * ps - a * pt) / (b**3 / law.gain_b**2 + a**3 / law.out_a**2)
        speeds = [math.sqrt(max(out, 0.0)), math.sqrt(max(back, 0.0))]
        margin = p.valve.compensator_margin
        if margin is not None:  # the compensator holds the meter-in flow
            speeds = [min(speeds[0], law.gain_a * math.sqrt(margin) / a),
                      min(speeds[1], law.gain_b * math.sqrt(margin) / b)]
        return min(speeds)

    @property
    def mid_arm(self) -> float:
        """r at the middle of the joint's limits, m (or 1 for a prismatic joint's)."""
        limits = self.joint.limits or (0.0, 0.0)
        return float(self.geometry.arm(0.5 * sum(limits)))

    @property
    def top_speed(self) -> float:
        """:meth:`piston_speed` over the moment arm at mid-range, rad/s or m/s."""
        return self.piston_speed() / abs(self.mid_arm)

    @property
    def lag(self) -> float:
        """The spool's time constant, s."""
        return self.params.valve.tau

    def stiffness(self, q: float) -> float:
        """E (A_A²/V_A + A_B²/V_B) r(q)², the two oil columns in series with the rod, at the
        chamber volumes of position q, N·m/rad or N/m."""
        c = self.params.cylinder
        s, r = float(self.geometry.length(q)), float(self.geometry.arm(q))
        _, _, va, vb = chambers.flows(self.law, self.initial_state(), s)
        return self.params.bulk_modulus * (c.cap_area**2 / va + c.rod_area**2 / vb) * r**2

    def _smallest_volume(self) -> float:
        return min(self.params.chamber_dead_volumes)

    def _hose_lines(self) -> list[str]:
        """What the hoses add to the dead volumes (none without hoses), for :meth:`details`."""
        p, hoses = self.params, self.params.cylinder.hoses
        if hoses is None or (hoses.a is None and hoses.b is None):
            return []
        pressure = p.supply_pressure + P_ATM
        parts = [f"{side} {h.length:g} m x ⌀{h.inner_diameter * 1e3:g} mm, {h.volume * 1e3:.4g} L "
                 f"at β_e {h.bulk_modulus(p.bulk_modulus, pressure) / 1e9:.3g} GPa: "
                 f"+{h.equivalent_volume(p.bulk_modulus, pressure) * 1e3:.4g} L"
                 for side, h in (("A", hoses.a), ("B", hoses.b)) if h is not None]
        va, vb = p.chamber_dead_volumes
        line = (f"{' ' * len(self.joint.name)}  hoses {'; '.join(parts)} (oil at "
                f"{p.bulk_modulus / 1e9:.3g} GPa): dead volumes {va * 1e3:.4g}, {vb * 1e3:.4g} L")
        return [line]

    def _cushion_lines(self) -> list[str]:
        """The end cushions (none without), for :meth:`details`."""
        cushions = self.params.cylinder.cushions
        if cushions is None:
            return []
        line = (f"{' ' * len(self.joint.name)}  end cushions {cushions.length * 1e3:.4g} mm at "
                f"both ends, the throttle {cushions.nominal_flow * 6e4:.4g} L/min at "
                f"{cushions.nominal_pressure_drop / 1e5:.4g} bar at the very end")
        return [line]

    def _holding_lines(self) -> list[str]:
        """The load-holding valves (none without), for :meth:`details`."""
        lines = []
        for side, valve in zip("AB", chambers.holding_valves(self.params), strict=True):
            if valve is None:
                continue
            pilot = "AB".replace(side, "")
            if valve.type == "counterbalance":
                what = (f"counterbalance valve on {side}: setting {valve.crack / 1e5:.4g} bar, "
                        f"pilot ratio {valve.pilot_ratio:.3g}:1 from {pilot}")
            else:
                what = (f"pilot-operated check on {side}: pilot ratio {valve.pilot_ratio:.3g}:1 "
                        f"from {pilot}, spring {valve.crack / 1e5:.4g} bar")
            lines.append(f"{' ' * len(self.joint.name)}  {what}; "
                         f"{valve.nominal_flow * 6e4:.4g} L/min at "
                         f"{valve.nominal_pressure_drop / 1e5:.4g} bar fully open, over "
                         f"{valve.band / 1e5:.4g} bar")
        return lines

    def rates(self, native: bool = False) -> dict[str, float]:
        """The spool's lag 1/τ and the pressure decay of the leakage across the piston,
        Le E (1/V_A0 + 1/V_B0), 1/s; none in the engine plugin, whose exponential step takes
        them exactly (``maniplab_native/stiff.h``)."""
        if native:
            return {}
        p = self.params
        leak = p.leakage * p.bulk_modulus * sum(1.0 / v for v in p.chamber_dead_volumes)
        return {"spool lag": 1.0 / p.valve.tau, "leakage": leak}

    def decays(self, native: bool = False) -> dict[str, float]:
        """A chamber filling through a wide-open edge: E/V_0 K / sqrt(p_l), the orifice's
        steepest slope (at its laminar transition) on the smaller dead volume, 1/s; none in
        the engine plugin, whose exponential step is stable at any step."""
        if native:
            return {}
        law = self.law
        slope = max(law.gain_a, law.gain_b, law.out_a, law.out_b) / math.sqrt(law.laminar)
        return {"chamber filling": self.params.bulk_modulus / self._smallest_volume() * slope}

    # --- in MuJoCo --------------------------------------------------------------------------------
    def mujoco_plugin(self) -> EnginePlugin:
        """The engine plugin ``maniplab.cylinder`` with its three states and every parameter."""
        return EnginePlugin(MUJOCO_PLUGIN, len(self.states), chambers.plugin_config(self.params))

    def configure_mjcf(self, act: mujoco.MjsActuator) -> None:
        """The valve current's range ±current_limit."""
        set_command_range(act, self.command_limit)

    def mount(self, act: mujoco.MjsActuator, mount: Mount) -> None:
        """Sites at the pins and a spatial tendon between them (drawn as thick as the bore),
        which the actuator acts on. With rod friction the tendon carries its viscous part as
        ``damping`` (N·s/m along the rod: MuJoCo applies Fv r(q)² q̇ in every stage, in the plant
        too) and its Coulomb level as ``frictionloss`` (plain MuJoCo's stand-in, which the plant
        turns off and replaces with its stick/slip automaton)."""
        name, pins = self.joint.name, self.params.cylinder.pins
        base = mount.parent.add_site(name=name + TENDON_SUFFIX + "_base",
                                     pos=list(mount.origin + np.asarray(pins.parent)))
        rod = mount.child.add_site(name=name + TENDON_SUFFIX + "_rod", pos=list(pins.child))
        for site in (base, rod):
            site.size = [0.25 * self.params.cylinder.bore, 0.0, 0.0]
            site.rgba = list(COLOUR)
        tendon = mount.spec.add_tendon(name=name + TENDON_SUFFIX)
        tendon.width = 0.5 * self.params.cylinder.bore
        tendon.rgba = list(COLOUR)
        tendon.wrap_site(base.name)
        tendon.wrap_site(rod.name)
        friction = self.params.cylinder.friction
        if friction is not None:  # the rod's: MuJoCo maps the tendon's forces through r(q)
            tendon.damping = [friction.viscous, 0.0, 0.0]
            tendon.frictionloss = friction.coulomb
        act.trntype = mujoco.mjtTrn.mjTRN_TENDON
        act.target = tendon.name

    def describe(self) -> str:
        """``cylinder ⌀100/56 x 535 mm, r -0.30..-0.21 m/rad, Ps 8 MPa`` (r signed as
        :meth:`details` gives it: negative where extending the rod turns the joint backwards)."""
        p, c = self.params, self.params.cylinder
        lo, hi = self.joint.limits or (0.0, 0.0)
        arms = self.geometry.arm(np.linspace(lo, hi, 33))  # signed, as details() prints it
        unit = " (ratio)" if self.joint.prismatic else " m/rad"
        relief = f" relief {p.relief_pressure / 1e6:g} MPa" if p.relief_pressure else ""
        return (f"cylinder ⌀{c.bore * 1e3:g}/{c.rod * 1e3:g} x {c.stroke * 1e3:g} mm, "
                f"r {arms.min():.3g}..{arms.max():.3g}{unit}, "
                f"{p.valve.nominal_flow * 6e4:.3g} L/min valve, "
                f"Ps {p.supply_pressure / 1e6:g} MPa{relief}")

    def details(self) -> list[str]:
        """The cylinder's length and moment arm over the limits, the range its stroke allows,
        its areas and the valve's edge coefficients."""
        c, law, j = self.params.cylinder, self.law, self.joint
        lo, hi = j.limits or (0.0, 0.0)
        q = np.linspace(lo, hi, 65)
        s, r = self.geometry.length(q), self.geometry.arm(q)
        allowed = self.geometry.span(c.min_length, c.max_length, 0.5 * (lo + hi))
        unit = self.geometry.unit
        arm_unit = " (ratio)" if j.prismatic else " m/rad"
        where = (f"{j.name}: cylinder s {s.min():.4g}..{s.max():.4g} m over the limits (its stroke "
                 f"allows [{allowed[0]:.4g}, {allowed[1]:.4g}] {unit}), r(q) {r.min():.4g}.."
                 f"{r.max():.4g}{arm_unit}")
        sizes = (f"{' ' * len(j.name)}  A_A {c.cap_area * 1e4:.4g} cm², A_B "
                 f"{c.rod_area * 1e4:.4g} cm², valve edges K_A {law.gain_a:.4g}, K_B "
                 f"{law.gain_b:.4g}, K_AT {law.out_a:.4g}, K_BT {law.out_b:.4g} m³/(s·√Pa)")
        v = self.params.valve
        if v.deadband > 0.0 or v.characteristic is not None or v.command_unit != "A":
            shape = (f"deadband ±{v.deadband:g}" if v.characteristic is None else
                     f"{len(v.characteristic)}-point characteristic")
            sizes += (f"; command in {v.command_unit} from neutral, full at ±{v.current_limit:g}, "
                      f"{shape}")
        margin = self.params.valve.compensator_margin
        if margin is not None:
            sizes += (f"; compensated at {margin / 1e5:.4g} bar: at most "
                      f"{law.gain_a * math.sqrt(margin) * 6e4:.4g} L/min into A, "
                      f"{law.gain_b * math.sqrt(margin) * 6e4:.4g} L/min into B")
        if v.flow_sharing:
            sizes += "; flow sharing (post-compensated): its edges see the pump less the highest load"
        return [where, sizes, *self._hose_lines(), *self._cushion_lines(), *self._holding_lines(),
                *self._rod_friction_lines(np.abs(r))]

    def _rod_friction_lines(self, arms: np.ndarray) -> list[str]:
        """The rod friction in newtons and on the joint over the limits (|r| ``arms``), for
        :meth:`details` (none without rod friction)."""
        f = self.params.cylinder.friction
        if f is None:
            return []
        force, damping = ("N", "N·s/m") if self.joint.prismatic else ("N·m", "N·m·s/rad")
        lo, hi = float(arms.min()), float(arms.max())
        line = (f"{' ' * len(self.joint.name)}  rod friction: Coulomb {f.coulomb:g} N, static "
                f"{f.static:g} N, Stribeck {f.stribeck_velocity:g} m/s, viscous {f.viscous:g} "
                f"N·s/m, stick {f.stick_velocity:g} m/s; on the joint through |r(q)|: Coulomb "
                f"{f.coulomb * lo:.4g}..{f.coulomb * hi:.4g} {force}, break-away "
                f"{f.breakaway * lo:.4g}..{f.breakaway * hi:.4g} {force}, viscous "
                f"{f.viscous * lo**2:.4g}..{f.viscous * hi**2:.4g} {damping}")
        return [line]

    @classmethod
    def drive(cls, actuators: Sequence[ActuatorPlugin], joints: Sequence[int], *, dt: float,
              settings: ControlSpec) -> ForceDrive:
        """The load-pressure loop with the valve inversion (:class:`.pinned_drive.ChamberDrive`)."""
        from maniplab.actuators.hydraulic.pinned_drive import ChamberDrive

        return ChamberDrive(actuators, joints, dt=dt, settings=settings)
