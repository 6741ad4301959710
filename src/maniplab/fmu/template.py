"""The FMU's MuJoCo model: the plant's MJCF with its parameters as ``${name}`` tokens.

The FMU compiles the arm when its initialisation ends, after the importing tool has set the
parameters, so the model travels as text (``resources/model.xml``): the plant's model exactly as
:func:`~maniplab.sim.plant_model.build_plant_model` compiles it (the spec's MJCF at full
precision, the plant's time step, integrator and disabled features), in which each parameter's
value is a token the FMU replaces with the value (``%.17g``, exact for a double):

- ``payload``: the end-effector body's mass, kg (the spec's ``end_effector.mass``); its centre
  of gravity and inertia (``end_effector.com``, ``end_effector.inertia``) stay the spec's, so a
  payload parameter far from the spec's mass describes a body of another density;
- ``viscous.<joint>``: the joint's damping (``joints.<joint>.friction.viscous``);
- ``leakage.<joint>``, ``supply_pressure.<joint>``: the cylinder plugin instance's config
  (``joints.<joint>.actuator.leakage``, ``...supply_pressure``);
- ``supply_pressure``: with a shared pump (the spec's ``supply:``), the setting every pinned
  cylinder draws at (``supply.pressure`` and each pinned cylinder's ``supply_pressure``, which
  the spec requires equal), in place of their ``supply_pressure.<joint>``;
- ``${plugin}``: the prefix of the plugins' names (the FMU registers maniplab's plugins under
  names of its own).
"""

from __future__ import annotations

import dataclasses
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping

from maniplab.actuators.hydraulic.pinned import MUJOCO_PLUGIN as CYLINDER_PLUGIN
from maniplab.fmu.errors import FmuError
from maniplab.friction import FrictionModel
from maniplab.mjcf_gen.names import END_EFFECTOR
from maniplab.mjcf_gen.writer import serialize
from maniplab.sim.plant import Plant
from maniplab.sim.plant_model import DISABLED, plant_mjspec

PLUGIN_TOKEN = "${plugin}"
"""Where the plugins' prefix goes: ``plugin="${plugin}hydraulic"``."""

_TOKEN = re.compile(r"\$\{([^}]*)\}")


@dataclasses.dataclass(frozen=True)
class Parameter:
    """A parameter of the FMU: a value in the model's text.

    Attributes:
        name: its FMU name (``payload``, ``leakage.q2``...).
        default: the spec's value.
        unit: its FMI unit name.
        override: the spec's dotted path of the same value (``ml.simulate(overrides=...)``).
        positive: it must be > 0 (else >= 0).
        description: one line for modelDescription.xml.
        also: other dotted paths that hold the same value (the shared supply's pressure is also
            each pinned cylinder's ``supply_pressure``).
    """

    name: str
    default: float
    unit: str
    override: str
    positive: bool
    description: str
    also: tuple[str, ...] = ()

    def overrides(self, value: float) -> dict[str, float]:
        """The spec's overrides that give this parameter ``value``."""
        return {path: value for path in (self.override, *self.also)}


def model_template(plant: Plant) -> tuple[str, list[Parameter]]:
    """The plant's MJCF with its parameters as tokens, and the parameters.

    Raises:
        FmuError: the model has none of what a parameter needs (a maniplab bug, one line).
    """
    spec = plant.spec
    root = ET.fromstring(serialize(plant_mjspec(spec, dt=plant.dt / plant.substeps,
                                                integrator=plant.integrator)))
    option = root.find("option")
    if option is None:  # the plant always sets its time step
        raise FmuError(f"{spec.name}: the plant's MJCF has no <option>")
    ET.SubElement(option, "flag", {name: "disable" for name in DISABLED})
    params = _payload(root) + _viscous(root, plant) + _plugin_configs(root, plant)
    for plugin in root.iterfind("extension/plugin"):
        plugin.set("plugin", plugin.get("plugin", "").replace("maniplab.", PLUGIN_TOKEN, 1))
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="unicode") + "\n", params


