"""Dotted-path overrides of a spec: ``{"joints.q2.actuator.leakage": 1e-11}``.

Overrides are applied to the spec's plain dict and the result is validated again, so every rule
of a spec file also holds for an override. A path is checked against the spec's fields (not the
values present), so a field left at its default, or a section that is absent (a joint without a
body), can be set too; an actuator's fields are those of its type, a plugin's the fields of its
``Params`` (``{"joints.q1.actuator.gear_ratio": 50}`` on a geared motor plugin). A body's COG and
inertia that were left at their defaults follow the length, direction and mass they derive from.
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
from collections.abc import Mapping
from typing import Any

from maniplab import specfile
from maniplab.errors import SpecError
from maniplab.spec import (
    Body,
    CartesianGains,
    ControlSpec,
    EndEffector,
    Friction,
    HydraulicActuator,
    Joint,
    JointPIDGains,
    ManipulatorSpec,
    PressureGains,
    TorqueActuator,
)

_SECTIONS: dict[tuple[type, str], type] = {
    (ManipulatorSpec, "end_effector"): EndEffector,
    (Joint, "body"): Body,
    (Joint, "friction"): Friction,
    (ManipulatorSpec, "control"): ControlSpec,
    (ControlSpec, "position"): CartesianGains,
    (ControlSpec, "orientation"): CartesianGains,
    (ControlSpec, "pressure"): PressureGains,
    (ControlSpec, "pid_only"): JointPIDGains,
}
_ACTUATORS: dict[str, type] = {"torque": TorqueActuator, "hydraulic": HydraulicActuator}


def apply(spec: ManipulatorSpec, overrides: Mapping[str, Any]) -> ManipulatorSpec:
    """Return ``spec`` with each dotted path in ``overrides`` set to its value.

    Joints are addressed by name or 0-based index. Raises SpecError when a path does not exist
    (naming the valid choices) or a value is invalid.
    """
    if not isinstance(overrides, Mapping):
        raise SpecError(
            f"overrides must be a mapping {{'dotted.path': value}}, got {type(overrides).__name__}",
            file=spec.source,
        )
    data = spec.to_dict()
    _forget_derived_defaults(data, spec)
    for path, value in overrides.items():
        _set(data, spec, path, value)
    try:
        return specfile.spec_from_dict(data, source=spec.source)
    except SpecError as exc:
        raise SpecError(
            f"{exc.problem} (after override {_render(overrides)})",
            file=spec.source,
            joint=exc.joint,
            field=exc.field,
        ) from None


def _render(overrides: Mapping[str, Any]) -> str:
    return ", ".join(f"{k}={v!r}" for k, v in overrides.items())


def _fields(cls: type) -> list[str]:
    return [f.name for f in dataclasses.fields(cls) if f.name != "source"]


def _set(data: dict[str, Any], spec: ManipulatorSpec, path: Any, value: Any) -> None:
    joint: str | None = None
    field_start = 0
    parts = path.split(".") if isinstance(path, str) else []

    def fail(problem: str) -> SpecError:
        field = ".".join(parts[field_start:]) or None
        return SpecError(
            f"override {path!r}: {problem}", file=spec.source, joint=joint, field=field
        )

    if not parts or not all(parts):
        raise fail("malformed path; expected dotted keys such as 'end_effector.mass'")
    node: dict[str, Any] = data
    cls: type = ManipulatorSpec
    i = 0
    while True:
        part = parts[i]
        valid = _valid_keys(cls, node)
        if part not in valid:
            raise fail(_unknown(part, valid, cls, node))
        if i == len(parts) - 1:
            break
        if cls is ManipulatorSpec and part == "joints":
            index = _joint_index(spec, parts[i + 1], fail)
            if i + 1 == len(parts) - 1:
                raise fail(
                    "names a whole joint; expected a path to one of its fields, "
                    f"e.g. '{path}.body.mass'"
                )
            joint, field_start = spec.joints[index].name, i + 2
            node, cls, i = data["joints"][index], Joint, i + 2
            continue
        child = _child(cls, part, node)
        if child is None:
            raise fail(
                f"'{part}' is a single value, not a section; expected to override it whole, "
                f"e.g. {{'{'.'.join(parts[: i + 1])}': ...}}"
            )
        if node.get(part) is None:  # an absent optional section (e.g. no body): create it
            node[part] = {}
        if not isinstance(node[part], dict):
            raise fail(f"'{part}' was set to {node[part]!r} by an earlier override; not a section")
        node, cls, i = node[part], child, i + 1
    if cls is _Actuator and parts[-1] == "type" and value != node.get("type"):
        node.clear()  # another type of actuator: its old parameters do not apply
    node[parts[-1]] = copy.deepcopy(value)


def _valid_keys(cls: type, node: dict[str, Any]) -> list[str]:
    if cls is Joint or cls is ManipulatorSpec or cls in _SECTIONS.values():
        return _fields(cls)
    # an actuator: its fields depend on its type (all built-in types' fields if that is unknown)
    kind = node.get("type")
    actuator = _ACTUATORS.get(kind)  # type: ignore[arg-type]
    if actuator is not None:
        return _fields(actuator)
    params = _plugin_params(kind)
    if params is not None:
        return ["type", *(f.name for f in dataclasses.fields(params))]
    return list(dict.fromkeys(f for a in _ACTUATORS.values() for f in _fields(a)))


def _plugin_params(kind: Any) -> type | None:
    """The ``Params`` dataclass of the actuator plugin a spec's ``type`` names, if it names one
    (an unknown type is left to the spec's validation, which reports it)."""
    if not isinstance(kind, str):
        return None
    from maniplab.actuators.plugin import PluginLookupError, resolve

    try:
        return resolve(kind).Params
    except PluginLookupError:
        return None


def _child(cls: type, part: str, node: dict[str, Any]) -> type | None:
    if cls is Joint and part == "actuator":
        return _Actuator
    return _SECTIONS.get((cls, part))


class _Actuator:
    """Marker for the actuator section, whose fields depend on its type."""


def _unknown(part: str, valid: list[str], cls: type, node: dict[str, Any]) -> str:
    problem = specfile.unknown_key_problem(part, valid)
    if cls is _Actuator:
        owner = next((t for t, a in _ACTUATORS.items() if part in _fields(a)), None)
        if owner is not None and owner != node.get("type"):
            problem += (
                f"; '{part}' belongs to a {owner} actuator, and this one is "
                f"{node.get('type')!r}: override the whole actuator"
            )
    return problem


def _joint_index(spec: ManipulatorSpec, key: str, fail: Any) -> int:
    try:
        return spec.joint_index(int(key) if key.lstrip("-").isdigit() else key)
    except SpecError as exc:
        close = difflib.get_close_matches(key, spec.joint_names, n=1)
        hint = f"; did you mean '{close[0]}'?" if close else ""
        raise fail(exc.problem + hint) from None


def _forget_derived_defaults(data: dict[str, Any], spec: ManipulatorSpec) -> None:
    """Drop each body's COG and inertia where they equal the defaults, so they are derived anew."""
    for joint_data, joint in zip(data["joints"], spec.joints):
        body = joint.body
        if body is None:
            continue
        default = Body(length=body.length, direction=body.direction, mass=body.mass)
        for name in ("com", "inertia"):
            if getattr(body, name) == getattr(default, name):
                joint_data["body"].pop(name)
