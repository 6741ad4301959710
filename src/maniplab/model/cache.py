"""On-disk cache of generated models: one folder per key, verified on every load.

Layout: ``<root>/<key>/`` holds the generated files and ``meta.json`` with the key, the inputs it
was hashed from, and the SHA-256 of every file. An entry is written in a temporary folder and
renamed into place in one step, so a reader never sees half an entry and two processes generating
the same model at once both succeed (the second rename loses and its copy is dropped). An entry
whose meta is unreadable, whose key or inputs differ, or whose file checksum does not match is
moved out of the way and regenerated, never used.

The root is ``$MANIPLAB_CACHE`` when set, else ``$XDG_CACHE_HOME/maniplab`` or
``~/.cache/maniplab``.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
import uuid
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from maniplab_native.build import cache_root

META = "meta.json"


def make_key(inputs: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the JSON of ``inputs`` (keys sorted): the entry's name."""
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def lookup(key: str, inputs: Mapping[str, Any], root: Path | None = None) -> Path | None:
    """The verified entry folder for ``key``, or None (missing, or bad and then discarded)."""
    folder = (root or cache_root()) / key
    if not folder.is_dir():
        return None
    if _valid(folder, key, inputs):
        return folder
    discard(folder)
    return None


def _valid(folder: Path, key: str, inputs: Mapping[str, Any]) -> bool:
    try:
        meta = json.loads((folder / META).read_text())
        if meta.get("key") != key or meta.get("inputs") != json.loads(json.dumps(inputs)):
            return False
        files = meta["files"]
        return bool(files) and all(_digest(folder / name) == digest for name, digest in files.items())
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return False


def discard(folder: Path) -> None:
    """Move a bad entry aside (atomically) and delete it; a concurrent discard is harmless."""
    trash = folder.with_name(f".trash-{folder.name}-{uuid.uuid4().hex[:8]}")
    try:
        os.rename(folder, trash)
    except OSError:
        return  # already gone (another process discarded or replaced it)
    shutil.rmtree(trash, ignore_errors=True)


def staging(root: Path | None = None) -> Path:
    """A fresh private folder in the cache root to write a new entry into."""
    base = root or cache_root()
    base.mkdir(parents=True, exist_ok=True)
    return Path(tempfile.mkdtemp(prefix=".tmp-", dir=base))


def commit(stage: Path, key: str, inputs: Mapping[str, Any], root: Path | None = None) -> Path:
    """Seal the files in ``stage`` (write meta with checksums) and rename it to the entry ``key``.

    Returns:
        The entry folder: ours, or the one another process committed first.
    """
    files = {p.name: _digest(p) for p in sorted(stage.iterdir()) if p.is_file() and p.name != META}
    meta = {"key": key, "inputs": inputs, "files": files}
    (stage / META).write_text(json.dumps(meta, indent=1, sort_keys=True))
    folder = (root or cache_root()) / key
    for _ in range(3):
        try:
            os.rename(stage, folder)
            return folder
        except OSError:
            # the entry exists: another process won the race, or a bad entry is in the way
            if _valid(folder, key, inputs):
                shutil.rmtree(stage, ignore_errors=True)
                return folder
            discard(folder)
    shutil.rmtree(stage, ignore_errors=True)
    raise OSError(f"could not write the cache entry {folder}")
