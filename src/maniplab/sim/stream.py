"""Run files written while the run goes: each signal streamed in chunks into its member of the
``.npz``, the header and the zip's directory written when the run ends.

A run file is a zip of ``.npy`` members (:mod:`maniplab.sim.store`). Stored uncompressed, every
member has a size known before the run starts (samples × bytes per sample), so the writer lays
the file out at once: one region per signal, then ``t``. Each chunk of samples is written into
its place in every region (``os.pwrite``), the CRC-32 of each member kept up to date; at the end
the content hash is computed by reading the regions back in order, and the header member, the
members' local headers and the central directory (ZIP64 records where sizes or offsets need
them) complete the file. The file is any numpy's ``.npz``, read by ``Run.load`` as a saved run;
its arrays can be memory-mapped (``Run.load(path, mmap=True)``).

The writer writes a file it is given, a temporary one: the caller makes it the run file when the
run is complete (:func:`maniplab.atomic.atomic_path`), so an interrupted run leaves nothing.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
import os
import stat
import struct
import time
import zlib
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from maniplab.sim.store import ContentHash

ZIP64_AT = 0xFFFFFFFF
"""Sizes and offsets from which the zip needs its ZIP64 records (4 GiB; lowered by tests)."""

READ_BLOCK = 1 << 23
"""Bytes read at a time when hashing the written regions (8 MiB)."""

_LOCAL = struct.Struct("<IHHHHHIIIHH")
_CENTRAL = struct.Struct("<IHHHHHHIIIHHHHHII")
_END = struct.Struct("<IHHHHIIH")
_END64 = struct.Struct("<IQHHIIQQQQ")
_LOCATOR64 = struct.Struct("<IIQI")
_FULL, _FULL16 = 0xFFFFFFFF, 0xFFFF
_UNIX = 3 << 8


@dataclasses.dataclass
class _Member:
    """One ``.npy`` member of the file: its name, where it starts, its npy header and size."""

    name: str
    dtype: np.dtype
    shape: tuple[int, ...]
    offset: int = 0
    head: bytes = b""  # the npy header (the header member: all of it)
    crc: int = 0
    written: int = 0  # samples
    nbytes: int = 0  # bytes of array data after ``head``

    @property
    def entry(self) -> bytes:
        return f"{self.name}.npy".encode()

    @property
    def sample_bytes(self) -> int:
        return self.dtype.itemsize * math.prod(self.shape[1:])

    @property
    def size(self) -> int:
        """The member's bytes: npy header and data."""
        return len(self.head) + self.nbytes

    @property
    def zip64(self) -> bool:
        return self.size >= ZIP64_AT

    @property
    def data(self) -> int:
        """Offset of the member's array data in the file."""
        return self.offset + _LOCAL.size + len(self.entry) + (20 if self.zip64 else 0) + \
            len(self.head)


class RunWriter:
    """A run file being written: members laid out for ``rows`` samples of ``signals``.

    Args:
        path: the file to write (created or truncated; a temporary file the caller renames).
        signals: name -> (dtype, shape of one sample) of the run's signals, as
            :func:`maniplab.sim.recorder.layout` gives them.
        rows: the run's samples.
    """

    def __init__(self, path: Path, signals: Mapping[str, tuple[np.dtype, tuple[int, ...]]],
                 rows: int) -> None:
        self.path, self.rows = path, rows
        self.members = [_Member(f"signal/{name}", np.dtype(dtype), (rows, *shape))
                        for name, (dtype, shape) in signals.items()]
        self.members.append(_Member("t", np.dtype(float), (rows,)))
        offset = 0
        for m in self.members:
            m.head = _npy_header(m.dtype, m.shape)
            m.crc = zlib.crc32(m.head)
            m.offset, m.nbytes = offset, m.dtype.itemsize * math.prod(m.shape)
            offset = m.data + m.nbytes
        self.end = offset
        self.fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)

    @property
    def nbytes(self) -> int:
        """The bytes of the run's arrays (time and signals)."""
        return sum(m.nbytes for m in self.members)

    def put(self, t: np.ndarray, signals: Mapping[str, np.ndarray]) -> None:
        """Write the next samples: times ``t`` (m,), s, and each signal (m, ...) of the layout."""
        for m in self.members:
            values = t if m.name == "t" else signals[m.name.removeprefix("signal/")]
            if values.dtype != m.dtype or values.shape[1:] != m.shape[1:]:
                raise ValueError(f"{m.name}: got {values.dtype} {values.shape[1:]}, expected "
                                 f"{m.dtype} {m.shape[1:]}")
            if m.written + len(values) > self.rows:
                raise ValueError(f"{m.name}: more than {self.rows} samples")
            data = np.ascontiguousarray(values).reshape(-1).view(np.uint8).data
            _pwrite(self.fd, data, m.data + m.written * m.sample_bytes)
            m.crc = zlib.crc32(data, m.crc)
            m.written += len(values)

    def finish(self, header: dict[str, Any]) -> dict[str, Any]:
        """Complete the file: the content hash (the regions read back), the header member, the
        local headers and the central directory; returns the header with its hash.

        Args:
            header: the run's header without its hash (:func:`maniplab.sim.store.header_body`).

        Raises:
            ValueError: a signal is missing samples.
        """
        short = [m.name for m in self.members if m.written != self.rows]
        if short:
            raise ValueError(f"run file incomplete: {', '.join(short)} short of {self.rows} samples")
        digest = ContentHash(header)
        t = self.members[-1]
        for m in [t, *sorted(self.members[:-1], key=lambda m: m.name)]:
            digest.array(m.name.removeprefix("signal/"), m.dtype, m.shape, self._read(m))
        full = {**header, "hash": digest.hexdigest()}
        text = np.array(json.dumps(full))
        buffer = io.BytesIO()
        np.lib.format.write_array(buffer, text, allow_pickle=False)
        last = _Member("header", text.dtype, text.shape, offset=self.end)
        last.head, last.crc = buffer.getvalue(), zlib.crc32(buffer.getvalue())
        entries = [*self.members, last]
        stamp = _dos_time(time.localtime())
        _pwrite(self.fd, _local(last, stamp) + last.head, last.offset)
        for m in self.members:
            _pwrite(self.fd, _local(m, stamp) + m.head, m.offset)
        directory = b"".join(_central(m, stamp) for m in entries)
        start = last.offset + len(_local(last, stamp)) + len(last.head)
        _pwrite(self.fd, directory + _end(len(entries), len(directory), start), start)
        return full

    def close(self) -> None:
        """Close the file (written or not)."""
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1

    def _read(self, m: _Member) -> Iterator[bytes]:
        """Member ``m``'s array data, read back in blocks of at most READ_BLOCK bytes."""
        start, left = m.data, m.nbytes
        with open(self.path, "rb", buffering=0) as handle:
            while left:
                block = os.pread(handle.fileno(), min(READ_BLOCK, left), start)
                if not block:
                    raise OSError(f"{self.path}: shorter than written")
                start, left = start + len(block), left - len(block)
                yield block


