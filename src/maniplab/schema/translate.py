"""pydantic's validation errors as one-line SpecErrors, in the words of a spec file's author.

The wording is derived from the dataclasses themselves: the valid keys of a section are its
fields, the length of a vector is its tuple type's, the choices of a discrete field are its
enum's values, and the error's location gives the line (from the YAML parser's map) and the
joint. A field's own validator can word its problem completely by raising
``PydanticCustomError("spec_problem", "{problem}", {"problem": ..., "field": "dotted.field"})``;
``field`` (optional) continues the location below the field (e.g. an actuator's parameter).
"""

from __future__ import annotations

import dataclasses
import difflib
import enum
import re
import types
import typing
from collections.abc import Mapping, Sequence
from typing import Any, Union

from maniplab.errors import SpecError

Loc = tuple[Any, ...]

UNKNOWN_KEY = ("extra_forbidden", "unexpected_keyword_argument")
"""pydantic's error kinds for a key that is not a field."""

INTERNAL = "internal"
"""Metadata flag of a dataclass field that is not part of the file's schema (e.g. the source)."""


def translate_errors(errors: Sequence[Any], *, root: type, data: Any = None,
                     source: str | None = None, lines: Mapping[Loc, int] | None = None
                     ) -> SpecError:
    """One SpecError for pydantic's errors: the first one, but an unknown key before a missing one.

    A misspelt key (``aera``) makes pydantic report both the missing ``area`` and the unknown
    ``aera``; the unknown key with its did-you-mean is the more helpful of the two.

    Args:
        errors: ``ValidationError.errors()``.
        root: the dataclass that was validated (the locations are relative to it).
        data: the data that was validated (to name a joint that has no name), or None.
        source: the file, for the message.
        lines: map from data locations to 1-based line numbers (see ``maniplab.spec.yaml_io``).
    """
    error = errors[0]
    if error["type"] == "missing":
        parent = tuple(error["loc"])[:-1]
        error = next((e for e in errors if e["type"] in UNKNOWN_KEY
                      and tuple(e["loc"])[:-1] == parent), error)
    return _translate(error, root, data, source, lines or {})


def _translate(error: Any, root: type, data: Any, source: str | None,
               lines: Mapping[Loc, int]) -> SpecError:
    loc = tuple(error["loc"])
    kind = error["type"]
    parent_loc = loc[:-1]
    if loc and isinstance(loc[-1], int) and kind == "missing":  # too few vector elements
        loc = loc[:-1]
    if kind == "invalid_key":  # a key that is not text: report it at its mapping
        loc = loc[:-1]
        parent_loc = loc
    problem = problem_text(error, loc, keys_at(root, parent_loc), schema_at(root, loc))
    if kind == "spec_problem":  # a field's validator named the field below it
        field = str((error.get("ctx") or {}).get("field") or "")
        loc = (*loc, *field.split(".")) if field else loc
    joint, field_loc = None, loc
    if _is_named_list(root, loc):
        joint = _item_label(data, loc[0], loc[1])
        field_loc = loc[2:]
    return SpecError(problem, file=source, joint=joint, field=dotted(field_loc) or None,
                     line=line_of(lines, loc))


# --- the schema at a location ------------------------------------------------------------------


def unwrap(annotation: Any) -> Any:
    """The type under ``Annotated[...]`` and ``X | None`` (the first non-None member)."""
    while True:
        origin = typing.get_origin(annotation)
        if origin is typing.Annotated:
            annotation = typing.get_args(annotation)[0]
        elif origin in (Union, types.UnionType):
            members = [a for a in typing.get_args(annotation) if a is not type(None)]
            annotation = members[0] if len(members) == 1 else annotation
            if len(members) != 1:
                return annotation
        else:
            return annotation


def fields_of(cls: type) -> dict[str, Any]:
    """Schema fields of a dataclass, name -> annotation (internal fields left out)."""
    hints = typing.get_type_hints(cls, include_extras=True)
    return {f.name: hints[f.name] for f in dataclasses.fields(cls)
            if not f.metadata.get(INTERNAL)}


def schema_at(root: type, loc: Loc) -> Any:
    """The (unwrapped) type of the field at ``loc`` below the dataclass ``root``, or None."""
    node: Any = root
    for part in loc:
        node = unwrap(node)
        if isinstance(part, int):
            args = typing.get_args(node) if typing.get_origin(node) is tuple else ()
            if not args:
                return None
            node = args[0] if len(args) == 2 and args[1] is Ellipsis else args[min(part, len(args) - 1)]
        elif dataclasses.is_dataclass(node) and isinstance(node, type):
            node = fields_of(node).get(part)
            if node is None:
                return None
        else:
            return None
    return unwrap(node)


