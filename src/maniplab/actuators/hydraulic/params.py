"""Parameters of the hydraulic actuators, the ``actuator:`` section of a joint: the lumped
cylinder of the paper's eq. (4), and a two-chamber cylinder pinned across its joint."""

from __future__ import annotations

import itertools
import math
from typing import Annotated, ClassVar, Literal

import numpy as np
from pydantic import BeforeValidator, ValidationInfo, field_validator

from maniplab.actuators.hydraulic.hose import P_ATM, Hoses
from maniplab.actuators.hydraulic.valve import relief_gain
from maniplab.schema import NonNegative, Positive, Vec3, validated
from maniplab.schema.fields import Real, sequence


@validated
class HydraulicActuator:
    """A valve-controlled hydraulic cylinder (eq. 4 of the paper), one per joint.

    Attributes:
        type: "hydraulic".
        area: piston area A, m² (prismatic joint), or displacement per radian, m³/rad (rotational).
        volume: effective oil volume V, m³.
        bulk_modulus: oil bulk modulus E, Pa.
        leakage: leakage coefficient Le, m³/(s·Pa).
        valve_gain: flow gain C, m³/(s·A): flow at current i_v with no load is i_v C.
        valve_tau: valve time constant τ, s.
        supply_pressure: Ps, Pa.
        current_limit: largest |i_v|, A.
        valve_law: "orifice" (the default: the flow follows the pressure drop across the
            metering edges, so a lowered load is braked) or "paper" (eq. 4 literally: the flow
            falls with |ΔP| whichever way the load acts); see :mod:`.valve`.
        relief_pressure: setting of a relief valve across the cylinder, Pa, or None for none.
    """

    EXAMPLE: ClassVar[str] = "type: hydraulic, area: 0.001, volume: 0.002, ..."

    type: Literal["hydraulic"]
    area: Positive
    volume: Positive
    valve_gain: Positive
    supply_pressure: Positive
    bulk_modulus: Positive = 1.4e9
    leakage: NonNegative = 0.0
    valve_tau: Positive = 0.01
    current_limit: Positive = 1.0
    valve_law: Literal["orifice", "paper"] = "orifice"
    relief_pressure: Positive | None = None

    @property
    def orifice(self) -> bool:
        """True for the orifice law."""
        return self.valve_law == "orifice"

    @property
    def relief_gain(self) -> float:
        """K_r of the relief valve, m³/(s·Pa) (0 without one)."""
        if self.relief_pressure is None:
            return 0.0
        return relief_gain(self.valve_gain, self.current_limit, self.relief_pressure)


@validated
class Pins:
    """Where a cylinder is pinned, from its joint's origin in base axes at q = 0, m.

    Attributes:
        parent: on the body before the joint, (3,).
        child: on the body the joint moves, (3,).
    """

    EXAMPLE: ClassVar[str] = "parent: [0.3, 0, -0.2], child: [0.9, 0, 0.1]"

    parent: Vec3
    child: Vec3


@validated
class RodFriction:
    """A cylinder's seal friction on its rod, in newtons, as datasheets and papers give it.

    It acts on the joint through the cylinder's moment arm r(q) = ds/dq: a rod force F is a
    joint force F r(q), so its Coulomb and static levels on the joint are Fc |r(q)| and
    Fs |r(q)|, its Stribeck and stick velocities on the joint vs/|r(q)| and (stick velocity)/|r|,
    and its viscous coefficient Fv r(q)², all changing with the pose. It uses the hybrid
    stick/slip automaton whatever the joint's own ``friction`` model (none or hybrid: the
    joint's friction adds to it; LuGre with rod Coulomb or static friction is refused).

    Attributes:
        coulomb: Coulomb friction Fc, N.
        static: stiction above Coulomb Fs, N: the rod breaks away at Fc + Fs.
        stribeck_velocity: Stribeck velocity vs of the rod, m/s.
        viscous: viscous coefficient Fv, N·s/m.
        stick_velocity: a rod decelerating below this speed sticks, m/s.
    """

    EXAMPLE: ClassVar[str] = "coulomb: 800.0, static: 400.0, viscous: 5000.0"

    coulomb: NonNegative = 0.0
    static: NonNegative = 0.0
    stribeck_velocity: Positive = 0.01
    viscous: NonNegative = 0.0
    stick_velocity: Positive = 1e-3

    @property
    def breakaway(self) -> float:
        """Fc + Fs, N: the largest rod force stiction holds."""
        return self.coulomb + self.static

    @property
    def sticks(self) -> bool:
        """Whether it has stick/slip friction (Fc + Fs > 0), not only a viscous part."""
        return self.breakaway > 0.0


