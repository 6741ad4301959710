"""Your own controller named on the command line: ``--controller module:Factory`` or
``--controller path/to/file.py:Factory``.

The module is imported (or the file run) only because you named it, as ``--plugin`` does for
actuators; nothing in a spec or a run file names code that maniplab would run. The factory is
called as ``factory(spec, move) -> controller`` (:func:`~maniplab.control.move.run_move`).
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import sys
from pathlib import Path
from typing import Any

from maniplab.control.errors import ControlError


def load_factory(text: str) -> Any:
    """The callable ``text`` names: ``"package.module:Name"`` or ``"file.py:Name"``.

    Raises:
        ControlError: one line: not of that form, the module or file cannot be loaded, or it has
            no callable of that name.
    """
    where, sep, name = text.rpartition(":")
    if not sep or not where or not name.isidentifier():
        raise ControlError(f"--controller {text!r}: expected MODULE:NAME or FILE.py:NAME, e.g. "
                           "mypkg.control:SlidingMode or my_controller.py:SlidingMode")
    module = _from_file(Path(where)) if where.endswith(".py") else _import(where)
    factory = getattr(module, name, None)
    if not callable(factory):
        raise ControlError(f"--controller {text!r}: {where} has no callable {name!r}")
    return factory


def _import(module: str) -> Any:
    if not all(part.isidentifier() for part in module.split(".")):
        raise ControlError(f"--controller: {module!r} is not a module name (e.g. mypkg.control)")
    try:
        return importlib.import_module(module)
    except Exception as exc:  # noqa: BLE001 - any import failure, in one line
        raise ControlError(f"--controller: cannot import {module!r} "
                           f"({type(exc).__name__}: {exc})") from None


def _from_file(path: Path) -> Any:
    if not path.is_file():
        raise ControlError(f"--controller: {path}: no such file")
    # a name of its own per file, so that worker processes (pickling by reference) find it
    name = "maniplab_controller_" + hashlib.sha1(str(path.resolve()).encode()).hexdigest()[:12]
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ControlError(f"--controller: {path}: not a Python file")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except Exception as exc:  # noqa: BLE001 - any failure of the user's file, in one line
        del sys.modules[name]
        raise ControlError(f"--controller: {path} failed to load "
                           f"({type(exc).__name__}: {exc})") from None
    return module
