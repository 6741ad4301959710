"""MuJoCo's actuator callbacks, which are process-global: one lock and two scopes.

``mujoco.set_mjcb_act_dyn`` and ``set_mjcb_act_bias`` (and MuJoCo's other ``mjcb_*``) act on the
whole process, and MuJoCo calls them not only while stepping but also while compiling a model
(to compute its constants), when the Python bindings cannot hand them the model yet: a Python
callback installed at that moment makes the compilation fail. So:

- :func:`installed` puts a plant's pair in place for a block and restores the previous pair
  afterwards, also when the block raises;
- :func:`suspended` removes whatever is installed for a block (compiling a model, stepping a
  plant that has no callbacks of its own) and restores it afterwards.

Both hold one process-wide re-entrant lock, so a model compiled or a plant stepped in one thread
never sees another thread's callbacks, while a plant may still step another one (or build a
model) from inside its own controller: the inner scope changes the pair and gives the outer one
back. The plant's callbacks themselves are :class:`maniplab.sim.callbacks.PluginCallbacks`.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator
from typing import Any, Protocol

import mujoco

_LOCK = threading.RLock()


class ActuatorCallbacks(Protocol):
    """A pair of MuJoCo actuator callbacks, ``(model, data, actuator id) -> float``."""

    def act_dyn(self, m: Any, d: Any, i: int, /) -> float: ...

    def act_bias(self, m: Any, d: Any, i: int, /) -> float: ...


@contextlib.contextmanager
def installed(callbacks: ActuatorCallbacks) -> Iterator[None]:
    """Install ``callbacks`` as MuJoCo's act_dyn/act_bias for the block, then restore the
    previous ones."""
    with _LOCK:
        previous = (mujoco.get_mjcb_act_dyn(), mujoco.get_mjcb_act_bias())
        mujoco.set_mjcb_act_dyn(callbacks.act_dyn)
        mujoco.set_mjcb_act_bias(callbacks.act_bias)
        try:
            yield
        finally:
            mujoco.set_mjcb_act_dyn(previous[0])
            mujoco.set_mjcb_act_bias(previous[1])


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