@validated
class Cushions:
    """A cylinder's end cushions, the same at both ends: over the last ``length`` of the stroke a
    spear enters the outlet and the leaving oil passes a throttle, which brakes the piston.

    Attributes:
        length: the cushion's length, m (a datasheet's "cushion length", 20 to 60 mm).
        nominal_flow: the throttle's flow at the very end of the stroke and
            ``nominal_pressure_drop``, m³/s (the cushion needle's setting).
        nominal_pressure_drop: Pa.
    """

    EXAMPLE: ClassVar[str] = "length: 0.03, nominal_flow: 5.0e-5, nominal_pressure_drop: 1.0e6"

    length: Positive
    nominal_flow: Positive
    nominal_pressure_drop: Positive = 1.0e6

    @property
    def gain(self) -> float:
        """K of the throttle at the very end, m³/(s·√Pa)."""
        return self.nominal_flow / self.nominal_pressure_drop ** 0.5


@validated
class Cylinder:
    """A cylinder's dimensions.

    Attributes:
        pins: where it is pinned (:class:`Pins`).
        bore: piston diameter, m.
        rod: rod diameter, m (smaller than the bore).
        min_length: pin to pin, fully retracted, m.
        stroke: m.
        dead_volumes: oil that is not swept, cap side and rod side, m³: the cylinder's own, and
            the hoses' unless they are given in ``hoses``.
        double_rod: a rod on both sides (both areas the annulus).
        hoses: the hoses to the two chambers (:class:`~.hose.Hoses`), each adding its equivalent
            dead volume (:meth:`dead_volumes_with_hoses`); None: none (or counted in
            ``dead_volumes``).
        friction: the seals' friction on the rod, in newtons (:class:`RodFriction`), mapped
            onto the joint through r(q); None: none (the joint's own ``friction`` only).
    """

    EXAMPLE: ClassVar[str] = ("pins: {parent: [...], child: [...]}, bore: 0.1, rod: 0.056, "
                              "min_length: 1.2, stroke: 0.535, dead_volumes: [2e-4, 2e-4]")

    pins: Pins
    bore: Positive
    rod: Positive
    min_length: Positive
    stroke: Positive
    dead_volumes: Annotated[tuple[Positive, Positive], BeforeValidator(sequence)]
    double_rod: bool = False
    hoses: Hoses | None = None
    cushions: Cushions | None = None
    friction: RodFriction | None = None

    @field_validator("rod")
    @classmethod
    def _thinner_than_bore(cls, rod: float, info: ValidationInfo) -> float:
        bore = info.data.get("bore")
        if bore is not None and not rod < bore:
            raise ValueError(f"rod {rod:g} m is not thinner than the bore {bore:g} m")
        return rod

    @field_validator("cushions")
    @classmethod
    def _cushions_fit(cls, cushions: Cushions | None, info: ValidationInfo) -> Cushions | None:
        stroke = info.data.get("stroke")
        if cushions is not None and stroke is not None and not 2.0 * cushions.length <= stroke:
            raise ValueError(f"cushions.length {cushions.length:g} m: a cushion at each end "
                             f"does not fit in the stroke {stroke:g} m (at most half of it)")
        return cushions

    @property
    def cap_area(self) -> float:
        """A_A, m²: the bore's (the annulus for a double rod)."""
        return self.rod_area if self.double_rod else math.pi / 4.0 * self.bore**2

    @property
    def rod_area(self) -> float:
        """A_B, m²: the annulus."""
        return math.pi / 4.0 * (self.bore**2 - self.rod**2)

    @property
    def max_length(self) -> float:
        """Pin to pin fully extended, m."""
        return self.min_length + self.stroke

    def dead_volumes_with_hoses(self, oil: float, pressure: float) -> tuple[float, float]:
        """The chambers' dead volumes with each hose's equivalent volume V_h β_oil/β_e added
        (:mod:`.hose`), cap side and rod side, m³, for oil of bulk modulus ``oil`` (Pa) and the
        hoses' air taken at the absolute ``pressure`` (Pa)."""
        if self.hoses is None:
            return self.dead_volumes
        a, b = self.hoses.equivalent_volumes(oil, pressure)
        return self.dead_volumes[0] + a, self.dead_volumes[1] + b


