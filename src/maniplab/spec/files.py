"""Reading spec files: a path to a validated :class:`~maniplab.spec.arm.ManipulatorSpec`."""

from __future__ import annotations

import math
import os
import stat
from pathlib import Path
from typing import Any

from maniplab.errors import SpecError
from maniplab.schema import describe
from maniplab.spec.arm import ManipulatorSpec
from maniplab.spec.yaml_io import Loc, parse_yaml

MAX_BYTES = 1_000_000
"""The largest spec file, bytes: a spec is a few kB, and a larger file is read and parsed in
seconds and memory that grow with it."""


def load_spec(path: str | os.PathLike[str]) -> ManipulatorSpec:
    """Read and validate a spec file.

    Args:
        path: a YAML spec file.

    Returns:
        The validated spec; ``spec.source`` is the path.

    Raises:
        SpecError: the file is missing, unreadable, not a regular file or larger than
            :data:`MAX_BYTES`, is not valid YAML, or describes an invalid arm; the message names
            the file, line, joint and field.
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
    return parse_yaml(_read_text(path, file), file)


def _read_text(path: Path, file: str) -> str:
    """The text of a regular file of at most :data:`MAX_BYTES`, read without blocking on a pipe
    or reading a device forever."""
    try:
        info = path.stat()
    except (FileNotFoundError, NotADirectoryError):
        raise SpecError("file not found; expected a YAML spec file or a built-in spec name",
                        file=file) from None
    except (OSError, ValueError) as exc:  # e.g. a NUL byte or an over-long name
        raise SpecError(f"not a usable file name ({exc})", file=file) from None
    _check_file(info, file)
    try:
        # O_NONBLOCK: a pipe swapped in after the check must not block the open
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as stream:
            _check_file(os.fstat(fd), file)
            data = stream.read(MAX_BYTES + 1)
        _check_size(len(data), file)  # it grew since
        return data.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(f"cannot be read ({exc.__class__.__name__}: {exc})", file=file) from None


def _check_file(info: os.stat_result, file: str) -> None:
    if stat.S_ISDIR(info.st_mode):
        raise SpecError("is a directory; expected a YAML spec file", file=file)
    if not stat.S_ISREG(info.st_mode):
        raise SpecError("is not a regular file (a device, pipe or socket); expected a YAML spec "
                        "file", file=file)
    _check_size(info.st_size, file)


def _check_size(size: int, file: str) -> None:
    if size > MAX_BYTES:
        shown = math.ceil(size / 1e5) / 10  # rounded up: 1 000 001 bytes is 1.1 MB, not 1.0
        raise SpecError(f"{shown:.1f} MB is larger than the {MAX_BYTES / 1e6:g} MB a spec may "
                        "have", file=file)
