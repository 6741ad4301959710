"""Reading and writing spec files (YAML), and turning validation failures into one-line SpecErrors.

The YAML dialect is PyYAML's safe subset with two fixes users trip over: ``1e-11`` is a float
(YAML 1.1 would read it as a string), and a key given twice in one mapping is an error.
"""

from __future__ import annotations

import difflib
import os
import re
import tempfile
import typing
from pathlib import Path
from typing import Any

import yaml
from pydantic import TypeAdapter, ValidationError

from maniplab import spec as _spec
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
    |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
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
    """Writes short lists of numbers in flow style ([1.0, 0.0, 0.0]) and keeps key order."""

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
    file = str(path)
    data, lines = _read_yaml(Path(path), file)
    if data is None:
        raise SpecError("the file is empty; expected a spec with at least 'joints'", file=file)
    if isinstance(data, dict) and "name" not in data:
        data = {"name": Path(path).stem, **data}
    return spec_from_dict(data, source=file, lines=lines)


def _read_yaml(path: Path, file: str) -> tuple[Any, dict[Loc, int]]:
    if not path.exists():
        raise SpecError("file not found; expected a YAML spec file or a built-in spec name", file=file)
    if path.is_dir():
        raise SpecError("is a directory; expected a YAML spec file", file=file)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(f"cannot be read ({exc.__class__.__name__}: {exc})", file=file) from None
    return parse_yaml(text, file)


def parse_yaml(text: str, file: str | None = None) -> tuple[Any, dict[Loc, int]]:
    """Parse YAML text into plain data and a map from data paths to 1-based line numbers."""
    try:
        node = yaml.compose(text, Loader=_Loader)
        data = yaml.load(text, Loader=_Loader)  # noqa: S506 - _Loader is a SafeLoader
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        problem = " ".join(str(p) for p in (exc.context, exc.problem) if p)
        raise SpecError(
            f"invalid YAML: {problem}", file=file, line=mark.line + 1 if mark else None
        ) from None
    except yaml.YAMLError as exc:
        raise SpecError(f"invalid YAML: {exc}", file=file) from None
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
    write_atomic(Path(path), text)


