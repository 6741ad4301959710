"""Dotted-path overrides of a spec: ``{"joints.q2.actuator.leakage": 1e-11}``.

Overrides are applied to the spec's plain dict and the result is validated again, so every rule
of a spec file also holds for an override. A path is checked against the schema (the spec's
dataclasses, not the values present), so a field left at its default, or a section that is
absent (a joint without a body), can be set too; an actuator's fields are those of its type's
``Params`` (``{"joints.q1.actuator.gear_ratio": 50}`` on a geared motor plugin). A body's COG and
inertia that were left at their defaults follow the length, direction and mass they derive from.
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from maniplab.actuators.registry import PluginLookupError, registered, resolve
from maniplab.errors import SpecError
from maniplab.schema.translate import fields_of, unknown_key_problem, unwrap

if TYPE_CHECKING:
    from maniplab.spec.arm import ManipulatorSpec

_ACTUATOR = "actuator"


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
    _follow_the_pump(data, spec, overrides)
    try:
        return type(spec).from_dict(data, source=spec.source)
    except SpecError as exc:
        raise SpecError(
            f"{exc.problem} (after override {_render(overrides)})",
            file=spec.source, joint=exc.joint, field=exc.field,
        ) from None


def _follow_the_pump(data: dict[str, Any], spec: ManipulatorSpec,
                     overrides: Mapping[str, Any]) -> None:
    """A new shared pump's pressure (``supply.pressure``) is every pinned cylinder's supply
    pressure too (they must equal it), unless an override sets a cylinder's own."""
    supply = data.get("supply")
    if "supply.pressure" not in overrides or spec.supply is None or not isinstance(supply, dict):
        return
    own = {f"joints.{key}.actuator.supply_pressure" for j, joint in enumerate(spec.joints)
           for key in (joint.name, str(j))}
    if own & set(map(str, overrides)):
        return
    for joint, section in zip(spec.joints, data["joints"]):
        actuator = section.get("actuator")
        if getattr(joint.actuator, "cylinder", None) is not None and isinstance(actuator, dict):
            actuator["supply_pressure"] = supply["pressure"]


def _render(overrides: Mapping[str, Any]) -> str:
    return ", ".join(f"{k}={v!r}" for k, v in overrides.items())


def _set(data: dict[str, Any], spec: ManipulatorSpec, path: Any, value: Any) -> None:
    joint: str | None = None
    field_start = 0
    parts = path.split(".") if isinstance(path, str) else []

    def fail(problem: str) -> SpecError:
        field = ".".join(parts[field_start:]) or None
        return SpecError(f"override {path!r}: {problem}", file=spec.source, joint=joint,
                         field=field)

    if not parts or not all(parts):
        raise fail("malformed path; expected dotted keys such as 'end_effector.mass'")
    node: dict[str, Any] = data
    schema: Any = type(spec)  # a dataclass, or _ACTUATOR for an actuator section
    i = 0
    while True:
        part = parts[i]
        valid = _valid_keys(schema, node)
        if part not in valid:
            raise fail(_unknown(part, valid, schema, node))
        if i == len(parts) - 1:
            break
        if part == "joints" and schema is type(spec):
            index = _joint_index(spec, parts[i + 1], fail)
            if i + 1 == len(parts) - 1:
                raise fail("names a whole joint; expected a path to one of its fields, "
                           f"e.g. '{path}.body.mass'")
            joint, field_start = spec.joints[index].name, i + 2
            node, schema, i = data["joints"][index], type(spec.joints[index]), i + 2
            continue
        child = _child(schema, part, node)
        if child is None:
            raise fail(f"'{part}' is a single value, not a section; expected to override it "
                       f"whole, e.g. {{'{'.'.join(parts[: i + 1])}': ...}}")
        if node.get(part) is None:  # an absent optional section (e.g. no body): create it
            node[part] = {}
        if not isinstance(node[part], dict):
            raise fail(f"'{part}' was set to {node[part]!r} by an earlier override; not a section")
        node, schema, i = node[part], child, i + 1
    if schema == _ACTUATOR and parts[-1] == "type" and value != node.get("type"):
        node.clear()  # another type of actuator: its old parameters do not apply
    node[parts[-1]] = copy.deepcopy(value)


def _child(schema: Any, part: str, node: dict[str, Any]) -> Any:
    """The schema of section ``part`` of ``schema`` (a dataclass, or _ACTUATOR for the actuator
    section ``node``: its type's ``Params``), or None when ``part`` is a single value."""
    if schema == _ACTUATOR:
        schema = _params_of_type(node.get("type"), node)
        if schema is None:
            return None
    if part == _ACTUATOR:
        return _ACTUATOR
    child = unwrap(fields_of(schema)[part])
    return child if isinstance(child, type) and dataclasses.is_dataclass(child) else None


def _valid_keys(schema: Any, node: dict[str, Any]) -> list[str]:
    if schema != _ACTUATOR:
        return list(fields_of(schema))
    params = _params_of_type(node.get("type"), node)
    if params is not None:
        return list(dict.fromkeys(["type", *fields_of(params)]))
    # the type is unknown: the fields of every registered type (validation reports the type)
    return list(dict.fromkeys(k for p in registered().values() for k in ["type", *fields_of(p.Params)]))


def _params_of_type(kind: Any, node: dict[str, Any]) -> type | None:
    """The ``Params`` dataclass of the actuator type ``kind`` names (the variant the section's
    keys choose), if it names one."""
    if not isinstance(kind, str):
        return None
    try:
        return resolve(kind).variant(node).Params
    except PluginLookupError:
        return None


def _unknown(part: str, valid: list[str], schema: Any, node: dict[str, Any]) -> str:
    problem = unknown_key_problem(part, valid)
    if schema == _ACTUATOR:
        owner = next((name for name, plugin in registered().items()
                      if part in fields_of(plugin.Params)), None)
        if owner is not None and owner != node.get("type"):
            problem += (f"; '{part}' belongs to a {owner} actuator, and this one is "
                        f"{node.get('type')!r}: override the whole actuator")
    return problem


def _joint_index(spec: ManipulatorSpec, key: str, fail: Callable[[str], SpecError]) -> int:
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
        default = type(body)(length=body.length, direction=body.direction, mass=body.mass)
        for name in ("com", "inertia"):
            if getattr(body, name) == getattr(default, name):
                joint_data["body"].pop(name)