def fill(template: str, values: Mapping[str, float], plugin_prefix: str = "maniplab.") -> str:
    """The template with its tokens replaced as the FMU replaces them (for tests and checks).

    Raises:
        FmuError: a token with no value.
    """
    def value(match: re.Match[str]) -> str:
        name = match.group(1)
        if name == "plugin":
            return plugin_prefix
        if name not in values:
            raise FmuError(f"the FMU's model has a token ${{{name}}} with no value")
        return f"{float(values[name]):.17g}"
    return _TOKEN.sub(value, template)


def _token(element: ET.Element, attribute: str, name: str) -> float:
    """Put token ``name`` in place of the first number of ``attribute``; its value (0 when the
    attribute is absent)."""
    words = element.get(attribute, "0").split()
    element.set(attribute, " ".join(["${" + name + "}", *words[1:]]))
    return float(words[0])


def _payload(root: ET.Element) -> list[Parameter]:
    inertial = root.find(f".//body[@name='{END_EFFECTOR}']/inertial")
    if inertial is None:
        return []
    mass = _token(inertial, "mass", "payload")
    return [Parameter("payload", mass, "kg", "end_effector.mass", False,
                      "payload: the end-effector body's mass (its centre of gravity and "
                      "inertia are the spec's)")]


def _viscous(root: ET.Element, plant: Plant) -> list[Parameter]:
    out = []
    for joint in plant.spec.joints:
        if joint.friction.model is FrictionModel.none:
            continue
        element = root.find(f".//joint[@name='{joint.name}']")
        if element is None:
            raise FmuError(f"{plant.spec.name}: joint {joint.name} is not in the plant's MJCF")
        value = _token(element, "damping", f"viscous.{joint.name}")
        unit = "N.s/m" if joint.prismatic else "N.m.s/rad"
        out.append(Parameter(f"viscous.{joint.name}", value, unit,
                             f"joints.{joint.name}.friction.viscous", False,
                             f"viscous friction coefficient of joint {joint.name}"))
    return out


_CONFIGS = {
    "leakage": ("m3/(s.Pa)", False, "leakage coefficient of joint {}'s cylinder"),
    "supply_pressure": ("Pa", True, "supply pressure of joint {}'s valve"),
}


def _plugin_configs(root: ET.Element, plant: Plant) -> list[Parameter]:
    """leakage.<joint> and supply_pressure.<joint> of each actuator with a plugin instance; with
    a shared supply, one ``supply_pressure`` for all the pinned cylinders."""
    instances = {i.get("name"): i for i in root.iterfind("extension/plugin/instance")}
    plugin_of = {i.get("name"): p.get("plugin") for p in root.iterfind("extension/plugin")
                 for i in p.iterfind("instance")}
    supply = plant.spec.supply
    pumped: list[str] = []
    out = []
    for actuator in root.iterfind("actuator/plugin"):
        joint, instance = actuator.get("name", ""), instances.get(actuator.get("instance"))
        shared = supply is not None and plugin_of.get(actuator.get("instance")) == CYLINDER_PLUGIN
        for config in () if instance is None else instance.iterfind("config"):
            key = config.get("key", "")
            if shared and key == "supply_pressure":
                _token(config, "value", "supply_pressure")
                pumped.append(joint)
            elif key in _CONFIGS:
                unit, positive, text = _CONFIGS[key]
                value = _token(config, "value", f"{key}.{joint}")
                out.append(Parameter(f"{key}.{joint}", value, unit,
                                     f"joints.{joint}.actuator.{key}", positive,
                                     text.format(joint)))
    if supply is not None and pumped:
        out.append(Parameter("supply_pressure", float(supply.pressure), "Pa", "supply.pressure",
                             True, "the shared pump's setting: the supply pressure of every "
                             "pinned cylinder", tuple(f"joints.{j}.actuator.supply_pressure"
                                                      for j in pumped)))
    return out
