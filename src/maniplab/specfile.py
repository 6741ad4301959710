"""Reading and writing spec files (YAML), and turning validation failures into one-line SpecErrors.

The YAML dialect is PyYAML's safe subset with two fixes users trip over: ``1e-11`` is a float
(YAML 1.1 would read it as a string), and a key given twice in one mapping is an error.
"""

from __future__ import annotations

import difflib
import os
import re
import typing
from pathlib import Path
from typing import Any

import yaml
from pydantic import TypeAdapter, ValidationError

from maniplab import spec as _spec
from maniplab.atomic import write_text
from maniplab.errors import SpecError

Loc = tuple[Any, ...]


class _Loader(yaml.SafeLoader):
    """Safe loader with YAML 1.2 floats and duplicate-key detection."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if isinstance(key, typing.Hashable) and key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key '{key}' is given twice in one mapping", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


_FLOAT = re.compile(
    r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
    |[-+]?\.[0-9_]+(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""",
    re.X,
)
_Loader.yaml_implicit_resolvers = {
    k: [(tag, rx) for tag, rx in v if tag != "tag:yaml.org,2002:float"]
    for k, v in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+0123456789."))


class _Dumper(yaml.SafeDumper):
    """Writes short lists of numbers in flow style ([1.0, 0.0, 0.0]) and keeps key order.

    It resolves plain scalars as _Loader does, so text that _Loader would read as a number
    (e.g. a name '1e5') is quoted.
    """

    yaml_implicit_resolvers = _Loader.yaml_implicit_resolvers

    def represent_list(self, data: list[Any]) -> yaml.Node:  # noqa: D102
        flow = all(isinstance(v, (int, float)) for v in data)
        return self.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)


_Dumper.add_representer(list, _Dumper.represent_list)