def write_atomic(path: Path, text: str) -> None:
    """Write text to ``path`` through a temporary file in the same folder, so no half file is left."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


# --- validation ------------------------------------------------------------------------------

_ADAPTER = TypeAdapter(_spec.ManipulatorSpec)
_TOP_KEYS = ("name", "gravity", "joints", "end_effector")


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
    data = _with_default_names(data)
    _check_duplicate_names(data, source, lines)
    try:
        spec = _ADAPTER.validate_python({**data, "source": None})
    except ValidationError as exc:
        raise _translate(exc.errors()[0], data, source, lines) from None
    return _spec.dataclasses.replace(spec, source=source) if source else spec


def _with_default_names(data: dict[str, Any]) -> dict[str, Any]:
    data = {"name": "manipulator", **data}
    joints = data.get("joints")
    if isinstance(joints, list):
        data["joints"] = [
            {"name": f"q{i + 1}", **j} if isinstance(j, dict) else j for i, j in enumerate(joints)
        ]
    if "source" in data:
        raise SpecError(unknown_key_problem("source", _TOP_KEYS), field="source")
    return data


def _check_duplicate_names(data: dict[str, Any], source: str | None, lines: dict[Loc, int]) -> None:
    seen: dict[str, int] = {}
    for i, joint in enumerate(data.get("joints") or []):
        name = joint.get("name") if isinstance(joint, dict) else None
        if not isinstance(name, str):
            continue
        if name in seen:
            raise SpecError(
                f"duplicate joint name '{name}' (joint {seen[name] + 1} has it too); "
                "joint names must be unique",
                file=source,
                joint=name,
                field="name",
                line=_line(lines, ("joints", i, "name")),
            )
        seen[name] = i


def _translate(
    error: dict[str, Any], data: dict[str, Any], source: str | None, lines: dict[Loc, int]
) -> SpecError:
    raw_loc = tuple(error["loc"])
    loc = _strip_tags(raw_loc)
    joint = None
    field_loc = loc
    if len(loc) >= 2 and loc[0] == "joints" and isinstance(loc[1], int):
        raw = data["joints"][loc[1]]
        name = raw.get("name") if isinstance(raw, dict) else None
        joint = name if isinstance(name, str) else f"#{loc[1] + 1}"
        field_loc = loc[2:]
    return SpecError(
        _problem(error, loc, _fields_at(raw_loc[:-1])),
        file=source,
        joint=joint,
        field=_dotted(field_loc) or None,
        line=_line(lines, loc),
    )


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


def _describe(value: Any) -> str:
    text = repr(value)
    text = text if len(text) <= 40 else text[:37] + "..."
    return f"{text} ({type(value).__name__})"


def _problem(error: dict[str, Any], loc: Loc, siblings: list[str]) -> str:  # noqa: C901
    """The problem in words, for one pydantic error at ``loc`` (``siblings``: the valid keys)."""
    kind, value, ctx = error["type"], error.get("input"), error.get("ctx") or {}
    leaf = loc[-1] if loc else ""
    if kind in ("extra_forbidden", "unexpected_keyword_argument"):
        return unknown_key_problem(str(leaf), siblings)
    if kind == "missing" and isinstance(leaf, int):
        return f"expected a list of {leaf + 1} or more numbers, got too few"
    if kind == "missing":
        return f"missing required key '{leaf}'"
    if kind in ("too_short", "too_long"):
        if loc == ("joints",):
            return "the joint list is empty; a manipulator needs at least one joint"
        return f"expected a list of {ctx.get('min_length', '?')} values, got {_describe(value)}"
    if kind in ("float_type", "float_parsing", "int_type"):
        return f"expected a number, got {_describe(value)}"
    if kind == "finite_number":
        return f"expected a finite number, got {value!r}"
    if kind in ("greater_than_equal", "greater_than"):
        bound = ctx.get("ge", ctx.get("gt"))
        sign = ">=" if kind == "greater_than_equal" else ">"
        return f"must be {sign} {bound:g}, got {value!r}"
    if kind == "enum":
        extra = " (Tr is accepted for P)" if leaf == "type" else ""
        return f"unknown {leaf} {value!r}; expected {ctx.get('expected')}{extra}"
    if kind == "union_tag_invalid":
        return f"unknown actuator type '{ctx.get('tag')}'; expected {ctx.get('expected_tags')}"
    if kind == "union_tag_not_found":
        return f"missing key 'type'; expected one of {', '.join(_spec.ACTUATOR_TYPES)}"
    if kind == "string_type":
        return f"expected a string, got {_describe(value)}"
    if kind == "string_pattern_mismatch":
        return f"{value!r} is not a valid name; use letters, digits, '_' and '-', starting with a letter"
    if kind in ("tuple_type", "list_type"):
        return f"expected a list, got {_describe(value)}"
    if kind in ("dataclass_type", "model_attributes_type", "dict_type", "dataclass_exact_type"):
        return f"expected a mapping (key: value), got {_describe(value)}"
    if kind == "value_error":
        return str(error["msg"]).removeprefix("Value error, ")
    return f"{error['msg']}, got {_describe(value)}"


def unknown_key_problem(key: str, valid: typing.Sequence[str]) -> str:
    close = difflib.get_close_matches(key, valid, n=1)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    return f"unknown key '{key}'{hint} (valid keys: {', '.join(valid)})"


_CHILD_TYPES: dict[tuple[type, str], type] = {
    (_spec.ManipulatorSpec, "joints"): _spec.Joint,
    (_spec.ManipulatorSpec, "end_effector"): _spec.EndEffector,
    (_spec.Joint, "body"): _spec.Body,
    (_spec.Joint, "friction"): _spec.Friction,
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