def keys_at(root: type, loc: Loc) -> list[str]:
    """The valid keys of the section at ``loc`` (empty when it is not a dataclass)."""
    node = schema_at(root, loc)
    return list(fields_of(node)) if _is_section(node) else []


def _is_section(node: Any) -> bool:
    return isinstance(node, type) and dataclasses.is_dataclass(node)


def _vector_length(node: Any) -> int | None:
    """Length of a fixed-length tuple type, else None."""
    if typing.get_origin(node) is not tuple:
        return None
    args = typing.get_args(node)
    return None if len(args) == 2 and args[1] is Ellipsis else len(args)


def _item_type(node: Any) -> Any:
    """The element type of a variable-length tuple type (``tuple[X, ...]``), else None."""
    args = typing.get_args(node) if typing.get_origin(node) is tuple else ()
    return unwrap(args[0]) if len(args) == 2 and args[1] is Ellipsis else None


def _is_named_list(root: type, loc: Loc) -> bool:
    """Whether ``loc`` starts inside a list of named sections (the spec's joints)."""
    if len(loc) < 2 or not isinstance(loc[1], int):
        return False
    item = _item_type(schema_at(root, loc[:1]))
    return _is_section(item) and "name" in fields_of(item)


def label(cls: type) -> str:
    """A class's name in words: ``FrictionModel`` -> 'friction model'."""
    return re.sub(r"(?<!^)(?=[A-Z])", " ", cls.__name__).lower()


def example(cls: type) -> str:
    """An example of a section, ``key: value, ...``: the class's ``EXAMPLE`` or its first fields."""
    given = getattr(cls, "EXAMPLE", None)
    if isinstance(given, str):
        return given
    defaults = [(f.name, f.default) for f in dataclasses.fields(cls)
                if f.default is not dataclasses.MISSING and not f.metadata.get(INTERNAL)]
    return ", ".join(f"{k}: {_yaml(v)}" for k, v in defaults[:2]) or "key: value"


def _yaml(value: Any) -> str:
    if isinstance(value, enum.Enum):
        return str(value.value)
    if value is None:
        return "null"
    return str(list(value)) if isinstance(value, tuple) else str(value)


# --- locations -----------------------------------------------------------------------------------