@validated
class Valve:
    """A proportional directional valve with four metering edges (P→A, B→T, P→B, A→T).

    Attributes:
        nominal_flow: flow through the A edges at full opening and the nominal drop, m³/s.
        nominal_pressure_drop: at which nominal_flow is rated, Pa: across the whole valve (two
            edges in series, as catalogues rate them) unless ``per_edge``.
        per_edge: the nominal drop is across one edge.
        flow_ratio: the B port's flow over the A port's at the same opening and drop (a
            datasheet's "62 L/min at A, 72 L/min at B": 72/62).
        meter_out_ratio: the meter-out edges' (A→T, B→T) flow over the meter-in edges' of the
            same port (P→A, P→B) at the same opening and drop.
        compensator_margin: a local pressure compensator's margin, Pa: the drop it holds across
            the meter-in edge, so the flow follows the opening and not the load while the supply
            exceeds the chamber's pressure by it (below, the edge sees the whole drop, the
            orifice law); None: no compensator.
        flow_sharing: the section is post-compensated (flow sharing, LUDV): its compensator sits
            after the meter-in edge and is set by the highest load on the shared pump, so every
            such section's edge sees the pump's pressure less that load (a load-sensing pump's
            margin) and, when the pump runs short, every section slows in the same proportion;
            excludes ``compensator_margin`` (the pre-compensated kind, whose lightest loads keep
            their flow when the pump runs short).
        tau: the spool's time constant, s.
        current_limit: the command that opens it fully, measured from neutral: A, or the
            unit of ``command_unit``.
        command_unit: the unit of the valve's command as its datasheet gives it: "A", "mA",
            "V" or "%"; the command is measured from the datasheet's neutral (a 0.25-0.75 Us
            signal with Us = 24 V: "V", current_limit 6.0, neutral at 12 V).
        deadband: the command band around neutral where the spool stays shut (its overlap), in
            the command's unit; beyond it the opening rises linearly to full at current_limit.
        characteristic: the opening at each of 2 to 16 commands instead, [[command, opening],
            ...]: commands rising within ±current_limit, openings within -1..1 not falling,
            0 at the neutral command; interpolated, held beyond its ends.
    """

    EXAMPLE: ClassVar[str] = "nominal_flow: 9.0e-4, nominal_pressure_drop: 35.0e5"

    nominal_flow: Positive
    nominal_pressure_drop: Positive
    per_edge: bool = False
    flow_ratio: Positive = 1.0
    meter_out_ratio: Positive = 1.0
    compensator_margin: Positive | None = None
    flow_sharing: bool = False
    tau: Positive = 0.01
    current_limit: Positive = 1.0
    command_unit: Literal["A", "mA", "V", "%"] = "A"
    deadband: NonNegative = 0.0
    characteristic: Annotated[tuple[tuple[Real, Real], ...], BeforeValidator(sequence)] | None = None

    def __post_init__(self) -> None:
        if self.flow_sharing and self.compensator_margin is not None:
            raise ValueError("flow_sharing (a post-compensated section) and compensator_margin (a "
                             "pre-compensated one) exclude each other: give one")
        if not self.deadband < self.current_limit:
            raise ValueError(f"deadband {self.deadband:g} is not below current_limit "
                             f"{self.current_limit:g}")
        points = self.characteristic
        if points is None:
            return
        if self.deadband > 0.0:
            raise ValueError("give a deadband or a characteristic, not both (the "
                             "characteristic's points include the deadband)")
        if not 2 <= len(points) <= 16:
            raise ValueError(f"characteristic has {len(points)} points; expected 2 to 16")
        u = [c for c, _ in points]
        x = [o for _, o in points]
        if any(b <= a for a, b in itertools.pairwise(u)) or any(
                b < a for a, b in itertools.pairwise(x)):
            raise ValueError("characteristic: commands must rise and openings must not fall")
        if max(abs(v) for v in u) > self.current_limit or max(abs(v) for v in x) > 1.0:
            raise ValueError(f"characteristic: commands within ±current_limit "
                             f"({self.current_limit:g}) and openings within -1..1")
        if not u[0] <= 0.0 <= u[-1] or abs(float(np.interp(0.0, u, x))) > 1e-12:
            raise ValueError("characteristic: the spool must be shut (opening 0) at the "
                             "neutral command 0")

    @property
    def edge_drop(self) -> float:
        """The nominal drop across one edge, Pa."""
        return self.nominal_pressure_drop if self.per_edge else 0.5 * self.nominal_pressure_drop

    @property
    def gain_a(self) -> float:
        """K_A: an A edge's flow at full opening per √Pa of drop, m³/(s·√Pa)."""
        return self.nominal_flow / math.sqrt(self.edge_drop)

    @property
    def gain_b(self) -> float:
        """K_B = flow_ratio K_A: the P→B edge's."""
        return self.flow_ratio * self.gain_a

    @property
    def out_a(self) -> float:
        """K_AT = meter_out_ratio K_A: the A→T edge's, m³/(s·√Pa)."""
        return self.meter_out_ratio * self.gain_a

    @property
    def out_b(self) -> float:
        """K_BT = meter_out_ratio K_B: the B→T edge's, m³/(s·√Pa)."""
        return self.meter_out_ratio * self.gain_b


