"""Run files: one .npz per run (numpy's zip of arrays, readable by any numpy, and by other tools
through the zip of .npy files), with the spec and the run's metadata as a JSON document inside."""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from maniplab.errors import SpecError
from maniplab.sim.run import Run, RunFileError
from maniplab.spec import ManipulatorSpec

FORMAT = "maniplab-run/1"


def save(run: Run, path: Path) -> None:
    """Write ``run`` to ``path`` through a temporary file, so an interruption leaves no half file."""
    arrays = {f"signal/{name}": np.asarray(values) for name, values in run.signals.items()}
    header = json.dumps({"format": FORMAT, "spec": run.spec.to_dict(), "meta": dict(run.meta)})
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            np.savez(handle, t=np.asarray(run.t), header=np.array(header), **arrays)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load(path: Path) -> Run:
    """Read a run file; raises RunFileError naming the file and what is wrong."""
    if not path.is_file():
        raise RunFileError(f"{path}: no such run file")
    try:
        with np.load(path, allow_pickle=False) as data:
            header = json.loads(str(data["header"]))
            t = data["t"]
            signals = {k.removeprefix("signal/"): data[k] for k in data.files if k.startswith("signal/")}
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError, json.JSONDecodeError) as exc:
        raise RunFileError(f"{path}: not a readable maniplab run file ({exc})") from None
    if header.get("format") != FORMAT:
        raise RunFileError(f"{path}: unknown run format {header.get('format')!r}; expected {FORMAT}")
    try:
        spec = ManipulatorSpec.from_dict(header["spec"], source=str(path))
    except SpecError as exc:
        raise RunFileError(f"{path}: the stored spec is invalid ({exc.problem})") from None
    return Run(t=t, signals=signals, spec=spec, meta=header.get("meta", {}))