def dotted(loc: Loc) -> str:
    """``("body", "inertia", 2)`` -> ``body.inertia[2]``."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def line_of(lines: Mapping[Loc, int], loc: Loc) -> int | None:
    """The line of ``loc``, or of its nearest enclosing location that has one."""
    for end in range(len(loc), -1, -1):
        if loc[:end] in lines:
            return lines[loc[:end]]
    return None


def _item_label(data: Any, key: Any, index: int) -> str:
    """An item of a named list (a joint) by its name as written, or '#k' (1-based)."""
    try:
        raw = data[key][index]
    except (KeyError, IndexError, TypeError):
        raw = None
    name = raw.get("name") if isinstance(raw, dict) else None
    return name if isinstance(name, str) and name else f"#{index + 1}"


# --- the problem in words ----------------------------------------------------------------------

_KINDS = {
    str: "text", bool: "a boolean", int: "an integer", float: "a number",
    type(None): "an empty value", list: "a list", tuple: "a list", dict: "a mapping",
}  # fmt: skip


def describe(value: Any) -> str:
    """A value as a YAML user would recognise it: ``'10 kg' (text)``, ``true (a boolean)``."""
    if value is None:
        return "nothing (an empty value)"
    if isinstance(value, bool):
        text = "true" if value else "false"
    else:
        try:
            text = repr(value)
        except Exception:  # noqa: BLE001 - a broken __repr__ must not hide the real problem
            text = "?"
    text = text if len(text) <= 40 else text[:37] + "..."
    return f"{text} ({_KINDS.get(type(value), type(value).__name__)})"


def _shortened(text: Any) -> str:
    """``repr`` of ``text``, cut to 40 characters."""
    shown = repr(text)
    return shown if len(shown) <= 40 else shown[:37] + "..."


def choices(values: Sequence[str]) -> str:
    """``'a', 'b' or 'c'``."""
    quoted = [f"'{v}'" for v in values]
    return ", ".join(quoted[:-1]) + f" or {quoted[-1]}" if len(quoted) > 1 else quoted[0]


def did_you_mean(value: Any, valid: Sequence[str]) -> str:
    """``; did you mean 'x'?`` for the closest valid value (case-insensitive), or ''."""
    if not isinstance(value, str):
        return ""
    lowered = {v.lower(): v for v in valid}
    close = difflib.get_close_matches(value.lower(), list(lowered), n=1, cutoff=0.5)
    return f"; did you mean '{lowered[close[0]]}'?" if close else ""


def unknown_key_problem(key: str, valid: Sequence[str]) -> str:
    """``unknown key 'aera'; did you mean 'area'? (valid keys: ...)``."""
    close = difflib.get_close_matches(key, valid, n=1)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    return f"unknown key '{key}'{hint} (valid keys: {', '.join(valid)})"


def _number_hint(value: Any) -> str:
    if isinstance(value, str) and re.fullmatch(r"\s*[-+]?[0-9]+,[0-9]+\s*", value):
        return f"; write a decimal point: {value.strip().replace(',', '.')}"
    if isinstance(value, str) and re.match(r"\s*[-+]?\.?[0-9]", value):
        return "; write a plain number in SI units (m, kg, rad, N, Pa, m³/s)"
    return ""


def _list_problem(node: Any, value: Any) -> str:
    item = _item_type(node)
    if _is_section(item):
        name = label(item)
        first = next(iter(fields_of(item)), "key")
        return f"expected a list of {name}s (each '- {first}: ...'), got {describe(value)}"
    return f"expected a list of {_vector_length(node) or 3} numbers, got {describe(value)}"


def problem_text(error: Any, loc: Loc, siblings: Sequence[str], node: Any = None) -> str:
    """The problem in words for one pydantic error at ``loc``.

    Args:
        error: one entry of ``ValidationError.errors()``.
        loc: its location (for a missing vector element, the vector's).
        siblings: the valid keys of the section the error is in.
        node: the field's type there (:func:`schema_at`), for lengths, choices and examples.
    """
    kind, value, ctx = error["type"], error.get("input"), error.get("ctx") or {}
    leaf = loc[-1] if loc else ""
    if kind in UNKNOWN_KEY:
        return unknown_key_problem(str(leaf), siblings)
    if kind == "invalid_key":
        return f"unknown key {describe(value)}; expected one of {', '.join(siblings)}"
    if kind == "spec_problem":
        return str(ctx.get("problem"))
    if kind == "missing" and error["loc"] and isinstance(error["loc"][-1], int):
        return f"expected a list of {_vector_length(node) or 3} numbers, got {describe(value)}"
    if kind == "missing":
        return f"missing required key '{leaf}'"
    if kind in ("too_short", "too_long"):
        item = _item_type(node)
        if _is_section(item) and kind == "too_short":
            return f"the {label(item)} list is empty; expected at least one {label(item)}"
        return f"expected a list of {_vector_length(node) or 3} numbers, got {describe(value)}"
    if kind in ("float_type", "float_parsing", "int_type"):
        return f"expected a number, got {describe(value)}{_number_hint(value)}"
    if kind in ("bool_type", "bool_parsing"):
        return f"expected true or false, got {describe(value)}"
    if kind == "finite_number":
        return f"expected a finite number, got {describe(value)}"
    if kind in ("greater_than_equal", "greater_than", "less_than_equal", "less_than"):
        sign = {"greater_than_equal": ">=", "greater_than": ">", "less_than_equal": "<=",
                "less_than": "<"}[kind]
        bound = ctx.get("ge", ctx.get("gt", ctx.get("le", ctx.get("lt"))))
        return f"expected a number {sign} {bound:g}, got {describe(value)}"
    if kind == "enum" and isinstance(node, type) and issubclass(node, enum.Enum):
        values = [str(m.value) for m in node]
        hint = node.choice_hint() if hasattr(node, "choice_hint") else ""
        shown = repr(value) if isinstance(value, str) else describe(value)
        return (f"unknown {label(node)} {shown}; expected {choices(values)}{hint}"
                f"{did_you_mean(value, values)}")
    if kind == "string_type":
        return f"expected text, got {describe(value)}"
    if kind == "string_too_short":
        return "expected a non-empty name, got ''"
    if kind == "string_pattern_mismatch":
        return (f"{_shortened(value)} is not a valid name; expected letters, digits, '_' and '-', "
                "starting with a letter or '_'")
    if kind == "string_too_long":
        return (f"the name {_shortened(value)} has {len(value)} characters; expected at most "
                f"{ctx.get('max_length')}")
    if kind in ("tuple_type", "list_type"):
        return _list_problem(node, value)
    if kind in ("dataclass_type", "model_attributes_type", "dict_type", "dataclass_exact_type"):
        shown = example(node) if _is_section(node) else "key: value"
        return f"expected a mapping such as {{{shown}}}, got {describe(value)}"
    if kind == "literal_error":
        return f"expected {ctx.get('expected')}, got {describe(value)}"
    if kind == "value_error":
        return str(error["msg"]).removeprefix("Value error, ")
    return f"{error['msg']}, got {describe(value)}"
