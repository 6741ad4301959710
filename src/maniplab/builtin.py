"""The built-in spec library (``src/maniplab/assets/*.yaml``) and spec-or-name resolution."""

from __future__ import annotations

import difflib
import functools
import os
from importlib import resources
from pathlib import Path

from maniplab.errors import SpecError
from maniplab.spec import ManipulatorSpec
from maniplab.spec.files import load_spec


def _assets() -> Path:
    return Path(str(resources.files("maniplab") / "assets"))


def builtin_specs() -> list[str]:
    """Names of the built-in specs, sorted (e.g. ['crane3', 'erector', 'planar2'])."""
    return sorted(p.stem for p in _assets().glob("*.yaml"))


def builtin_spec(name: str) -> ManipulatorSpec:
    """The built-in spec called ``name``; raises SpecError listing the names when unknown."""
    names = builtin_specs()
    if name not in names:
        raise SpecError(
            f"no built-in spec {name!r}; expected one of {', '.join(names)}{_hint(name)}"
        )
    return _load_builtin(name)


@functools.cache
def _load_builtin(name: str) -> ManipulatorSpec:
    """A built-in spec, parsed once per process (specs are frozen; the files ship with the
    package)."""
    return load_spec(_assets() / f"{name}.yaml")


def _hint(name: str) -> str:
    close = difflib.get_close_matches(str(name), builtin_specs(), n=1)
    return f"; did you mean '{close[0]}'?" if close else ""


def resolve_spec(spec: str | os.PathLike[str] | ManipulatorSpec) -> ManipulatorSpec:
    """A spec from a spec object, a file path, or a built-in name (a file of that name wins)."""
    if isinstance(spec, ManipulatorSpec):
        return spec
    if not isinstance(spec, (str, os.PathLike)):
        raise SpecError(
            f"expected a spec, a spec file or a built-in name, got {type(spec).__name__}"
        )
    path = Path(spec)
    try:
        exists = path.exists()
    except (OSError, ValueError):
        exists = False
    if exists or str(spec) not in builtin_specs():
        if not exists and path.suffix == "" and os.sep not in str(spec):
            raise SpecError(
                f"no such file and no built-in spec of that name; expected a spec file or one "
                f"of the built-ins {', '.join(builtin_specs())}{_hint(str(spec))}",
                file=str(spec),
            )
        return load_spec(path)
    return builtin_spec(str(spec))
