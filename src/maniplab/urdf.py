"""The arm as URDF: links, joints, limits, inertias at full precision, and an extension element.

The file describes the same rigid bodies as the analytic model (:class:`~maniplab.AnalyticModel`),
so that a URDF tool (Pinocchio, ROS, ...) computes the same M(q) and, with the spec's gravity, the
same G(q):

- a root link ``base_link`` (the base frame, no inertia);
- per spec joint ``<j>`` a link ``link_<j>`` (frame j after the joint's motion, as in the MJCF)
  whose ``<inertial>`` is the joint's body: ``mass`` (kg), ``origin xyz`` the centre of gravity
  (m, link frame) and the full inertia tensor about it (kg·m², link axes); a joint without a body
  gets a link without ``<inertial>`` (no mass);
- per spec joint a ``revolute`` (R with limits), ``continuous`` (R without) or ``prismatic`` (P)
  joint from the previous link to ``link_<j>``, at ``origin xyz`` = the previous body's offset
  ``length * direction`` (m; ``rpy`` 0: every frame keeps the base orientation), with ``axis`` the
  joint's base axis; ``<limit>`` has ``lower``/``upper`` (rad or m), ``effort`` (N·m or N) the
  largest force the actuator holds over the joint's range (``holding_range``) and ``velocity``
  (rad/s or m/s) its ``top_speed``; ``<dynamics>`` has the viscous coefficient as ``damping`` and
  the Coulomb level as ``friction`` (when the joint has a friction model);
- the payload as a link ``end_effector`` fixed to the last link at ``length_n * direction_n +
  end_effector.offset`` (m): its mass (kg) at ``end_effector.com`` from there, with
  ``end_effector.inertia`` about it (kg·m²; none by default: a point mass).

URDF requires finite numbers where the spec may have no bound: a prismatic joint without limits,
or an actuator without a force or speed bound, gets :data:`UNBOUNDED` (the largest double) there.

URDF has no gravity: the spec's gravity (m/s², base axes) is written in the extension, and a tool
that computes G(q) must be given it (Pinocchio: ``model.gravity.linear``).

maniplab's own parameters, which URDF has no element for, are in one extension element in the
namespace :data:`NAMESPACE` (prefix ``maniplab``), which urdfdom, Pinocchio and ROS ignore::

    <maniplab:model version="1" gravity="0.0 -9.81 0.0">
      <maniplab:joint name="q1">
        <maniplab:actuator type="hydraulic" area="0.0302" .../>
        <maniplab:friction model="hybrid" coulomb="3000.0" .../>
      </maniplab:joint>
      <maniplab:supply pressure="20000000.0" max_flow="0.001"/>   (only with a shared supply)
    </maniplab:model>

The actuator's attributes are its parameters as in the spec file (SI units), nested sections
joined with dots (``cylinder.pins.parent="-1.2 -1.2 0.0"``), lists as space-separated numbers,
booleans as ``true``/``false``; a parameter that is ``None`` (not set) is left out.
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from maniplab.actuators.base import CapabilityError
from maniplab.atomic import write_text
from maniplab.builtin import resolve_spec
from maniplab.errors import ManiplabError
from maniplab.friction import FrictionModel
from maniplab.schema import plain
from maniplab.spec import Joint, ManipulatorSpec, model_of
from maniplab.spec.actuator import actuator_dict

NAMESPACE = "urn:maniplab:urdf:1"
"""The XML namespace of maniplab's extension element (prefix ``maniplab``)."""

VERSION = "1"
"""The extension's version, the ``version`` attribute of ``<maniplab:model>``."""

UNBOUNDED = sys.float_info.max
"""What stands for "no bound" where URDF requires a finite number (the largest double)."""

BASE_LINK = "base_link"
"""The root link: the base frame."""

END_EFFECTOR = "end_effector"
"""The link holding the payload (fixed to the last link)."""

RANGE_SAMPLES = 201
"""Joint positions at which the actuator's holding range is evaluated for ``effort``."""

SpecLike = ManipulatorSpec | str | os.PathLike[str]


def link_name(joint_name: str) -> str:
    """Name of the URDF link moved by the spec joint ``joint_name`` ('q1' -> 'link_q1')."""
    return f"link_{joint_name}"


