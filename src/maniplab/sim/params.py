"""A run's parameters as flat dotted paths, and what differs between runs (for legends, tables)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from maniplab.spec import ManipulatorSpec


def flatten_spec(spec: ManipulatorSpec) -> dict[str, Any]:
    """Every value of the spec under its override path, joints by name.

    Example: ``{"end_effector.mass": 4000.0, "joints.q2.actuator.leakage": 1e-12, ...}``; vectors
    stay tuples so they compare whole.
    """
    data = spec.to_dict()
    flat: dict[str, Any] = {}
    for key, value in data.items():
        if key == "joints":
            for joint in value:
                _flatten(joint, f"joints.{joint['name']}", flat)
        else:
            _flatten(value, key, flat)
    return flat


def _flatten(value: Any, prefix: str, out: dict[str, Any]) -> None:
    if isinstance(value, Mapping):
        for key, item in value.items():
            _flatten(item, f"{prefix}.{key}", out)
    else:
        out[prefix] = tuple(value) if isinstance(value, list) else value


def differing(parameter_sets: Sequence[Mapping[str, Any]]) -> list[str]:
    """Keys whose value is not the same in every set (a key missing from one set differs)."""
    keys: list[str] = []
    for params in parameter_sets:
        keys += [k for k in params if k not in keys]
    return [k for k in keys if len({_hashable(p.get(k, _MISSING)) for p in parameter_sets}) > 1]


_MISSING = object()


def _hashable(value: Any) -> Any:
    return repr(value) if isinstance(value, (list, dict)) else value


def short_key(key: str) -> str:
    """A legend-friendly name: ``joints.q2.actuator.leakage`` -> ``q2 leakage``,
    ``end_effector.mass`` -> ``payload``."""
    parts = key.split(".")
    if parts[0] == "joints" and len(parts) >= 3:
        return f"{parts[1]} {parts[-1]}"
    return "payload" if key == "end_effector.mass" else key


def labels(parameter_sets: Sequence[Mapping[str, Any]], names: Iterable[str] | None = None) -> list[str]:
    """One label per set naming the parameters that differ, e.g. ``mass=3000, q2 leakage=1e-12``.

    When nothing differs, the given names (or "run 1", "run 2", ...) are used.
    """
    keys = differing(parameter_sets)
    fallback = list(names) if names is not None else [f"run {i + 1}" for i in range(len(parameter_sets))]
    if not keys:
        return fallback
    return [format_parameters({k: p.get(k) for k in keys}) for p in parameter_sets]


def format_parameters(values: Mapping[str, Any]) -> str:
    """``{"end_effector.mass": 3000.0}`` -> ``payload=3000``."""
    return ", ".join(f"{short_key(k)}={format_value(v)}" for k, v in values.items())


def format_value(value: Any) -> str:
    """Compact text of a parameter value (floats with %g, vectors in brackets)."""
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, tuple):
        return "[" + ", ".join(format_value(v) for v in value) + "]"
    return str(value)
