"""The package's structure: no import cycle, no import from the package root, and nothing outside
``maniplab.actuators`` that asks for a built-in actuator type."""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import maniplab
from maniplab.actuators.registry import BUILTIN

ROOT = Path(maniplab.__file__).parent
PACKAGE = "maniplab"


def modules() -> dict[str, Path]:
    """Every module of the package by dotted name (a package is its __init__)."""
    out = {}
    for path in sorted(ROOT.rglob("*.py")):
        parts = path.relative_to(ROOT.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


MODULES = modules()
FACES = ("cli", "demo")
"""Subpackages on top of the public API (nothing in the package imports them)."""


def _runtime_nodes(tree: ast.AST) -> Iterator[ast.AST]:
    """Every node that runs at some time: all but the bodies of ``if TYPE_CHECKING:``."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            yield from (n for child in node.orelse for n in [child, *_runtime_nodes(child)])
            continue
        yield node
        yield from _runtime_nodes(node)


def imports_of(name: str) -> set[str]:
    """The package's modules that ``name`` imports when it runs (at any depth: functions too)."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in _runtime_nodes(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1]
                                + ([base] if base else []))
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base
                       for alias in node.names]
        else:
            continue
        for target in targets:
            if target.startswith(PACKAGE + ".") or target == PACKAGE:
                found.add(target)
                # importing a.b.c from outside a.b runs a.b's __init__ first (within a.b it is
                # already running; the root's __init__ is the public API, on top of everything)
                parts = target.split(".")
                found.update(a for a in (".".join(parts[:k]) for k in range(2, len(parts)))
                             if not (package + ".").startswith(a + "."))
    found.discard(name)
    return {m for m in found if m in MODULES}


def test_every_module_is_found() -> None:
    assert {"maniplab.spec.arm", "maniplab.sim.plant", "maniplab.actuators.registry"} <= set(MODULES)
    assert "maniplab.spec" in imports_of("maniplab.sim.plant")


def test_no_import_cycle_inside_the_package() -> None:
    graph = {name: imports_of(name) - {PACKAGE} for name in MODULES if name != PACKAGE}
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    cycles = []

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                cycles.append(path[path.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt, [*path, nxt])
        state[node] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c) for c in cycles)


def test_nothing_imports_from_the_package_root() -> None:
    """``from maniplab import x`` (a name of the public API) runs the whole package first; only
    the faces that sit on top of it (the command line, the demo) may use the public API so."""
    offenders = []
    for name, path in MODULES.items():
        if name == PACKAGE or name.endswith("__main__") or name.split(".")[1] in FACES:
            continue
        for node in _runtime_nodes(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module == PACKAGE and not node.level:
                offenders += [f"{name}: {a.name}" for a in node.names
                              if f"{PACKAGE}.{a.name}" not in MODULES]
            if isinstance(node, ast.Import) and any(a.name == PACKAGE for a in node.names):
                offenders.append(f"{name}: import {PACKAGE}")
    assert not offenders, offenders


def _face(name: str) -> str | None:
    parts = name.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in FACES else None


def test_the_faces_sit_on_top() -> None:
    """Nothing but the command line imports the demo, and nothing imports the command line."""
    offenders = [f"{name} imports {target}" for name in MODULES for target in imports_of(name)
                 if _face(target) and _face(target) != _face(name)
                 and not (_face(name) == "cli" or name.endswith("__main__"))]
    assert not offenders, offenders


def test_no_builtin_actuator_type_is_asked_for_outside_the_actuators_package() -> None:
    """Everything else uses the capabilities an actuator declares: no isinstance on a built-in
    model or parameter class, no comparison with a built-in type's name."""
    classes = {c.__name__ for c in BUILTIN.values()} | {c.Params.__name__ for c in BUILTIN.values()}
    offenders = []
    for name, path in MODULES.items():
        if name.startswith(PACKAGE + ".actuators"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
                    and node.func.id in ("isinstance", "issubclass")):
                used = {n.id for n in ast.walk(node.args[1]) if isinstance(n, ast.Name)}
                used |= {n.attr for n in ast.walk(node.args[1]) if isinstance(n, ast.Attribute)}
                if used & classes:
                    offenders.append(f"{name}:{node.lineno}: {ast.unparse(node)}")
            if isinstance(node, ast.Compare):
                texts = {c.value for c in [node.left, *node.comparators]
                         if isinstance(c, ast.Constant) and isinstance(c.value, str)}
                if texts & set(BUILTIN):
                    offenders.append(f"{name}:{node.lineno}: {ast.unparse(node)}")
    assert not offenders, "\n".join(offenders)