def load_spec(path: str | os.PathLike[str]) -> _spec.ManipulatorSpec:
    """Read and validate a spec file.

    Args:
        path: a YAML spec file.

    Returns:
        The validated spec; ``spec.source`` is the path.

    Raises:
        SpecError: the file is missing or unreadable, is not valid YAML, or describes an invalid
            arm; the message names the file, line, joint and field.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise SpecError(f"expected a file path, got {_describe(path)}")
    file = str(path)
    data, lines = _read_yaml(Path(path), file)
    if data is None:
        raise SpecError("the file is empty; expected a spec with at least 'joints'", file=file)
    if isinstance(data, dict) and "name" not in data:
        data = {"name": Path(path).stem, **data}
    return spec_from_dict(data, source=file, lines=lines)


def _read_yaml(path: Path, file: str) -> tuple[Any, dict[Loc, int]]:
    try:
        exists, is_dir = path.exists(), path.is_dir()
    except (OSError, ValueError) as exc:  # e.g. a NUL byte or an over-long name
        raise SpecError(f"not a usable file name ({exc})", file=file) from None
    if not exists:
        raise SpecError("file not found; expected a YAML spec file or a built-in spec name", file=file)
    if is_dir:
        raise SpecError("is a directory; expected a YAML spec file", file=file)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(f"cannot be read ({exc.__class__.__name__}: {exc})", file=file) from None
    return parse_yaml(text, file)


def parse_yaml(text: str, file: str | None = None) -> tuple[Any, dict[Loc, int]]:
    """Parse YAML text into plain data and a map from data paths to 1-based line numbers."""
    try:
        loader = _Loader(text)
        try:  # parse once: the node tree gives the line numbers, and constructs the data
            node = loader.get_single_node()
            data = loader.construct_document(node) if node is not None else None
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        problem = " ".join(str(p) for p in (exc.context, exc.problem) if p)
        if exc.context_mark and mark and exc.context_mark.line != mark.line:
            problem += f" (the construct started on line {exc.context_mark.line + 1})"
        if "'\\t'" in problem:
            problem += " (YAML does not allow tabs for indentation; expected spaces)"
        elif "<block end>" in problem or "mapping values are not allowed" in problem:
            problem += " (check this line's indentation, and that each ':' has a space after it)"
        raise SpecError(
            f"invalid YAML: {problem}", file=file, line=mark.line + 1 if mark else None
        ) from None
    except yaml.YAMLError as exc:
        raise SpecError(f"invalid YAML: {' '.join(str(exc).split())}", file=file) from None
    except RecursionError:
        raise SpecError("invalid YAML: nested too deeply", file=file) from None
    lines: dict[Loc, int] = {}
    if node is not None:
        _record_lines(node, (), lines)
    return data, lines


def _record_lines(node: yaml.Node, loc: Loc, lines: dict[Loc, int]) -> None:
    lines[loc] = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        for key_node, value_node in node.value:
            key = (key_node.value,)
            lines[loc + key] = key_node.start_mark.line + 1
            _record_lines(value_node, loc + key, lines)
            lines[loc + key] = key_node.start_mark.line + 1
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _record_lines(item, loc + (i,), lines)


def dump_spec(spec: _spec.ManipulatorSpec, path: str | os.PathLike[str]) -> None:
    """Write ``spec`` as YAML to ``path`` atomically (temporary file, then rename)."""
    text = f"# maniplab spec '{spec.name}'\n" + yaml.dump(
        spec.to_dict(), Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100
    )
    write_text(Path(path), text)


# --- validation ------------------------------------------------------------------------------

_ADAPTER = TypeAdapter(_spec.ManipulatorSpec)
_TOP_KEYS = ("name", "gravity", "joints", "end_effector", "control")


def spec_from_dict(
    data: Any, *, source: str | None = None, lines: dict[Loc, int] | None = None
) -> _spec.ManipulatorSpec:
    """Validate plain data into a ManipulatorSpec, raising a one-line SpecError on bad input.

    Args:
        data: the parsed spec (a mapping).
        source: the file it came from, for messages.
        lines: map from data paths to line numbers (from :func:`parse_yaml`), for messages.
    """
    lines = lines or {}
    if not isinstance(data, dict):
        raise SpecError(
            f"expected a mapping with keys {', '.join(_TOP_KEYS)}, got {_describe(data)}",
            file=source,
        )
    if "source" in data:
        raise SpecError(
            unknown_key_problem("source", _TOP_KEYS),
            file=source,
            field="source",
            line=_line(lines, ("source",)),
        )
    named = _with_default_names(data)
    _check_duplicate_names(named, data, source, lines)
    data = named
    try:
        spec = _ADAPTER.validate_python({**data, "source": None})
    except ValidationError as exc:
        raise translate_errors(exc.errors(), data, source, lines) from None
    return _spec.dataclasses.replace(spec, source=source) if source else spec


def _with_default_names(data: dict[Any, Any]) -> dict[Any, Any]:
    data = {"name": "manipulator", **data}
    joints = data.get("joints")
    if isinstance(joints, list):
        data["joints"] = [
            {"name": f"q{i + 1}", **j} if isinstance(j, dict) else j for i, j in enumerate(joints)
        ]
    return data


def _check_duplicate_names(
    data: dict[Any, Any], original: dict[Any, Any], source: str | None, lines: dict[Loc, int]
) -> None:
    """Duplicate joint names (``data`` has default names filled in, ``original`` does not)."""
    joints = data.get("joints")
    if not isinstance(joints, list):
        return
    seen: dict[str, int] = {}
    for i, joint in enumerate(joints):
        name = joint.get("name") if isinstance(joint, dict) else None
        if not isinstance(name, str):
            continue
        if name in seen:
            first = seen[name]
            unnamed = [k + 1 for k in (first, i) if "name" not in original["joints"][k]]
            hint = (
                f"; joint {unnamed[0]} has no name and defaults to '{name}', so give it one"
                if unnamed
                else ""
            )
            raise SpecError(
                f"duplicate joint name '{name}' (joint {first + 1} has it too){hint}; "
                "expected unique joint names",
                file=source,
                joint=name,
                field="name",
                line=_line(lines, ("joints", i, "name")),
            )
        seen[name] = i


def translate_errors(
    errors: list[Any], data: Any, source: str | None, lines: dict[Loc, int]
) -> SpecError:
    """One SpecError for pydantic's errors: the first one, but an unknown key before a missing one.

    A misspelt key (``aera``) makes pydantic report both the missing ``area`` and the unknown
    ``aera``; the unknown key with its did-you-mean is the more helpful of the two.
    """
    error = errors[0]
    if error["type"] == "missing":
        parent = tuple(error["loc"])[:-1]
        for other in errors:
            if other["type"] in _UNKNOWN_KEY and tuple(other["loc"])[:-1] == parent:
                error = other
                break
    return _translate(error, data, source, lines)


_UNKNOWN_KEY = ("extra_forbidden", "unexpected_keyword_argument")


def _translate(error: Any, data: Any, source: str | None, lines: dict[Loc, int]) -> SpecError:
    raw_loc = tuple(error["loc"])
    loc = _strip_tags(raw_loc)
    kind = error["type"]
    siblings = _fields_at(raw_loc[:-1])
    if loc and isinstance(loc[-1], int) and kind == "missing":  # too few vector elements
        loc = loc[:-1]
    if kind == "invalid_key":  # a key that is not text: report it at its mapping
        loc = loc[:-1]
    if kind in ("union_tag_invalid", "union_tag_not_found"):  # the actuator's type is at fault
        loc = (*loc, "type")
    if kind == "plugin_problem":  # a plugin actuator's type or parameter: ctx names the field
        field = str((error.get("ctx") or {}).get("field") or "")
        loc = (*loc, *field.split(".")) if field else loc
    joint = None
    field_loc = loc
    if len(loc) >= 2 and loc[0] == "joints" and isinstance(loc[1], int):
        joint = _joint_label(data, loc[1])
        field_loc = loc[2:]
    return SpecError(
        _problem(error, loc, siblings),
        file=source,
        joint=joint,
        field=_dotted(field_loc) or None,
        line=_line(lines, loc),
    )


def _joint_label(data: Any, index: int) -> str:
    """The joint's name as written, or '#k' (1-based) when it has none."""
    try:
        raw = data["joints"][index]
    except (KeyError, IndexError, TypeError):
        raw = None
    name = raw.get("name") if isinstance(raw, dict) else None
    return name if isinstance(name, str) and name else f"#{index + 1}"


