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
import struct
import zipfile
import zlib
from collections.abc import Iterable, Iterator
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from maniplab.atomic import atomic_path
from maniplab.errors import ManiplabError, SpecError
from maniplab.sim.energy import SIGNALS as ENERGY_SIGNALS
from maniplab.sim.energy import SUPPLY_INTEGRAL
from maniplab.spec import ManipulatorSpec

if TYPE_CHECKING:
    from maniplab.sim.run import Run

FORMAT = "maniplab-run/1"

R = TypeVar("R", bound="Run")

#: Signals with one column per joint.
JOINT_SIGNALS = frozenset({"q", "qd", "tau_act", "tau_fric", "tau_limit", "ctrl", "iv", "dP", "Q",
                           "mode", *ENERGY_SIGNALS, SUPPLY_INTEGRAL})


class RunFileError(ManiplabError):
    """A stored run cannot be read (missing, truncated, corrupt or from an unknown format)."""


class ContentHash:
    """The SHA-256 content hash of a run file, fed in its order: the header without its hash
    entry, then the time vector and the signals sorted by name (:meth:`array`, each once).

    Args:
        header: the header (its ``hash`` entry, if any, is left out).
    """

    def __init__(self, header: dict[str, Any]) -> None:
        self.digest = hashlib.sha256()
        body = {k: v for k, v in header.items() if k != "hash"}
        self.digest.update(json.dumps(body, sort_keys=True).encode())

    def array(self, name: str, dtype: np.dtype, shape: tuple[int, ...],
              chunks: Iterable[Any]) -> None:
        """Add array ``name``: its dtype, shape and data, given as consecutive byte chunks (any
        buffers: bytes, contiguous numpy arrays)."""
        self.digest.update(f"{name}|{dtype.str}|{tuple(shape)}|".encode())
        for chunk in chunks:
            self.digest.update(chunk)

    def hexdigest(self) -> str:
        return self.digest.hexdigest()


def content_hash(t: np.ndarray, signals: dict[str, np.ndarray], header: dict[str, Any]) -> str:
    """SHA-256 (hex) over the time vector, every signal (name, dtype, shape, bytes) and the header
    without its hash entry (the arrays are hashed in place, not copied)."""
    digest = ContentHash(header)
    for name, values in [("t", t), *sorted(signals.items())]:
        values = np.ascontiguousarray(values)
        digest.array(name, values.dtype, values.shape, [values.reshape(-1).view(np.uint8)])
    return digest.hexdigest()


def header_body(spec: ManipulatorSpec, meta: dict[str, Any], units: dict[str, str]) -> dict[str, Any]:
    """The JSON header of a run file without its hash (format, spec, meta, units, versions)."""
    return {
        "format": FORMAT,
        "spec": spec.to_dict(),
        "meta": dict(meta),
        "units": units,
        "versions": {"maniplab": _version("maniplab"), "mujoco": _version("mujoco")},
    }


def header_of(run: Run) -> dict[str, Any]:
    """The JSON header stored with ``run`` (format, spec, meta, units, versions, hash)."""
    header = header_body(run.spec, dict(run.meta), run.units())
    header["hash"] = content_hash(np.asarray(run.t), dict(run.signals), header)
    return header


def _version(package: str) -> str:
    try:
        return version(package)
    except PackageNotFoundError:
        return "unknown"


def save(run: Run, path: Path, compress: bool = False) -> None:
    """Write ``run`` to ``path`` through a temporary file, so an interruption leaves no half file
    and an earlier file of that name stays intact until the new one is complete. ``compress``:
    deflate the arrays (a simulated run shrinks to about 0.4 of its size; such a file is read
    whole, never memory-mapped)."""
    arrays = {f"signal/{name}": np.asarray(values) for name, values in run.signals.items()}
    header = json.dumps(header_of(run))
    write = np.savez_compressed if compress else np.savez
    with atomic_path(path) as tmp, open(tmp, "wb") as handle:
        # allow_pickle is numpy's default, named so that no array is taken for the option
        write(handle, t=np.asarray(run.t), header=np.array(header), allow_pickle=True,
              **arrays)


def read_header(path: Path) -> dict[str, Any]:
    """Only the JSON header of a run file (cheap: the arrays are not read)."""
    with _open(path) as data:
        return _header(path, data)


def load(path: Path, cls: type[R], *, mmap: bool = False, verify: bool = True) -> R:
    """Read a run file as a ``cls`` (a Run) and check its content hash; raises RunFileError naming
    the file and what is wrong (missing, truncated, corrupt, unknown format, invalid spec, signals
    of the wrong length).

    Args:
        path: the run file.
        cls: the class of the run made.
        mmap: memory-map the arrays stored uncompressed (as maniplab writes them) instead of
            reading them: read-only arrays whose pages are read from the file when used.
        verify: check the content hash (False only for a file this process just wrote).
    """
    read = _mapped if mmap else _array
    with _open(path) as data:
        header = _header(path, data)
        t = read(path, data, "t")
        signals = {name.removeprefix("signal/"): read(path, data, name)
                   for name in data.files if name.startswith("signal/")}
    if verify and content_hash(t, signals, header) != header.get("hash"):
        raise RunFileError(f"{path}: content hash mismatch; the file is corrupt or was edited")
    spec = stored_spec(header, path)
    try:
        run = cls(t=t, signals=signals, spec=spec, meta=header.get("meta", {}))
    except ManiplabError as exc:  # e.g. a signal whose length is not t's
        raise RunFileError(f"{path}: {exc}") from None
    if verify:
        _check_samples(path, run)
    return run