@validated
class HoldingValve:
    """A load-holding valve on a cylinder's chamber, mounted on the cylinder between the chamber
    and its hose: a counterbalance (overcentre) valve, or a pilot-operated check valve. Either
    holds the chamber's oil while its pilot, the other line's pressure, stays low, lets the
    valve's oil into the chamber freely through its check, and lets it out only when opened:

    - a counterbalance valve opens where the chamber's pressure plus the pilot ratio times the
      pilot pressure exceeds its setting (gauge pressures), fully over ``band``: it meters a
      lowering load, and it relieves the chamber at its setting;
    - a pilot-operated check opens where the pilot pressure exceeds the chamber's pressure over
      the pilot ratio plus ``setting`` (its spring), fully over ``band``: it holds or lets go.

    Attributes:
        type: "counterbalance" or "pilot_check".
        setting: a counterbalance valve's crack (setting) pressure, Pa (about 1.3 times the
            highest load-induced pressure); a pilot-operated check's spring as a pilot pressure,
            Pa (default 0).
        pilot_ratio: the pilot piston's area over the seat's (3 to 10 for a counterbalance valve,
            3 to 5 for a pilot-operated check).
        nominal_flow: the flow fully open at ``nominal_pressure_drop``, m³/s.
        nominal_pressure_drop: Pa.
        band: the pressure from cracking to fully open, Pa.
        leakage: the seat's leakage while closed, m³/(s·Pa) (0: drop-tight, as poppet valves are
            rated).
    """

    EXAMPLE: ClassVar[str] = ("type: counterbalance, setting: 25.0e6, pilot_ratio: 4.0, "
                              "nominal_flow: 1.5e-3")

    type: Literal["counterbalance", "pilot_check"]
    pilot_ratio: Positive
    nominal_flow: Positive
    setting: NonNegative | None = None
    nominal_pressure_drop: Positive = 1.0e6
    band: Positive = 2.0e6
    leakage: NonNegative = 0.0

    def __post_init__(self) -> None:
        if self.type == "counterbalance" and not (self.setting or 0.0) > 0.0:
            raise ValueError("a counterbalance valve needs its setting, Pa (the crack pressure, "
                             "about 1.3 times the highest load-induced pressure)")

    @property
    def gain(self) -> float:
        """K fully open, m³/(s·√Pa)."""
        return self.nominal_flow / self.nominal_pressure_drop ** 0.5

    @property
    def crack(self) -> float:
        """The setting, Pa (0 when not given)."""
        return self.setting or 0.0


