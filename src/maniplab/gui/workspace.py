"""The GUI's workspace: the one folder the page may read and write.

Layout::

    WORKSPACE/
        runs/NAME.npz        every run, with its spec and parameters (maniplab's run files)
        specs/NAME.yaml      specs saved from the Configure tab
        exports/NAME.*       MJCF, analytic models and replays made for download

Everything the page sends is a *name*, never a path: a name is letters, digits, ``-``, ``_`` and
``.`` (not first), at most 64 characters, so no name reaches outside its folder. Every file is
written through a temporary file and renamed (:mod:`maniplab.atomic`): a run stopped, a browser
closed or a server killed mid-write leaves the earlier files whole and no half file.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from maniplab.atomic import atomic_path, is_temporary, write_text
from maniplab.errors import ManiplabError
from maniplab.sim.run import Run
from maniplab.spec import ManipulatorSpec
from maniplab.spec.yaml_io import dump_yaml

_NAME = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9_.-]{0,63}")
FOLDERS = ("runs", "specs", "exports")


class WorkspaceError(ManiplabError):
    """A name the page sent is not a valid file name, or names no stored file."""


class Workspace:
    """The folder of one GUI session (module docstring).

    Args:
        root: the folder (created when missing).
    """

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = Path(root).resolve()
        for folder in FOLDERS:
            (self.root / folder).mkdir(parents=True, exist_ok=True)

    def path(self, folder: str, name: str, suffix: str) -> Path:
        """The file ``name + suffix`` in ``folder``; raises WorkspaceError for a bad name."""
        if folder not in FOLDERS:
            raise WorkspaceError(f"unknown workspace folder '{folder}'")
        if not isinstance(name, str) or not _NAME.fullmatch(name):
            raise WorkspaceError(f"'{name}' is not a valid name: use letters, digits, '-', '_' "
                                 "and '.' (not first), at most 64")
        path = self.root / folder / f"{name}{suffix}"
        if path.parent != self.root / folder:  # belt and braces: the pattern allows no separator
            raise WorkspaceError(f"'{name}' leaves the workspace")
        return path

    # --- runs -----------------------------------------------------------------------------------

    def runs(self) -> list[str]:
        """Names of the stored runs, oldest first."""
        files = [p for p in (self.root / "runs").glob("*.npz") if not is_temporary(p)]
        return [p.stem for p in sorted(files, key=lambda p: (p.stat().st_mtime_ns, p.name))]

    def run_path(self, name: str) -> Path:
        """The file of the stored run ``name``; raises WorkspaceError when there is none."""
        path = self.path("runs", name, ".npz")
        if not path.is_file():
            raise WorkspaceError(f"no run named '{name}' in {self.root / 'runs'}")
        return path

    def load_run(self, name: str) -> Run:
        """The stored run ``name``."""
        return Run.load(self.run_path(name))

    def save_run(self, run: Run, name: str) -> str:
        """Store ``run`` under ``name`` (or ``name-2``, ``name-3``... when taken), compressed;
        returns the name used."""
        name = self.free_name(name)
        run.save(self.path("runs", name, ".npz"), compress=True)
        return name

    def free_name(self, name: str) -> str:
        """``name``, or the first of ``name-2``, ``name-3``... that no stored run has; raises
        WorkspaceError when that name is not valid (too long with its suffix)."""
        self.path("runs", name, ".npz")  # checks the name
        taken = set(self.runs())
        if name not in taken:
            return name
        free = next(f"{name}-{k}" for k in range(2, len(taken) + 3) if f"{name}-{k}" not in taken)
        try:
            self.path("runs", free, ".npz")
        except WorkspaceError:
            raise WorkspaceError(f"a run named '{name}' exists already, and '{free}' is too long: "
                                 "choose a shorter name") from None
        return free

    def rename_run(self, old: str, new: str) -> None:
        """Rename a stored run; refuses a name already taken."""
        source, target = self.run_path(old), self.path("runs", new, ".npz")
        if target.exists():
            raise WorkspaceError(f"a run named '{new}' exists already")
        os.rename(source, target)

    def delete_run(self, name: str) -> None:
        """Delete a stored run."""
        self.run_path(name).unlink()

    # --- specs and exports ----------------------------------------------------------------------

    def save_spec(self, spec: ManipulatorSpec, name: str) -> Path:
        """Write ``spec`` as ``specs/NAME.yaml`` (every default written out); returns the file."""
        return write_text(self.path("specs", name, ".yaml"), dump_yaml(spec.to_dict()))

    def export(self, name: str, suffix: str, content: str | bytes) -> Path:
        """Write a download into ``exports/``; returns the file."""
        path = self.path("exports", name, suffix)
        data = content.encode() if isinstance(content, str) else content
        with atomic_path(path) as tmp:
            tmp.write_bytes(data)
        return path
