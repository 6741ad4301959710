"""Dotted-path overrides of a spec: ``{"joints.q2.actuator.leakage": 1e-11}``.

Overrides are applied to the spec's plain dict and the result is validated again, so every rule
of a spec file also holds for an override. A body's COG and inertia that were left at their
defaults follow the length, direction and mass they derive from.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

from maniplab import specfile
from maniplab.errors import SpecError
from maniplab.spec import Body, ManipulatorSpec


def apply(spec: ManipulatorSpec, overrides: Mapping[str, Any]) -> ManipulatorSpec:
    """Return ``spec`` with each dotted path in ``overrides`` set to its value.

    Joints are addressed by name or 0-based index. Raises SpecError when a path does not exist
    (naming the valid choices) or a value is invalid.
    """
    data = spec.to_dict()
    _forget_derived_defaults(data, spec)
    for path, value in overrides.items():
        _set(data, spec, str(path), value)
    try:
        return specfile.spec_from_dict(data, source=spec.source)
    except SpecError as exc:
        raise SpecError(
            f"{exc.problem} (after override {_render(overrides)})",
            file=spec.source, joint=exc.joint, field=exc.field,
        ) from None


def _render(overrides: Mapping[str, Any]) -> str:
    return ", ".join(f"{k}={v!r}" for k, v in overrides.items())


def _set(data: dict[str, Any], spec: ManipulatorSpec, path: str, value: Any) -> None:
    parts = path.split(".")
    joint, field_start = None, 0
    node: Any = data

    def fail(problem: str) -> SpecError:
        field = ".".join(parts[field_start:]) or None
        return SpecError(f"override '{path}': {problem}", file=spec.source, joint=joint, field=field)

    if not all(parts):
        raise fail("malformed path; expected dotted keys such as 'end_effector.mass'")
    for i, part in enumerate(parts[:-1]):
        if node is data.get("joints"):
            index = _joint_index(spec, part, fail)
            joint, field_start, node = spec.joints[index].name, i + 1, node[index]
            continue
        if not isinstance(node, dict) or part not in node:
            raise fail(specfile.unknown_key_problem(part, list(node) if isinstance(node, dict) else []))
        if node[part] is None:  # an absent optional section (e.g. no body): create it
            node[part] = {}
        node = node[part]
    leaf = parts[-1]
    if node is data.get("joints") or not isinstance(node, dict):
        raise fail("does not name a field")
    if node and leaf not in node:
        raise fail(specfile.unknown_key_problem(leaf, list(node)))
    node[leaf] = copy.deepcopy(value)


def _joint_index(spec: ManipulatorSpec, key: str, fail: Any) -> int:
    try:
        return spec.joint_index(int(key) if key.lstrip("-").isdigit() else key)
    except SpecError as exc:
        raise fail(exc.problem) from None


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
