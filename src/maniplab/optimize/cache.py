"""Evaluations cached on disk by the candidate's content: a resumed or extended study re-runs
nothing it has already evaluated.

The key is the SHA-256 of the candidate's resolved spec (its plain data, every default written
out) and the study's evaluation settings (metrics, statics, duty cycle, plugins): two candidates
that describe the same arm under the same evaluation share a key, however they were reached.
Each evaluation is one JSON file, written atomically as it arrives, so Ctrl-C loses at most the
evaluations still running.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

from maniplab.atomic import write_text

KEY_VERSION = 1
"""Changes when what an evaluation computes changes (old entries are then never matched)."""


def candidate_key(spec_data: Any, settings: dict[str, Any]) -> str:
    """The cache key of a candidate (its spec's plain data, or the base's and the overrides for a
    candidate the spec refuses) under a study's evaluation settings."""
    text = json.dumps({"v": KEY_VERSION, "spec": spec_data, "settings": settings},
                      sort_keys=True, default=repr, allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


class Cache:
    """A folder of evaluations, one ``<key>.json`` each."""

    def __init__(self, folder: str | os.PathLike[str]) -> None:
        self.folder = Path(folder)

    def __len__(self) -> int:
        return sum(1 for _ in self.folder.glob("*.json")) if self.folder.is_dir() else 0

    def get(self, key: str) -> dict[str, Any] | None:
        """The stored evaluation of ``key``, or None (also for a file that cannot be read: it is
        evaluated again)."""
        path = self.folder / f"{key}.json"
        try:
            record: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        return record if record.get("key") == key else None

    def put(self, record: dict[str, Any]) -> None:
        """Store an evaluation (its ``key`` names the file)."""
        self.folder.mkdir(parents=True, exist_ok=True)
        write_text(self.folder / f"{record['key']}.json", json.dumps(record, allow_nan=True))
