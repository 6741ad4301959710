"""MuJoCo's actuator callbacks, which are process-global: maniplab's one dispatcher for them.

``mjcb_act_dyn`` and ``mjcb_act_bias`` (what ``mujoco.set_mjcb_act_dyn`` and ``set_mjcb_act_bias``
set) act on the whole process. maniplab's native library installs one dispatcher pair for the
process and never removes it (``ml_mjcb_install`` in ``maniplab_native/plant.c``):

- a call made while a thread steps a plant with Python actuators, for that plant's model, goes to
  that plant's actuators (each thread dispatches to its own plant: no lock, no swapping of
  globals, so plants in several threads run in parallel);
- any other model is left as MuJoCo would: the callback installed before the dispatcher (the
  user's, as ``mujoco.set_mjcb_act_*`` set it) is called, or without one the call answers 0, as
  MuJoCo does without callbacks (act_dot 0, bias 0);
- if user code replaces the dispatcher later, the next call or MuJoCo step of a plant with Python
  actuators installs it again, chaining to the new callback (``mujoco.get_mjcb_act_dyn`` keeps
  returning what the user set).

MuJoCo also calls the callbacks while compiling a model (to compute its constants), when the
Python bindings cannot hand a Python callback the model yet: :func:`suspended` keeps any chained
callback away from the models the calling thread compiles meanwhile.
"""

from __future__ import annotations

import contextlib
import ctypes
from collections.abc import Iterator

from maniplab.clib import Functions

_C = Functions({
    "ml_mjcb_install": (None, []),
    "ml_mjcb_suspend": (ctypes.c_int, [ctypes.c_int]),
})


def install() -> None:
    """Install the dispatcher unless it is installed, chaining to the callbacks installed now.

    Raises:
        ModelError: maniplab's native library could not be built (one line).
    """
    _C().ml_mjcb_install()


@contextlib.contextmanager
def suspended() -> Iterator[None]:
    """For the block, in this thread only: no chained (user's) callback is called; the model of
    a plant this thread steps still gets its own Python actuators, any other one MuJoCo's answer
    without callbacks.

    Nothing is removed: other threads' models keep being served by the user's callbacks.
    """
    install()
    lib = _C()
    previous = lib.ml_mjcb_suspend(1)
    try:
        yield
    finally:
        lib.ml_mjcb_suspend(previous)
