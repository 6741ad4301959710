"""MuJoCo's actuator callbacks, which are process-global: one lock, and a scope without them.

``mujoco.set_mjcb_act_dyn`` and ``set_mjcb_act_bias`` (and MuJoCo's other ``mjcb_*``) act on the
whole process, and MuJoCo calls them not only while stepping but also while compiling a model
(to compute its constants), when the Python bindings cannot hand them the model yet: a Python
callback installed at that moment makes the compilation fail. So:

- :func:`suspended` removes whatever is installed for a block (compiling a model) and restores it
  afterwards, also when the block raises;
- :func:`exclusive` is held by a plant whose Python actuators need the callbacks while it steps
  (the plant in C installs its own pair for the length of each call and restores the previous).

Both hold one process-wide re-entrant lock, so a model compiled or a plant stepped in one thread
never sees another thread's callbacks, while a plant may still step another one (or build a
model) from inside its own controller.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator

import mujoco

_LOCK = threading.RLock()


@contextlib.contextmanager
def exclusive() -> Iterator[None]:
    """Hold the process-wide lock of MuJoCo's callbacks for the block."""
    with _LOCK:
        yield


@contextlib.contextmanager
def suspended() -> Iterator[None]:
    """No actuator callbacks for the block (the previous ones are restored after it)."""
    with _LOCK:
        previous = (mujoco.get_mjcb_act_dyn(), mujoco.get_mjcb_act_bias())
        mujoco.set_mjcb_act_dyn(None)
        mujoco.set_mjcb_act_bias(None)
        try:
            yield
        finally:
            mujoco.set_mjcb_act_dyn(previous[0])
            mujoco.set_mjcb_act_bias(previous[1])