@validated
class Holding:
    """The load-holding valves of a cylinder's two chambers.

    Attributes:
        a: on the cap side (:class:`HoldingValve`), or None.
        b: on the rod side, or None.
    """

    EXAMPLE: ClassVar[str] = ("a: {type: counterbalance, setting: 25.0e6, pilot_ratio: 4.0, "
                              "nominal_flow: 1.5e-3}")

    a: HoldingValve | None = None
    b: HoldingValve | None = None


@validated
class PinnedHydraulicActuator:
    """A two-chamber cylinder pinned across its joint, fed by a four-edge valve.

    Attributes:
        type: "hydraulic" (a ``cylinder`` section makes it this model, not the lumped one).
        cylinder: its dimensions and pins (:class:`Cylinder`).
        valve: the valve that feeds it (:class:`Valve`).
        supply_pressure: Ps, Pa.
        tank_pressure: Pt, Pa; anti-cavitation valves keep each chamber at least at it.
        relief_pressure: the setting of a relief valve on each chamber, Pa, or None for none.
        bulk_modulus: E of the oil (and hoses), Pa.
        leakage: across the piston, m³/(s·Pa).
        holding: load-holding valves on the chambers (:class:`Holding`), or None.
    """

    EXAMPLE: ClassVar[str] = ("type: hydraulic, cylinder: {...}, valve: {...}, "
                              "supply_pressure: 8.0e6")

    type: Literal["hydraulic"]
    cylinder: Cylinder
    valve: Valve
    supply_pressure: Positive
    tank_pressure: NonNegative = 0.0
    relief_pressure: Positive | None = None
    bulk_modulus: Positive = 1.4e9
    leakage: NonNegative = 0.0
    holding: Holding | None = None

    def __post_init__(self) -> None:
        if not self.supply_pressure > self.tank_pressure:
            raise ValueError(f"supply_pressure {self.supply_pressure:g} Pa is not above "
                             f"tank_pressure {self.tank_pressure:g} Pa")
        margin = self.valve.compensator_margin
        if margin is not None and not margin < self.supply_pressure - self.tank_pressure:
            raise ValueError(f"valve.compensator_margin {margin:g} Pa is not below the supply's "
                             f"drop to tank, {self.supply_pressure - self.tank_pressure:g} Pa: "
                             "it would never hold the flow")
        if self.relief_pressure is not None and not self.relief_pressure > self.tank_pressure:
            raise ValueError(f"relief_pressure {self.relief_pressure:g} Pa is not above "
                             f"tank_pressure {self.tank_pressure:g} Pa")

    @property
    def holding_pressure(self) -> float:
        """The highest chamber pressure: the relief's setting, else the supply's, Pa."""
        return self.relief_pressure or self.supply_pressure

    @property
    def chamber_dead_volumes(self) -> tuple[float, float]:
        """V_A0 and V_B0 of the chambers' equations, m³: the cylinder's ``dead_volumes`` plus
        each hose's equivalent volume V_h E/β_e, E the oil's ``bulk_modulus`` and β_e the hose's
        effective one with its air at the supply pressure (absolute: ``supply_pressure`` +
        :data:`~.hose.P_ATM`); see :mod:`.hose`."""
        return self.cylinder.dead_volumes_with_hoses(self.bulk_modulus,
                                                     self.supply_pressure + P_ATM)


def rod_friction(actuator: object) -> RodFriction | None:
    """The rod friction of a joint's actuator section (a pinned cylinder's
    ``cylinder.friction``), or None (none, or not a pinned cylinder)."""
    cylinder = getattr(actuator, "cylinder", None)
    return cylinder.friction if isinstance(cylinder, Cylinder) else None
