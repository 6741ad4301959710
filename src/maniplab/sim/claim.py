"""How a run takes its controller: reset at the start, a copy of its own when another run holds it.

A controller is an object with state (integrators, filters, a held command, a log). Two rules
keep that state from leaking between runs, as a Simulink model's blocks start each simulation
from their initial conditions:

- **every run starts from a reset controller**: ``simulate`` calls ``controller.reset(state)``
  (or ``controller.reset()``) with the plant's state before the first sample;
- **one run at a time uses one object**: while a run in one thread holds a controller, a run in
  another thread gets a copy of it (``copy.deepcopy``; the cascade copies itself without
  recompiling its model), reset, so both runs are what each would be alone. A controller that
  cannot be copied is refused in one line.

A plain function (no ``reset``) is taken as it is: it has no state maniplab can see or copy.
"""

from __future__ import annotations

import contextlib
import copy
import inspect
import threading
import types
from collections.abc import Iterator
from typing import Any

from maniplab.sim.errors import InputError

_LOCK = threading.Lock()
_BUSY: set[int] = set()
"""``id`` of the controllers a run holds now (each alive while held: the run refers to it)."""


@contextlib.contextmanager
def claimed(controller: Any, state: Any) -> Iterator[Any]:
    """The controller a run uses, reset for the run.

    Args:
        controller: the run's controller, or None.
        state: the plant's state at the start (:class:`~maniplab.sim.state.PlantState`), given
            to ``reset`` when it takes an argument.

    Yields:
        ``controller`` itself, or (when another run holds it) a copy of it; None for None.

    Raises:
        InputError: the controller is in use by another run and cannot be copied.
    """
    if controller is None:
        yield None
        return
    key = id(controller)
    with _LOCK:
        mine = key not in _BUSY
        if mine:
            _BUSY.add(key)
    try:
        own = controller if mine else _copy(controller)
        _reset(own, state)
        yield own
    finally:
        if mine:
            with _LOCK:
                _BUSY.discard(key)


def _copy(controller: Any) -> Any:
    """An independent copy of a controller another run is using."""
    if isinstance(controller, (types.FunctionType, types.BuiltinFunctionType, types.MethodType,
                               types.BuiltinMethodType)):
        return controller
    try:
        return copy.deepcopy(controller)
    except Exception as exc:  # noqa: BLE001 - any failure to copy means: refuse, in one line
        name = type(controller).__qualname__
        raise InputError(
            f"controller {name} is used by another run at the same time and cannot be copied "
            f"({type(exc).__name__}: {exc}); give each thread its own controller") from None


def _reset(controller: Any, state: Any) -> None:
    """``controller.reset(state)``, or ``reset()`` when it takes no argument; nothing without."""
    reset = getattr(controller, "reset", None)
    if not callable(reset):
        return
    try:
        inspect.signature(reset).bind(state)
    except TypeError:
        reset()
    except ValueError:  # no signature to read (a builtin): call it as the interface says
        reset(state)
    else:
        reset(state)