def to_urdf(spec: SpecLike) -> str:
    """URDF text of ``spec`` at full float precision (see the module docstring for the contents).

    Args:
        spec: a spec, a spec file or a built-in spec name.

    Returns:
        The URDF document: links with the spec's masses (kg), centres of gravity (m) and
        inertias about them (kg·m²), joints with origins (m), axes, limits (rad or m), effort
        (N·m or N) and velocity (rad/s or m/s), the payload as a fixed link, and the extension
        element with gravity (m/s²), actuator and friction parameters.

    Raises:
        SpecError: ``spec`` names no file or built-in, or the file is invalid.
        ManiplabError: an actuator's parameters cannot be written as XML attributes (the message
            names the joint and the field), or its plugin is not loaded.
    """
    spec = resolve_spec(spec)
    ET.register_namespace("maniplab", NAMESPACE)
    robot = ET.Element("robot", {"name": spec.name})
    ET.SubElement(robot, "link", {"name": BASE_LINK})
    parent, origin = BASE_LINK, np.zeros(3)
    for joint in spec.joints:
        child = link_name(joint.name)
        _add_link(robot, child, joint)
        _add_joint(robot, joint, parent, child, origin)
        parent, origin = child, _offset(joint)
    _add_end_effector(robot, spec, parent, origin)
    robot.append(_extension(spec))
    ET.indent(robot, space="  ")
    # ElementTree declares the namespace on the root only when an element uses it: it does.
    text = ET.tostring(robot, encoding="unicode")
    return ('<?xml version="1.0"?>\n'
            "<!-- URDF written by maniplab (maniplab.urdf). URDF has no gravity: the spec's is "
            "the gravity attribute of maniplab:model, in m/s^2, base axes. The maniplab:model "
            "element holds the actuator and friction parameters; URDF parsers ignore it. -->\n"
            + text + "\n")


def write_urdf(spec: SpecLike, path: str | os.PathLike[str]) -> Path:
    """Write ``to_urdf(spec)`` to ``path`` atomically (temporary file, then rename).

    Args:
        spec: a spec, a spec file or a built-in spec name.
        path: the URDF file to write; missing folders are created.

    Returns:
        The path written.
    """
    target = Path(path)
    write_text(target, to_urdf(spec))
    return target


# --- links and joints ----------------------------------------------------------------------------

def _num(value: float) -> str:
    """A float at full precision (the shortest text that reads back to the same double)."""
    return repr(float(value))


def _vec(values: Iterable[float]) -> str:
    return " ".join(_num(v) for v in values)


def _offset(joint: Joint) -> np.ndarray:
    """``length * direction`` of the joint's body, m, (3,): computed as the analytic model does."""
    body = joint.body
    return np.zeros(3) if body is None else body.length * np.asarray(body.direction, dtype=float)


def _inertial(link: ET.Element, mass: float, com: Iterable[float],
              inertia: tuple[float, ...]) -> None:
    """``<inertial>``: mass (kg), COG (m) and [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] about it (kg·m²)."""
    ixx, iyy, izz, ixy, ixz, iyz = inertia
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "origin", {"xyz": _vec(com), "rpy": "0.0 0.0 0.0"})
    ET.SubElement(inertial, "mass", {"value": _num(mass)})
    ET.SubElement(inertial, "inertia", {
        "ixx": _num(ixx), "ixy": _num(ixy), "ixz": _num(ixz),
        "iyy": _num(iyy), "iyz": _num(iyz), "izz": _num(izz)})


def _add_link(robot: ET.Element, name: str, joint: Joint) -> None:
    link = ET.SubElement(robot, "link", {"name": name})
    body = joint.body
    if body is not None:
        assert body.com is not None and body.inertia is not None  # Body fills in their defaults
        _inertial(link, body.mass, body.com, body.inertia)


def _add_joint(robot: ET.Element, joint: Joint, parent: str, child: str,
               origin: np.ndarray) -> None:
    if joint.prismatic:
        kind = "prismatic"
    else:
        kind = "revolute" if joint.limits is not None else "continuous"
    element = ET.SubElement(robot, "joint", {"name": joint.name, "type": kind})
    ET.SubElement(element, "parent", {"link": parent})
    ET.SubElement(element, "child", {"link": child})
    ET.SubElement(element, "origin", {"xyz": _vec(origin), "rpy": "0.0 0.0 0.0"})
    ET.SubElement(element, "axis", {"xyz": _vec(joint.axis_vector)})
    effort, velocity = actuator_bounds(joint)
    limit: dict[str, str] = {}
    if joint.limits is not None:
        limit = {"lower": _num(joint.limits[0]), "upper": _num(joint.limits[1])}
    elif joint.prismatic:  # URDF reads absent bounds as 0: a locked joint
        limit = {"lower": _num(-UNBOUNDED), "upper": _num(UNBOUNDED)}
    if kind != "continuous" or math.isfinite(effort) or math.isfinite(velocity):
        limit |= {"effort": _num(_finite(effort)), "velocity": _num(_finite(velocity))}
        ET.SubElement(element, "limit", limit)
    f = joint.friction
    if f.model is not FrictionModel.none:
        ET.SubElement(element, "dynamics", {"damping": _num(f.damping),
                                            "friction": _num(f.coulomb)})


