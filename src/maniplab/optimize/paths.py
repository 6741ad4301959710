"""Design variables as overrides: a candidate's values become ``--set`` style dotted paths, a
vector component (``pins.child[0]``) merged into its vector."""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any

from maniplab.errors import SpecError
from maniplab.optimize.study import Variable
from maniplab.spec import ManipulatorSpec


def value_at(spec: ManipulatorSpec, path: str) -> Any:
    """The value at dotted ``path`` of ``spec``'s plain data (joints by name or index); None
    where the path is absent (a default section not written)."""
    node: Any = spec.to_dict()
    parts = path.split(".")
    i = 0
    while i < len(parts):
        part = parts[i]
        if part == "joints" and i == 0 and i + 1 < len(parts):
            key = parts[i + 1]
            try:
                j = spec.joint_index(int(key) if key.lstrip("-").isdigit() else key)
            except SpecError:
                return None
            node, i = node["joints"][j], i + 2
            continue
        if not isinstance(node, dict) or part not in node:
            return None
        node, i = node[part], i + 1
    return copy.deepcopy(node)


def overrides_of(base: ManipulatorSpec, variables: Sequence[Variable],
                 values: Sequence[Any]) -> dict[str, Any]:
    """The overrides that give a candidate: each variable's value at its path, components of a
    vector set within the base spec's vector."""
    out: dict[str, Any] = {}
    for variable, value in zip(variables, values):
        value = plain(value)
        if variable.index is None:
            out[variable.path] = value
            continue
        vector = out.get(variable.path)
        if vector is None:
            vector = value_at(base, variable.path)
        if not isinstance(vector, list) or variable.index >= len(vector):
            raise SpecError(f"variable {variable.name!r}: the value at {variable.path!r} is "
                            f"{vector!r}, not a vector with a component {variable.index}",
                            file=base.source)
        vector = list(vector)
        vector[variable.index] = value
        out[variable.path] = vector
    return out


def plain(value: Any) -> Any:
    """A numpy scalar as the Python number it holds (for YAML, JSON and the cache's key)."""
    if hasattr(value, "item") and callable(value.item):
        return value.item()
    return value