def _strip_tags(loc: Loc) -> Loc:
    """Remove pydantic's union-tag entries (``actuator.hydraulic.area`` -> ``actuator.area``)."""
    out: list[Any] = []
    for i, part in enumerate(loc):
        if i and loc[i - 1] == "actuator" and part in _spec.ACTUATOR_TYPES:
            continue
        out.append(part)
    return tuple(out)


def _dotted(loc: Loc) -> str:
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def _line(lines: dict[Loc, int], loc: Loc) -> int | None:
    for end in range(len(loc), -1, -1):
        if loc[:end] in lines:
            return lines[loc[:end]]
    return None


_KINDS = {
    str: "text", bool: "a boolean", int: "an integer", float: "a number",
    type(None): "an empty value", list: "a list", tuple: "a list", dict: "a mapping",
}  # fmt: skip


def _describe(value: Any) -> str:
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


_VECTOR_LENGTHS = {"limits": 2, "inertia": 6}  # every other vector has 3 elements
_ENUM_CHOICES = {
    "axis": [a.value for a in _spec.Axis],
    "type": [t.value for t in _spec.JointType],
    "model": [m.value for m in _spec.FrictionModel],
}


def _choices(values: typing.Sequence[str]) -> str:
    quoted = [f"'{v}'" for v in values]
    return ", ".join(quoted[:-1]) + f" or {quoted[-1]}" if len(quoted) > 1 else quoted[0]


def _did_you_mean(value: Any, valid: typing.Sequence[str]) -> str:
    if not isinstance(value, str):
        return ""
    lowered = {v.lower(): v for v in valid}
    close = difflib.get_close_matches(value.lower(), list(lowered), n=1, cutoff=0.5)
    return f"; did you mean '{lowered[close[0]]}'?" if close else ""


