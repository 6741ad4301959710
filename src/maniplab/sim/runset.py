"""A folder of stored runs: listed, filtered by parameter, loaded lazily."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from maniplab.atomic import is_temporary
from maniplab.sim import params, store
from maniplab.sim.run import Run


@dataclasses.dataclass(frozen=True)
class Failure:
    """A variant that did not produce a run: its parameters and the one-line reason."""

    parameters: Mapping[str, Any]
    error: str


class RunSet:
    """Runs stored as ``.npz`` files (usually one folder), read on first use.

    Only the JSON headers are read to list and filter; a run's arrays are read when the run is
    taken (``runset[i]``, iteration). ``failures`` lists variants of a sweep that failed.

    Args:
        paths: a folder (every ``*.npz`` in it, sorted, but the hidden temporary files of a save
            in progress or killed, see :mod:`maniplab.atomic`) or a sequence of run files.
        failures: failed variants to carry along (from a sweep).
    """

    def __init__(self, paths: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
                 failures: Sequence[Failure] = ()) -> None:
        if isinstance(paths, (str, os.PathLike)):
            folder = Path(paths)
            self.paths = _run_files(folder) if folder.is_dir() else [folder]
        else:
            self.paths = [Path(p) for p in paths]
        self.failures = list(failures)
        self._headers: dict[Path, dict[str, Any]] = {}
        self._runs: dict[Path, Run] = {}

    def __len__(self) -> int:
        return len(self.paths)

    def __getitem__(self, index: int) -> Run:
        path = self.paths[index]
        if path not in self._runs:
            self._runs[path] = store.load(path, Run)
        return self._runs[path]

    def __iter__(self) -> Iterator[Run]:
        return (self[i] for i in range(len(self)))

    def header(self, index: int) -> dict[str, Any]:
        """The stored header of run ``index`` (spec, meta, units, versions), arrays not read."""
        path = self.paths[index]
        if path not in self._headers:
            self._headers[path] = store.read_header(path)
        return self._headers[path]

    def parameters(self, index: int) -> dict[str, Any]:
        """Flat parameters of run ``index``: spec values by override path, plus ``meta.*`` keys."""
        header = self.header(index)
        spec = store.stored_spec(header, self.paths[index])
        flat = params.flatten_spec(spec)
        flat.update({f"meta.{k}": v for k, v in header.get("meta", {}).items()
                     if k != "label" and isinstance(v, (str, int, float, bool))})
        return flat

    def differing(self) -> list[str]:
        """Parameters that are not the same in every run of the set."""
        return params.differing([self.parameters(i) for i in range(len(self))])

    def filter(self, predicate: Callable[[dict[str, Any]], bool] | None = None,
               **equal: Any) -> RunSet:
        """Runs whose parameters satisfy ``predicate`` and equal the given values.

        Keyword names use ``__`` for dots: ``filter(end_effector__mass=4000.0)``.
        """
        wanted = {k.replace("__", "."): v for k, v in equal.items()}
        keep = [p for i, p in enumerate(self.paths)
                if _matches(self.parameters(i), wanted, predicate)]
        return RunSet(keep)

    def table(self) -> str:
        """A text table: one row per run with its file, label and the differing parameters."""
        keys = self.differing()
        rows = [["file", *(params.short_key(k) for k in keys)]]
        for i, path in enumerate(self.paths):
            values = self.parameters(i)
            rows.append([path.name, *(params.format_value(values.get(k)) for k in keys)])
        widths = [max(len(r[c]) for r in rows) for c in range(len(rows[0]))]
        lines = ["  ".join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip() for row in rows]
        lines.insert(1, "  ".join("-" * w for w in widths))
        lines += [f"FAILED {params.format_parameters(f.parameters)}: {f.error}" for f in self.failures]
        return "\n".join(lines)


def _run_files(folder: Path) -> list[Path]:
    """The run files of ``folder``: regular files (a fifo would block the reader), not hidden
    temporary files."""
    return sorted(p for p in folder.glob("*.npz") if p.is_file() and not is_temporary(p))


def _matches(values: dict[str, Any], wanted: dict[str, Any],
             predicate: Callable[[dict[str, Any]], bool] | None) -> bool:
    if any(values.get(k) != v for k, v in wanted.items()):
        return False
    return predicate(values) if predicate else True
