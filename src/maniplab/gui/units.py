"""The page's engineering labels and units: every field of a spec named in words with its unit
("Supply pressure [MPa]"), shown in the unit the user chose (MPa or bar, L/min or m³/s, mm or m,
deg or rad) and stored in SI, as the spec holds it; enumerations as choices.

A field is known by its dotted path in a joint (``actuator.supply_pressure``,
``actuator.cylinder.bore``, ``friction.viscous``) or in the arm (``end_effector.mass``); what
depends on the joint's type (a torque or a force, rad or m) is resolved for the joint.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

CHOICES = {  # quantity -> the units offered, first the default: (shown, SI per shown unit)
    "pressure": (("MPa", 1e6), ("bar", 1e5)),
    "flow": (("L/min", 1e-3 / 60.0), ("m³/s", 1.0)),
    "length": (("m", 1.0), ("mm", 1e-3)),
    "angle": (("deg", math.pi / 180.0), ("rad", 1.0)),
}
"""The unit choices of the page."""

FIXED = {  # quantity -> (unit, SI per unit) that no choice changes
    "time": ("s", 1.0), "mass": ("kg", 1.0), "current": ("A", 1.0), "inertia": ("kg·m²", 1.0),
    "acceleration": ("m/s²", 1.0), "energy": ("J", 1.0), "ratio": ("–", 1.0),
    "leakage": ("m³/(s·Pa)", 1.0), "orifice": ("m³/(s·√Pa)", 1.0),
}

# name -> (label, quantity): quantity is one of CHOICES or FIXED, or one depending on the joint's
# type ("position", "speed", "force", "damping", "stiffness", "area", "volume", "flow_gain");
# None: not a number (a choice or a section)
FIELDS: dict[str, tuple[str, str | None]] = {
    # the arm
    "name": ("Name", None),
    "gravity": ("Gravity [x, y, z]", "acceleration"),
    "end_effector.mass": ("Payload mass", "mass"),
    "end_effector.offset": ("Payload offset from the last joint [x, y, z]", "length"),
    # a joint
    "type": ("Joint type", None),
    "axis": ("Axis", None),
    "limits": ("Limits [lower, upper]", "position"),
    "body.length": ("Body length", "length"),
    "body.direction": ("Body direction (unit vector)", "ratio"),
    "body.mass": ("Body mass", "mass"),
    "body.com": ("Body COG [x, y, z]", "length"),
    "body.inertia": ("Body inertia about the COG [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]", "inertia"),
    "stop_energy": ("End-stop energy", "energy"),
    # actuators
    "actuator.type": ("Actuator type", None),
    "actuator.area": ("Piston area", "area"),
    "actuator.volume": ("Oil volume", "volume"),
    "actuator.bulk_modulus": ("Oil bulk modulus", "pressure"),
    "actuator.leakage": ("Leakage", "leakage"),
    "actuator.valve_gain": ("Valve flow gain", "flow_gain"),
    "actuator.valve_tau": ("Valve time constant", "time"),
    "actuator.supply_pressure": ("Supply pressure", "pressure"),
    "actuator.tank_pressure": ("Tank pressure", "pressure"),
    "actuator.relief_pressure": ("Relief pressure (blank: no relief valve)", "pressure"),
    "actuator.current_limit": ("Current limit", "current"),
    "actuator.valve_law": ("Valve law", None),
    "actuator.limit": ("Actuator limit", "force"),
    "actuator.holding": ("Holding valves (YAML)", None),
    "actuator.cylinder.bore": ("Cylinder bore", "length"),
    "actuator.cylinder.rod": ("Cylinder rod", "length"),
    "actuator.cylinder.min_length": ("Cylinder length, retracted", "length"),
    "actuator.cylinder.stroke": ("Cylinder stroke", "length"),
    "actuator.cylinder.dead_volumes": ("Cylinder dead volumes [A, B]", "volume"),
    "actuator.cylinder.double_rod": ("Double rod", None),
    "actuator.cylinder.pins.parent": ("Pin on the parent [x, y, z]", "length"),
    "actuator.cylinder.pins.child": ("Pin on the child [x, y, z]", "length"),
    "actuator.cylinder.hoses": ("Hoses (YAML)", None),
    "actuator.cylinder.cushions": ("End cushions (YAML)", None),
    "actuator.cylinder.friction": ("Rod friction (YAML, N)", None),
    "actuator.valve.nominal_flow": ("Valve nominal flow", "flow"),
    "actuator.valve.nominal_pressure_drop": ("Valve nominal pressure drop", "pressure"),
    "actuator.valve.per_edge": ("Nominal drop per edge", None),
    "actuator.valve.flow_ratio": ("Valve flow ratio B/A", "ratio"),
    "actuator.valve.meter_out_ratio": ("Meter-out ratio", "ratio"),
    "actuator.valve.compensator_margin": ("Compensator margin (blank: none)", "pressure"),
    "actuator.valve.flow_sharing": ("Flow sharing", None),
    "actuator.valve.tau": ("Valve time constant", "time"),
    "actuator.valve.current_limit": ("Valve current limit", "current"),
    "actuator.valve.command_unit": ("Valve command unit", None),
    "actuator.valve.deadband": ("Valve deadband", "current"),
    "actuator.valve.characteristic": ("Valve characteristic (YAML)", None),
    # friction
    "friction.model": ("Friction model", None),
    "friction.coulomb": ("Coulomb friction", "force"),
    "friction.static": ("Static friction (above Coulomb)", "force"),
    "friction.viscous": ("Viscous friction", "damping"),
    "friction.stribeck_velocity": ("Stribeck velocity", "speed"),
    "friction.stick_velocity": ("Stick velocity", "speed"),
    "friction.sigma0": ("LuGre bristle stiffness σ0", "stiffness"),
    "friction.sigma1": ("LuGre bristle damping σ1", "damping"),
}

ENUMS = {  # a field's choices (a dropdown)
    "type": ("R", "P"),
    "axis": ("x", "y", "z"),
    "actuator.valve_law": ("orifice", "paper"),
    "friction.model": ("none", "hybrid", "lugre"),
    "actuator.cylinder.double_rod": ("false", "true"),
    "actuator.valve.per_edge": ("false", "true"),
    "actuator.valve.flow_sharing": ("false", "true"),
}


@dataclasses.dataclass(frozen=True)
class Units:
    """The units the page shows: one per quantity of :data:`CHOICES` (e.g. ``pressure="bar"``)."""

    pressure: str = "MPa"
    flow: str = "L/min"
    length: str = "m"
    angle: str = "deg"

    def scale(self, quantity: str) -> tuple[str, float]:
        """(unit, SI per unit) of a quantity of :data:`CHOICES`."""
        chosen = getattr(self, quantity)
        return chosen, dict(CHOICES[quantity])[chosen]

    def of(self, quantity: str | None, revolute: bool = True) -> tuple[str, float] | None:
        """(unit shown, SI per unit) of ``quantity`` for a joint (revolute or prismatic); None
        for a field that is not a number."""
        if quantity is None:
            return None
        if quantity in CHOICES:
            chosen = getattr(self, quantity)
            return chosen, dict(CHOICES[quantity])[chosen]
        if quantity in FIXED:
            return FIXED[quantity]
        length, metres = self.length, dict(CHOICES["length"])[self.length]
        angle, radians = self.angle, dict(CHOICES["angle"])[self.angle]
        flow, cubic = self.flow, dict(CHOICES["flow"])[self.flow]
        volume = ("L", 1e-3) if flow == "L/min" else ("m³", 1.0)
        joint = {
            "position": (angle, radians) if revolute else (length, metres),
            "speed": (f"{angle}/s", radians) if revolute else (f"{length}/s", metres),
            "force": ("N·m", 1.0) if revolute else ("N", 1.0),
            "damping": ("N·m·s/rad", 1.0) if revolute else ("N·s/m", 1.0),
            "stiffness": ("N·m/rad", 1.0) if revolute else ("N/m", 1.0),
            "area": ("m³/rad", 1.0) if revolute else ("m²", 1.0),
            "volume": volume,
            "flow_gain": (f"{flow}/A", cubic),
        }
        return joint[quantity]


def describe(path: str, units: Units, revolute: bool = True) -> tuple[str, tuple[str, float] | None]:
    """A field's label with its unit (``Supply pressure [MPa]``) and its unit (None: not a
    number); an unknown field is named by its path, its unit SI."""
    label, quantity = FIELDS.get(path, (_words(path), None))
    unit = units.of(quantity, revolute)
    if unit is None:
        return label, None
    return f"{label} [{unit[0]}]", unit


def shown(value: Any, unit: tuple[str, float] | None) -> Any:
    """An SI value (a number, a list of numbers, None) in the unit shown, rounded to 6
    significant digits (no float noise: 20 MPa, not 20.000000000000004)."""
    if unit is None or value is None or isinstance(value, bool):
        return value
    if isinstance(value, (int, float)):
        return _tidy(value / unit[1])
    if isinstance(value, (list, tuple)) and all(isinstance(x, (int, float)) and
                                                not isinstance(x, bool) for x in value):
        return [_tidy(x / unit[1]) for x in value]
    return value


def si(value: Any, unit: tuple[str, float] | None) -> Any:
    """A value typed in the unit shown, in SI (what is not a number passes unchanged)."""
    if unit is None or value is None or isinstance(value, bool) or unit[1] == 1.0:
        return value
    if isinstance(value, (int, float)):
        return value * unit[1]
    if isinstance(value, list) and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                       for x in value):
        return [x * unit[1] for x in value]
    return value


def number(x: float) -> str:
    """An engineering format: 4 significant digits, exponent only outside 1e-3..1e6."""
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    if 1e-3 <= abs(x) < 1e6:
        return f"{x:.4g}"
    return f"{x:.3e}".replace("e+0", "e").replace("e-0", "e-").replace("e+", "e")


def _tidy(x: float) -> float | int:
    value = float(f"{x:.6g}")
    return int(value) if value.is_integer() and abs(value) < 1e15 else value


def _words(path: str) -> str:
    last = path.split(".")[-1].replace("_", " ")
    return last[:1].upper() + last[1:]
