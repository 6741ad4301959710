"""The built-in spec library (``src/maniplab/assets/*.yaml``) and spec-or-name resolution."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

from maniplab.errors import SpecError
from maniplab.spec import ManipulatorSpec
from maniplab.specfile import load_spec


def _assets() -> Path:
    return Path(str(resources.files("maniplab") / "assets"))


def builtin_specs() -> list[str]:
    """Names of the built-in specs, sorted (e.g. ['crane3', 'erector', 'planar2'])."""
    return sorted(p.stem for p in _assets().glob("*.yaml"))


def builtin_spec(name: str) -> ManipulatorSpec:
    """The built-in spec called ``name``; raises SpecError listing the names when unknown."""
    if name not in builtin_specs():
        raise SpecError(f"no built-in spec '{name}'; expected one of {', '.join(builtin_specs())}")
    return load_spec(_assets() / f"{name}.yaml")


def resolve_spec(spec: str | os.PathLike[str] | ManipulatorSpec) -> ManipulatorSpec:
    """A spec from a spec object, a file path, or a built-in name (a file of that name wins)."""
    if isinstance(spec, ManipulatorSpec):
        return spec
    path = Path(spec)
    if path.exists() or str(spec) not in builtin_specs():
        if not path.exists() and path.suffix == "" and os.sep not in str(spec):
            raise SpecError(
                f"no such file and no built-in spec of that name; built-ins are "
                f"{', '.join(builtin_specs())}",
                file=str(spec),
            )
        return load_spec(path)
    return builtin_spec(str(spec))
