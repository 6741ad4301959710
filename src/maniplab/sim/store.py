"""Run files: one ``.npz`` per run.

Why .npz: it is numpy's own container (a zip of ``.npy`` arrays), read by any numpy without
maniplab, and by MATLAB, Julia or R through their npy readers; it needs no extra dependency (HDF5
would add h5py and a C library) and keeps every float bit for bit. Beside the arrays, a JSON
header holds the spec (every default written out), the run's metadata (overrides, inputs,
controller, step), the units of the signals, the maniplab and MuJoCo versions, and a SHA-256
content hash over the arrays and the header, checked on load so a corrupt file is never used.
"""

from __future__ import annotations

import hashlib
import json
import zipfile
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from maniplab.atomic import atomic_path
from maniplab.errors import ManiplabError, SpecError
from maniplab.spec import ManipulatorSpec

if TYPE_CHECKING:
    from maniplab.sim.run import Run

FORMAT = "maniplab-run/1"

R = TypeVar("R", bound="Run")


class RunFileError(ManiplabError):
    """A stored run cannot be read (missing, truncated, corrupt or from an unknown format)."""


def content_hash(t: np.ndarray, signals: dict[str, np.ndarray], header: dict[str, Any]) -> str:
    """SHA-256 (hex) over the time vector, every signal (name, dtype, shape, bytes) and the header
    without its hash entry."""
    digest = hashlib.sha256()
    body = {k: v for k, v in header.items() if k != "hash"}
    digest.update(json.dumps(body, sort_keys=True).encode())
    for name, values in [("t", t), *sorted(signals.items())]:
        values = np.ascontiguousarray(values)
        digest.update(f"{name}|{values.dtype.str}|{values.shape}|".encode())
        digest.update(values.tobytes())
    return digest.hexdigest()


def header_of(run: Run) -> dict[str, Any]:
    """The JSON header stored with ``run`` (format, spec, meta, units, versions, hash)."""
    header = {
        "format": FORMAT,
        "spec": run.spec.to_dict(),
        "meta": dict(run.meta),
        "units": run.units(),
        "versions": {"maniplab": _version("maniplab"), "mujoco": _version("mujoco")},
    }
    header["hash"] = content_hash(np.asarray(run.t), dict(run.signals), header)
    return header


def _version(package: str) -> str:
    try:
        return version(package)
    except PackageNotFoundError:
        return "unknown"


def save(run: Run, path: Path) -> None:
    """Write ``run`` to ``path`` through a temporary file, so an interruption leaves no half file
    and an earlier file of that name stays intact until the new one is complete."""
    arrays = {f"signal/{name}": np.asarray(values) for name, values in run.signals.items()}
    header = json.dumps(header_of(run))
    with atomic_path(path) as tmp, open(tmp, "wb") as handle:
        # allow_pickle is numpy's default, named so that no array is taken for the option
        np.savez(handle, t=np.asarray(run.t), header=np.array(header), allow_pickle=True,
                 **arrays)


def read_header(path: Path) -> dict[str, Any]:
    """Only the JSON header of a run file (cheap: the arrays are not read)."""
    _check_exists(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            header = json.loads(str(data["header"]))
    except _READ_ERRORS as exc:
        raise RunFileError(f"{path}: not a readable maniplab run file ({_why(exc)})") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        found = header.get("format") if isinstance(header, dict) else None
        raise RunFileError(f"{path}: unknown run format {found!r}; expected {FORMAT}")
    return header


def load(path: Path, cls: type[R]) -> R:
    """Read a run file as a ``cls`` (a Run) and check its content hash; raises RunFileError naming
    the file and what is wrong (missing, truncated, corrupt, unknown format, invalid spec)."""
    header = read_header(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            t = data["t"]
            signals = {k.removeprefix("signal/"): data[k] for k in data.files if k.startswith("signal/")}
    except _READ_ERRORS as exc:
        raise RunFileError(f"{path}: not a readable maniplab run file ({_why(exc)})") from None
    if content_hash(t, signals, header) != header.get("hash"):
        raise RunFileError(f"{path}: content hash mismatch; the file is corrupt or was edited")
    try:
        spec = ManipulatorSpec.from_dict(header["spec"], source=str(path))
    except SpecError as exc:
        raise RunFileError(f"{path}: the stored spec is invalid ({exc.problem})") from None
    return cls(t=t, signals=signals, spec=spec, meta=header.get("meta", {}))


_READ_ERRORS = (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError, json.JSONDecodeError)


def _check_exists(path: Path) -> None:
    if not path.is_file():
        raise RunFileError(f"{path}: no such run file")


def _why(exc: BaseException) -> str:
    text = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
    return text[:120]
