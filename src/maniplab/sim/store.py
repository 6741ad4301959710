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
import math
import zipfile
import zlib
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

#: Signals with one column per joint.
JOINT_SIGNALS = frozenset({"q", "qd", "tau_act", "tau_fric", "tau_limit", "ctrl", "iv", "dP", "Q",
                           "mode"})


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
    with _open(path) as data:
        return _header(path, data)


def load(path: Path, cls: type[R]) -> R:
    """Read a run file as a ``cls`` (a Run) and check its content hash; raises RunFileError naming
    the file and what is wrong (missing, truncated, corrupt, unknown format, invalid spec, signals
    of the wrong length)."""
    with _open(path) as data:
        header = _header(path, data)
        t = _array(path, data, "t")
        signals = {name.removeprefix("signal/"): _array(path, data, name)
                   for name in data.files if name.startswith("signal/")}
    if content_hash(t, signals, header) != header.get("hash"):
        raise RunFileError(f"{path}: content hash mismatch; the file is corrupt or was edited")
    spec = stored_spec(header, path)
    try:
        run = cls(t=t, signals=signals, spec=spec, meta=header.get("meta", {}))
    except ManiplabError as exc:  # e.g. a signal whose length is not t's
        raise RunFileError(f"{path}: {exc}") from None
    _check_samples(path, run)
    return run


def stored_spec(header: dict[str, Any], path: Path) -> ManipulatorSpec:
    """The spec in a run file's ``header``; raises RunFileError naming ``path`` when invalid."""
    try:
        return ManipulatorSpec.from_dict(header.get("spec"), source=str(path), defer_plugins=True)
    except SpecError as exc:
        raise RunFileError(f"{path}: the stored spec is invalid ({exc.problem})") from None


def _check_samples(path: Path, run: Run) -> None:
    """What every reader of a run relies on: samples at increasing finite times, ``q``, and one
    column per joint in the per-joint signals (``ee_pos``: x, y, z)."""
    t = run.t
    if not len(t) or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise RunFileError(f"{path}: t is not a non-empty increasing series of finite times")
    if "q" not in run.signals:
        raise RunFileError(f"{path}: the run has no signal 'q'")
    for name, values in run.signals.items():
        width = 3 if name == "ee_pos" else run.spec.n if name in JOINT_SIGNALS else None
        if width is not None and values.shape[1:] != (width,):
            raise RunFileError(f"{path}: signal {name!r} has shape {values.shape}; expected "
                               f"({len(t)}, {width})")


def _open(path: Path) -> np.lib.npyio.NpzFile:
    """``path`` opened by numpy, never unpickling; raises RunFileError unless it is a zip."""
    if not path.is_file():
        raise RunFileError(f"{path}: {'not a regular file' if path.exists() else 'no such run file'}")
    # checked first: numpy reads any other file as a pickle, and refuses in its own words
    if not zipfile.is_zipfile(path):
        raise _unreadable(path, "not an .npz archive")
    try:
        return np.load(path, allow_pickle=False)
    except _READ_ERRORS as exc:
        raise _unreadable(path, _why(exc)) from None


def _header(path: Path, data: np.lib.npyio.NpzFile) -> dict[str, Any]:
    """The JSON header of an opened run file, checked for its format."""
    try:
        header = json.loads(str(_array(path, data, "header", kinds="U")))
    except json.JSONDecodeError:
        raise _unreadable(path, "its header is not JSON") from None
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        found = header.get("format") if isinstance(header, dict) else None
        raise RunFileError(f"{path}: unknown run format {found!r}; expected {FORMAT}")
    if not isinstance(header.get("meta", {}), dict):
        raise RunFileError(f"{path}: the stored meta is not a mapping")
    return header


def _array(path: Path, data: np.lib.npyio.NpzFile, name: str, kinds: str = "biuf") -> np.ndarray:
    """Member ``name`` of an opened run file: an array of a dtype kind in ``kinds``."""
    if name not in data.files:
        raise _unreadable(path, f"no {name!r} array")
    try:
        _check_size(data, name)
        values = data[name]
    except _READ_ERRORS as exc:
        raise _unreadable(path, f"{name!r}: {_why(exc)}") from None
    # numpy hands back the raw bytes of a member that is not an .npy array (e.g. a pickle)
    if not isinstance(values, np.ndarray) or values.dtype.kind not in kinds:
        raise _unreadable(path, f"{name!r} is not a plain array")
    return values


def _check_size(data: np.lib.npyio.NpzFile, name: str) -> None:
    """Raise ValueError when member ``name`` declares more values than it holds (numpy would
    allocate what the header claims, e.g. 8 TB, before finding out)."""
    archive = data.zip
    assert archive is not None  # an open NpzFile
    if f"{name}.npy" not in archive.namelist():
        return  # a member that is no .npy: numpy hands back its bytes, which _array refuses
    info = archive.getinfo(f"{name}.npy")
    with archive.open(info) as member:
        major, _ = np.lib.format.read_magic(member)
        read = (np.lib.format.read_array_header_1_0 if major == 1
                else np.lib.format.read_array_header_2_0)
        shape, _, dtype = read(member)
    declared = math.prod(shape) * dtype.itemsize
    if declared > info.file_size:
        raise ValueError(f"it claims {declared:,} bytes of data in {info.file_size:,}")


_READ_ERRORS = (OSError, ValueError, zipfile.BadZipFile, EOFError, zlib.error, MemoryError)


def _unreadable(path: Path, reason: str) -> RunFileError:
    return RunFileError(f"{path}: not a readable maniplab run file ({reason})")


def _why(exc: BaseException) -> str:
    """maniplab's words for a read error (numpy's would suggest unpickling the file)."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    if isinstance(exc, ValueError):
        return "not an array numpy reads without unpickling"
    return "damaged or truncated archive"