def _npy_header(dtype: np.dtype, shape: tuple[int, ...]) -> bytes:
    """The ``.npy`` header of an array of ``dtype`` and ``shape`` (C order), as numpy writes it."""
    buffer = io.BytesIO()
    fields = {"descr": np.lib.format.dtype_to_descr(dtype), "fortran_order": False,
              "shape": shape}
    try:
        np.lib.format.write_array_header_1_0(buffer, fields)
    except ValueError:  # a header over 64 KiB: format 2.0
        buffer = io.BytesIO()
        np.lib.format.write_array_header_2_0(buffer, fields)
    return buffer.getvalue()


def _pwrite(fd: int, data: Any, offset: int) -> None:
    """Write all of ``data`` (a buffer) at ``offset`` of ``fd``."""
    view = memoryview(data).cast("B")
    while view:
        done = os.pwrite(fd, view, offset)
        view, offset = view[done:], offset + done


def _dos_time(now: time.struct_time) -> tuple[int, int]:
    """(time, date) in the zip's DOS format."""
    return ((now.tm_hour << 11) | (now.tm_min << 5) | (now.tm_sec // 2),
            ((max(now.tm_year, 1980) - 1980) << 9) | (now.tm_mon << 5) | now.tm_mday)


def _flags(m: _Member) -> int:
    """General purpose flags: bit 11 for a UTF-8 name."""
    return 0 if m.entry.isascii() else 0x800


def _local(m: _Member, stamp: tuple[int, int]) -> bytes:
    """Member ``m``'s local file header (stored, no data descriptor)."""
    extra = struct.pack("<HHQQ", 1, 16, m.size, m.size) if m.zip64 else b""
    size = _FULL if m.zip64 else m.size
    return _LOCAL.pack(0x04034B50, 45 if m.zip64 else 20, _flags(m), 0, *stamp, m.crc, size,
                       size, len(m.entry), len(extra)) + m.entry + extra


def _central(m: _Member, stamp: tuple[int, int]) -> bytes:
    """Member ``m``'s central directory entry."""
    big_offset = m.offset >= ZIP64_AT
    fields = [m.size, m.size] if m.zip64 else []
    fields += [m.offset] if big_offset else []
    extra = struct.pack(f"<HH{len(fields)}Q", 1, 8 * len(fields), *fields) if fields else b""
    version = 45 if extra else 20
    size = _FULL if m.zip64 else m.size
    mode = (stat.S_IFREG | 0o644) << 16
    return _CENTRAL.pack(0x02014B50, _UNIX | version, version, _flags(m), 0, *stamp, m.crc, size,
                         size, len(m.entry), len(extra), 0, 0, 0, mode,
                         _FULL if big_offset else m.offset) + m.entry + extra


def _end(count: int, size: int, start: int) -> bytes:
    """The end of central directory record, preceded by the ZIP64 ones when needed."""
    big = start >= ZIP64_AT or size >= ZIP64_AT or count >= _FULL16
    if not big:
        return _END.pack(0x06054B50, 0, 0, count, count, size, start, 0)
    end64 = _END64.pack(0x06064B50, _END64.size - 12, _UNIX | 45, 45, 0, 0, count, count, size,
                        start)
    locator = _LOCATOR64.pack(0x07064B50, 0, start + size, 1)
    return end64 + locator + _END.pack(0x06054B50, 0, 0, min(count, _FULL16),
                                       min(count, _FULL16), min(size, _FULL),
                                       min(start, _FULL), 0)