def _finite(value: float) -> float:
    return value if math.isfinite(value) else UNBOUNDED


def actuator_bounds(joint: Joint) -> tuple[float, float]:
    """The ``effort`` and ``velocity`` of a joint's URDF limit, from its actuator's capabilities.

    Args:
        joint: the spec joint.

    Returns:
        (effort, velocity): the largest |force| the actuator holds the joint against
        (``holding_range``) over its range (sampled at :data:`RANGE_SAMPLES` positions; at q = 0
        for a joint without limits), N·m or N; and its ``top_speed``, rad/s or m/s. Either is
        inf when the actuator declares no bound.
    """
    model = model_of(joint)
    if joint.limits is None:
        positions = np.zeros(1)
    else:
        positions = np.linspace(joint.limits[0], joint.limits[1], RANGE_SAMPLES)
    try:
        effort = max(max(abs(low), abs(high))
                     for low, high in (model.holding_range(float(q)) for q in positions))
    except CapabilityError:
        effort = math.inf
    return float(effort), float(model.top_speed)


def _add_end_effector(robot: ET.Element, spec: ManipulatorSpec, parent: str,
                      origin: np.ndarray) -> None:
    """The payload: a fixed link at the last body's offset plus ``end_effector.offset``, its
    mass at ``end_effector.com`` from there, with ``end_effector.inertia`` about it."""
    link = ET.SubElement(robot, "link", {"name": END_EFFECTOR})
    ee = spec.end_effector
    _inertial(link, ee.mass, ee.com, ee.inertia)
    at = [float(e) + float(o) for e, o in zip(spec.end_effector.offset, origin)]
    element = ET.SubElement(robot, "joint", {"name": _fixed_joint_name(spec), "type": "fixed"})
    ET.SubElement(element, "parent", {"link": parent})
    ET.SubElement(element, "child", {"link": END_EFFECTOR})
    ET.SubElement(element, "origin", {"xyz": _vec(at), "rpy": "0.0 0.0 0.0"})


def _fixed_joint_name(spec: ManipulatorSpec) -> str:
    """``end_effector_fixed``, with ``_`` appended while a spec joint has the name."""
    name = f"{END_EFFECTOR}_fixed"
    while name in spec.joint_names:
        name += "_"
    return name


# --- the extension -------------------------------------------------------------------------------

def _tag(name: str) -> str:
    return f"{{{NAMESPACE}}}{name}"


def _extension(spec: ManipulatorSpec) -> ET.Element:
    model = ET.Element(_tag("model"), {"version": VERSION, "gravity": _vec(spec.gravity)})
    origin = f"{Path(spec.source).name}: " if spec.source else ""
    for joint in spec.joints:
        where = f"{origin}joint {joint.name}, "
        element = ET.SubElement(model, _tag("joint"), {"name": joint.name})
        ET.SubElement(element, _tag("actuator"),
                      _attributes(actuator_dict(joint.actuator), where + "actuator"))
        friction = plain(dataclasses.asdict(joint.friction))
        ET.SubElement(element, _tag("friction"), _attributes(friction, where + "friction"))
    if spec.supply is not None:
        supply = plain(dataclasses.asdict(spec.supply))
        ET.SubElement(model, _tag("supply"), _attributes(supply, origin + "supply"))
    return model


def _attributes(data: dict[str, Any], where: str) -> dict[str, str]:
    """Plain spec data as XML attributes: nested keys joined with '.', lists space-separated.
    ``where`` names the section for messages ("arm.yaml: joint q1, actuator")."""
    out: dict[str, str] = {}
    for key, value in data.items():
        field = f"{where}.{key}"
        if isinstance(value, dict):
            nested = _attributes(value, field)
            out |= {f"{key}.{k}": v for k, v in nested.items()}
        elif value is not None:
            out[str(key)] = _text(value, field)
    return out


def _text(value: Any, where: str) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str) and value.isprintable():
        return value
    if isinstance(value, (list, tuple)) and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return " ".join(repr(v) for v in value)
    raise ManiplabError(
        f"{where}: {type(value).__name__} {value!r} cannot be written into the URDF's maniplab "
        "extension; expected a number, one line of text, a boolean, a list of numbers or a "
        "mapping of these")
