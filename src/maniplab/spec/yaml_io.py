"""The YAML dialect of spec files: PyYAML's safe subset with two fixes users trip over.

``1e-11`` is a float (YAML 1.1 would read it as a string), and a key given twice in one mapping
is an error. :func:`parse_yaml` also maps each location in the data to its line, for messages.

Anchors and aliases (``&base``, ``*base``, ``<<: *base``) work, but a document whose aliases
expand to more than :data:`MAX_VALUES` values (a "billion laughs" bomb of nested aliases: a few
hundred bytes that expand to gigabytes) or that refers to itself is refused before it is
constructed.
"""

from __future__ import annotations

import re
import typing
from collections.abc import Iterable
from typing import Any

import yaml

from maniplab.errors import SpecError

Loc = tuple[Any, ...]
"""A location in parsed data: keys and list indices from the top."""

MAX_VALUES = 100_000
"""The most values (scalars, lists, mappings) a document may hold with its aliases expanded; a
spec holds a few hundred."""


_MERGE = "tag:yaml.org,2002:merge"


class _TooLarge(Exception):
    """The document holds more than MAX_VALUES values, counting aliases expanded."""

    def __init__(self, mark: yaml.Mark) -> None:
        super().__init__()
        self.line = mark.line + 1


class _Loader(yaml.SafeLoader):
    """Safe loader with YAML 1.2 floats, duplicate-key detection, and at most MAX_VALUES nodes."""

    _nodes = 0

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node | None:
        self._nodes += 1  # an alias counts as one here; _check_expansion counts what it repeats
        if self._nodes > MAX_VALUES:
            raise _TooLarge(self.peek_event().start_mark)
        return super().compose_node(parent, index)

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            if key_node.tag == _MERGE:  # '<<: *base': merged by SafeLoader, may be overridden
                continue
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
    re.VERBOSE,
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

    def represent_list(self, data: Iterable[Any]) -> yaml.SequenceNode:
        flow = all(isinstance(v, (int, float)) for v in data)
        return self.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)


_Dumper.add_representer(list, _Dumper.represent_list)


def parse_yaml(text: str, file: str | None = None) -> tuple[Any, dict[Loc, int]]:
    """Parse YAML text into plain data and a map from data paths to 1-based line numbers."""
    try:
        loader = _Loader(text)
        try:  # parse once: the node tree gives the line numbers, and constructs the data
            node = loader.get_single_node()
            if node is not None:
                _check_expansion(node, file)
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
    except _TooLarge as exc:
        raise SpecError(f"the YAML holds more than {MAX_VALUES} values (an alias repeats all "
                        "that its anchor holds); a spec holds a few hundred", file=file,
                        line=exc.line) from None
    lines: dict[Loc, int] = {}
    if node is not None:
        _record_lines(node, (), lines)
    return data, lines


def _check_expansion(node: yaml.Node, file: str | None) -> None:
    """Refuse a node graph that expands to more than MAX_VALUES values (raising _TooLarge), or
    that has a cycle (SpecError).

    An alias is the node of its anchor, shared: the graph is small, its expansion (which the
    spec's validation and ``_record_lines`` walk) may not be. Each node's expanded size is
    counted once.
    """
    sizes: dict[int, int] = {}
    open_nodes: set[int] = set()

    def size(n: yaml.Node) -> int:
        if id(n) in sizes:
            return sizes[id(n)]
        if id(n) in open_nodes:
            raise SpecError("invalid YAML: an alias refers to an anchor that contains it (a "
                            "recursive structure); expected plain data", file=file,
                            line=n.start_mark.line + 1)
        open_nodes.add(id(n))
        total = 1
        for child in _children(n):
            total += size(child)
            if total > MAX_VALUES:
                raise _TooLarge(n.start_mark)
        open_nodes.discard(id(n))
        sizes[id(n)] = total
        return total

    size(node)


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.MappingNode):
        return [child for pair in node.value for child in pair]
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    return []


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


def dump_yaml(data: Any) -> str:
    """YAML text of plain data in the dialect (short number lists in flow style, keys in order)."""
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100)