def _problem(error: Any, loc: Loc, siblings: list[str]) -> str:  # noqa: C901, PLR0911, PLR0912
    """The problem in words, for one pydantic error at ``loc`` (``siblings``: the valid keys)."""
    kind, value, ctx = error["type"], error.get("input"), error.get("ctx") or {}
    leaf = loc[-1] if loc else ""
    if kind in _UNKNOWN_KEY:
        return unknown_key_problem(str(leaf), siblings)
    if kind == "invalid_key":
        return f"unknown key {_describe(value)}; expected one of {', '.join(siblings)}"
    if kind == "missing" and error["loc"] and isinstance(error["loc"][-1], int):
        n = _VECTOR_LENGTHS.get(str(leaf), 3)
        return f"expected a list of {n} numbers, got {_describe(value)}"
    if kind == "missing":
        return f"missing required key '{leaf}'"
    if kind in ("too_short", "too_long"):
        if loc == ("joints",):
            return "the joint list is empty; expected at least one joint"
        n = ctx.get("max_length", ctx.get("min_length", _VECTOR_LENGTHS.get(str(leaf), 3)))
        return f"expected a list of {n} numbers, got {_describe(value)}"
    if kind in ("float_type", "float_parsing", "int_type"):
        hint = ""
        if isinstance(value, str) and re.fullmatch(r"\s*[-+]?[0-9]+,[0-9]+\s*", value):
            hint = f"; write a decimal point: {value.strip().replace(',', '.')}"
        elif isinstance(value, str) and re.match(r"\s*[-+]?\.?[0-9]", value):
            hint = "; write a plain number in SI units (m, kg, rad, N, Pa, m³/s)"
        return f"expected a number, got {_describe(value)}{hint}"
    if kind in ("bool_type", "bool_parsing"):
        return f"expected true or false, got {_describe(value)}"
    if kind == "finite_number":
        return f"expected a finite number, got {_describe(value)}"
    if kind in ("greater_than_equal", "greater_than"):
        bound = ctx.get("ge", ctx.get("gt"))
        sign = ">=" if kind == "greater_than_equal" else ">"
        return f"expected a number {sign} {bound:g}, got {_describe(value)}"
    if kind in ("less_than_equal", "less_than"):
        bound = ctx.get("le", ctx.get("lt"))
        sign = "<=" if kind == "less_than_equal" else "<"
        return f"expected a number {sign} {bound:g}, got {_describe(value)}"
    if kind == "enum":
        choices = _ENUM_CHOICES.get(str(leaf), [])
        extra = " (the paper's Tr is accepted for P)" if leaf == "type" else ""
        expected = _choices(choices) if choices else ctx.get("expected")
        shown = repr(value) if isinstance(value, str) else _describe(value)
        return (
            f"unknown {_ENUM_LABELS.get(str(leaf), leaf)} {shown}; expected {expected}{extra}"
            f"{_did_you_mean(value, choices)}"
        )
    if kind == "union_tag_invalid":
        tag = ctx.get("tag")
        return (
            f"unknown actuator type {tag!r}; expected {_choices(_spec.ACTUATOR_TYPES)}, or a "
            "plugin as 'module:Class' or a registered name"
            f"{_did_you_mean(tag, _spec.ACTUATOR_TYPES)}"
        )
    if kind == "plugin_problem":
        return str(ctx.get("problem"))
    if kind == "union_tag_not_found":
        types = " or ".join(f"'type: {t}'" for t in _spec.ACTUATOR_TYPES)
        return f"missing key 'type'; expected {types}"
    if kind == "string_type":
        return f"expected text, got {_describe(value)}"
    if kind == "string_too_short":
        return "expected a non-empty name, got ''"
    if kind == "string_pattern_mismatch":
        return (
            f"{value!r} is not a valid name; expected letters, digits, '_' and '-', "
            "starting with a letter or '_'"
        )
    if kind in ("tuple_type", "list_type"):
        if loc == ("joints",):
            return f"expected a list of joints (each '- name: ...'), got {_describe(value)}"
        n = _VECTOR_LENGTHS.get(str(leaf), 3)
        return f"expected a list of {n} numbers, got {_describe(value)}"
    if kind in ("dataclass_type", "model_attributes_type", "dict_type", "dataclass_exact_type"):
        section = "joint" if len(loc) == 2 and loc[0] == "joints" else str(leaf)
        example = _SECTION_EXAMPLES.get(section, "key: value")
        return f"expected a mapping such as {{{example}}}, got {_describe(value)}"
    if kind == "literal_error":
        return f"expected {ctx.get('expected')}, got {_describe(value)}"
    if kind == "value_error":
        return str(error["msg"]).removeprefix("Value error, ")
    return f"{error['msg']}, got {_describe(value)}"


