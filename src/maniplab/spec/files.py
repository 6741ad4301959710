"""Reading spec files: a path to a validated :class:`~maniplab.spec.arm.ManipulatorSpec`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from maniplab.errors import SpecError
from maniplab.schema import describe
from maniplab.spec.arm import ManipulatorSpec
from maniplab.spec.yaml_io import Loc, parse_yaml


def load_spec(path: str | os.PathLike[str]) -> ManipulatorSpec:
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
        raise SpecError(f"expected a file path, got {describe(path)}")
    file = str(path)
    data, lines = _read_yaml(Path(path), file)
    if data is None:
        raise SpecError("the file is empty; expected a spec with at least 'joints'", file=file)
    if isinstance(data, dict) and "name" not in data:
        data = {"name": Path(path).stem, **data}
    return ManipulatorSpec.from_dict(data, source=file, lines=lines)


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
