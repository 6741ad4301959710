"""Atomic file output: write to a temporary file beside the target, then rename it.

An interrupted write (an error, Ctrl-C, a full disk) leaves no half file, and an earlier file of
the same name stays intact until the new one is complete.

The target:

- a symbolic link is written through: the temporary file goes beside the file the link finally
  points to and is renamed onto that file, so the link stays a link. A dangling link is written
  to where it points when that folder exists (else an error); a missing folder of a path that is
  not a link is created.
- an existing target that is not a regular file (a device such as /dev/null, a fifo, a folder, a
  socket) is refused with an :class:`OutputError`, never replaced.
- an OSError while writing or renaming names the path the caller gave, never the temporary file.

Temporary files are hidden, ``.{stem}.XXXXXXXX.tmp{suffix}`` (:func:`is_temporary` lets listings
skip them), and their writer holds an exclusive ``flock`` on them until the rename. A writer
killed mid-save (SIGKILL, a power cut) leaves its temporary file behind; the next write of the
same target deletes such leftovers when they are stale: nobody holds their lock *and* they have
not changed for :data:`STALE_AFTER` seconds. Both, so that a live writer in another process never
loses its file: the lock covers a writer that is slow to start writing, the age a tool that
recreated the file under the same name (the lock stays on the old one) or a file system without
locks.
"""

from __future__ import annotations

import contextlib
import fcntl
import glob
import os
import re
import stat
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from maniplab.errors import ManiplabError

STALE_AFTER = 600.0
"""Seconds without a change after which an unlocked temporary file is a leftover, s."""

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a fifo"), (stat.S_ISSOCK, "a socket"))


class OutputError(ManiplabError):
    """An output path maniplab refuses to write: it exists and is not a regular file."""


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path in the target's folder; on success it becomes the target.

    Args:
        path: the file to write (see the module's rules for links and folders).
        suffix: the temporary file's suffix (default ``path``'s, so tools that pick a format by
            suffix, such as ffmpeg or matplotlib, see the right one).

    A file replaced keeps its permissions; a new one gets the usual ones (0666 less the umask),
    not mkstemp's 0600.

    Raises:
        OutputError: ``path`` is (or links to) an existing non-regular file.
        OSError: naming ``path``, when the folder, the temporary file or the rename fails.
    """
    given = Path(path)
    target = _target(given)
    prefix, ending = f".{target.stem}.", f".tmp{given.suffix if suffix is None else suffix}"
    try:
        if not given.is_symlink():
            target.parent.mkdir(parents=True, exist_ok=True)
        _remove_stale(target.parent, prefix, ending)
        fd, name = tempfile.mkstemp(prefix=prefix, suffix=ending, dir=target.parent)
    except OSError as exc:
        raise _named(exc, given) from None
    tmp = Path(name)
    try:
        with contextlib.suppress(OSError):  # a file system without locks: the age rule remains
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        yield tmp
        os.chmod(tmp, _mode(target))
        os.replace(tmp, target)
    except OSError as exc:
        if exc.filename not in (None, name, tmp):
            raise  # about another file the caller touched, not the output
        raise _named(exc, given, name) from None
    finally:
        tmp.unlink(missing_ok=True)
        os.close(fd)


def write_text(path: str | os.PathLike[str], text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def check_target(path: str | os.PathLike[str]) -> Path:
    """The file a write to ``path`` would replace (links resolved), checked before any work.

    Raises:
        OutputError: ``path`` is (or links to) an existing non-regular file.
        OSError: naming ``path``, when it cannot be examined (a component that is a file...).
    """
    return _target(Path(path))


def is_temporary(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is named like a temporary file of :func:`atomic_path` (hidden, ``.tmp``)."""
    name = Path(path).name
    return name.startswith(".") and ".tmp" in name


def _target(given: Path) -> Path:
    """The file a write to ``given`` replaces: ``given`` with every symbolic link resolved."""
    try:
        mode = os.stat(given).st_mode  # through the links, /dev/stdout's to a pipe too
    except FileNotFoundError:
        return Path(os.path.realpath(given))  # a new file, or where a dangling link points
    except OSError as exc:  # e.g. a component that is a file, a loop of links
        raise _named(exc, given) from None
    if not stat.S_ISREG(mode):
        kind = next((name for test, name in _KINDS if test(mode)), "a special file")
        raise OutputError(f"{given}: {kind}, not a regular file; refusing to replace it")
    return Path(os.path.realpath(given))


def _remove_stale(folder: Path, prefix: str, ending: str) -> None:
    """Delete leftover temporary files ``prefix*ending`` in ``folder`` (see the module's rule)."""
    now = time.time()
    ours = re.compile(re.escape(prefix) + r"[a-z0-9_]{8}" + re.escape(ending))  # mkstemp's names
    for candidate in folder.glob(glob.escape(prefix) + "*" + glob.escape(ending)):
        if not ours.fullmatch(candidate.name):
            continue  # a user's own hidden file of a similar name
        with contextlib.suppress(OSError):  # gone meanwhile, or not ours to delete
            if now - candidate.lstat().st_mtime > STALE_AFTER:
                _remove_unlocked(candidate)


def _remove_unlocked(path: Path) -> None:
    """Delete ``path`` unless a writer holds its lock (then flock raises BlockingIOError)."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        os.unlink(path)
    finally:
        os.close(fd)


def _named(exc: OSError, given: Path, tmp: str | None = None) -> OSError:
    """``exc`` as an OSError of the same kind naming ``given`` (also in place of ``tmp`` in a
    message without an errno)."""
    text = exc.strerror or (str(exc).replace(tmp, str(given)) if tmp else str(exc))
    return OSError(exc.errno, text, str(given))


def _mode(target: Path) -> int:
    """The permission bits the written file gets: the replaced file's, else the usual ones."""
    try:
        return stat.S_IMODE(os.stat(target).st_mode)
    except FileNotFoundError:
        return 0o666 & ~_umask()


def _umask() -> int:
    mask = os.umask(0o022)  # the only way to read it is to set it; put it straight back
    os.umask(mask)
    return mask