_ENUM_LABELS = {"type": "joint type", "model": "friction model"}
_SECTION_EXAMPLES = {
    "joint": "name: q1, type: R, axis: z",
    "actuator": "type: torque",
    "friction": "model: hybrid, coulomb: 100.0",
    "body": "length: 1.0, mass: 10.0",
    "end_effector": "mass: 500.0",
    "control": "rate: 200.0, position: {kp: 400.0, kd: 40.0}",
    "position": "kp: 400.0, ki: 1000.0, kd: 40.0",
    "orientation": "kp: 400.0, ki: 1000.0, kd: 40.0",
    "pressure": "bandwidth: 40.0",
    "pid_only": "kp: 3.0, ki: 96.0",
}


def plugin_problem(errors: list[Any], params: type) -> tuple[str, str]:
    """(field, problem) for the validation errors of an actuator plugin's ``Params`` dataclass.

    The field is dotted and relative to the actuator (``resistance``), the problem is phrased as
    for the spec's own fields.
    """
    valid = [f.name for f in _spec.dataclasses.fields(params)]
    error = errors[0]
    if error["type"] == "missing":
        error = next((e for e in errors if e["type"] in _UNKNOWN_KEY), error)
    loc = tuple(error["loc"])
    if error["type"] in _UNKNOWN_KEY:
        return _dotted(loc), unknown_key_problem(str(loc[-1]), valid)
    return _dotted(loc), _problem(error, loc, valid)


def unknown_key_problem(key: str, valid: typing.Sequence[str]) -> str:
    close = difflib.get_close_matches(key, valid, n=1)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    return f"unknown key '{key}'{hint} (valid keys: {', '.join(valid)})"


_CHILD_TYPES: dict[tuple[type, str], type] = {
    (_spec.ManipulatorSpec, "joints"): _spec.Joint,
    (_spec.ManipulatorSpec, "end_effector"): _spec.EndEffector,
    (_spec.Joint, "body"): _spec.Body,
    (_spec.Joint, "friction"): _spec.Friction,
    (_spec.ManipulatorSpec, "control"): _spec.ControlSpec,
    (_spec.ControlSpec, "position"): _spec.CartesianGains,
    (_spec.ControlSpec, "orientation"): _spec.CartesianGains,
    (_spec.ControlSpec, "pressure"): _spec.PressureGains,
    (_spec.ControlSpec, "pid_only"): _spec.JointPIDGains,
}


def _fields_at(raw_loc: Loc) -> list[str]:
    """Field names of the spec dataclass at pydantic location ``raw_loc`` (with union tags)."""
    cls: type = _spec.ManipulatorSpec
    for i, part in enumerate(raw_loc):
        if isinstance(part, int):
            continue
        if cls is _spec.Joint and part == "actuator":
            tag = raw_loc[i + 1] if i + 1 < len(raw_loc) else None
            cls = _ACTUATOR_CLASSES.get(tag, _spec.TorqueActuator)
            continue
        cls = _CHILD_TYPES.get((cls, part), cls)
    return [f.name for f in _spec.dataclasses.fields(cls) if f.name != "source"]


_ACTUATOR_CLASSES = {"torque": _spec.TorqueActuator, "hydraulic": _spec.HydraulicActuator}