def blocks(path: Path, name: str, rows: int = 1 << 16) -> Iterator[np.ndarray]:
    """Signal ``name`` (or ``"t"``) of a run file, ``rows`` samples at a time, read from the file
    (not mapped, nothing kept): a pass over a signal in bounded memory. The member's CRC is checked
    at its end, not the run's content hash.

    Raises:
        RunFileError: the file or the member cannot be read.
    """
    member = name if name == "t" else f"signal/{name}"
    try:
        with zipfile.ZipFile(path) as archive, archive.open(f"{member}.npy") as handle:
            major, _ = np.lib.format.read_magic(handle)
            read = (np.lib.format.read_array_header_1_0 if major == 1
                    else np.lib.format.read_array_header_2_0)
            shape, fortran, dtype = read(handle)
            if fortran or dtype.hasobject or not shape:
                raise ValueError("not a C-ordered plain array")
            row = dtype.itemsize * math.prod(shape[1:])
            for start in range(0, shape[0], rows):
                count = min(rows, shape[0] - start)
                data = handle.read(count * row)
                if len(data) != count * row:
                    raise EOFError
                yield np.frombuffer(data, dtype).reshape(count, *shape[1:])
    except KeyError:
        raise _unreadable(path, f"no {member!r} array") from None
    except _READ_ERRORS as exc:
        raise _unreadable(path, f"{member!r}: {_why(exc)}") from None


def stored_spec(header: dict[str, Any], path: Path) -> ManipulatorSpec:
    """The spec in a run file's ``header``; raises RunFileError naming ``path`` when invalid."""
    try:
        return ManipulatorSpec.from_dict(header.get("spec"), source=str(path), defer_plugins=True)
    except SpecError as exc:
        raise RunFileError(f"{path}: the stored spec is invalid ({exc.problem})") from None


def _check_samples(path: Path, run: Run) -> None:
    """What every reader of a run relies on: samples at increasing finite times, ``q``, and one
    column per joint in the per-joint signals (``ee_pos``: x, y, z)."""
    if not _increasing(run.t):
        raise RunFileError(f"{path}: t is not a non-empty increasing series of finite times")
    t = run.t
    if "q" not in run.signals:
        raise RunFileError(f"{path}: the run has no signal 'q'")
    for name, values in run.signals.items():
        width = 3 if name == "ee_pos" else run.spec.n if name in JOINT_SIGNALS else None
        if width is not None and values.shape[1:] != (width,):
            raise RunFileError(f"{path}: signal {name!r} has shape {values.shape}; expected "
                               f"({len(t)}, {width})")


def _increasing(t: np.ndarray, block: int = 1 << 20) -> bool:
    """Whether ``t`` is a non-empty increasing series of finite times (checked ``block`` samples
    at a time, so that a memory-mapped t is not copied whole)."""
    if not len(t):
        return False
    for start in range(0, len(t), block):
        part = t[start:start + block + 1]
        if not (np.all(np.isfinite(part)) and np.all(part[1:] > part[:-1])):
            return False
    return True


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


def _mapped(path: Path, data: np.lib.npyio.NpzFile, name: str, kinds: str = "biuf") -> np.ndarray:
    """Member ``name`` of an opened run file memory-mapped, read-only, when it is stored
    uncompressed (else read as :func:`_array` does)."""
    if name not in data.files:
        raise _unreadable(path, f"no {name!r} array")
    archive = data.zip
    assert archive is not None  # an open NpzFile
    entry = f"{name}.npy"
    if entry not in archive.namelist() or archive.getinfo(entry).compress_type != zipfile.ZIP_STORED:
        return _array(path, data, name, kinds)
    try:
        _check_size(data, name)
        offset, dtype, shape, fortran = _npy_at(path, archive.getinfo(entry))
        if dtype.kind not in kinds:
            raise _unreadable(path, f"{name!r} is not a plain array")
        if math.prod(shape) == 0:
            return np.empty(shape, dtype)
        mapped = np.memmap(path, dtype=dtype, mode="r", offset=offset, shape=shape,
                           order="F" if fortran else "C")
    except _READ_ERRORS as exc:
        raise _unreadable(path, f"{name!r}: {_why(exc)}") from None
    return np.asarray(mapped)  # a plain read-only ndarray on the map (kept open by it)


def _npy_at(path: Path, info: zipfile.ZipInfo) -> tuple[int, np.dtype, tuple[int, ...], bool]:
    """(offset of the data in the file, dtype, shape, Fortran order) of a stored .npy member."""
    with open(path, "rb") as handle:
        handle.seek(info.header_offset)
        local = handle.read(30)
        if len(local) != 30 or local[:4] != b"PK\x03\x04":
            raise ValueError("bad local header")
        name_length, extra_length = struct.unpack("<HH", local[26:30])
        handle.seek(info.header_offset + 30 + name_length + extra_length)
        major, _ = np.lib.format.read_magic(handle)
        read = (np.lib.format.read_array_header_1_0 if major == 1
                else np.lib.format.read_array_header_2_0)
        shape, fortran, dtype = read(handle)
        return handle.tell(), dtype, shape, fortran


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
