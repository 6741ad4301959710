"""Python actuators in the plant: MuJoCo's act_dyn and act_bias callbacks answered in Python.

MuJoCo's actuator callbacks are process-global: maniplab's one dispatcher (:mod:`maniplab.mjcb`,
``maniplab_native/plant.c``) hands each call for a plant's model, made while a thread steps that
plant, to the plant's hooks. For the actuators written in Python (``user`` dynamics or bias) they
call back into Python through the ctypes hooks of :class:`PythonHooks`, which ask the actuator's
:meth:`~maniplab.actuators.ActuatorPlugin.derivatives` and
:meth:`~maniplab.actuators.ActuatorPlugin.force` (:class:`PluginCallbacks`). A hook that raises
stops the run after the step, and the plant raises that error (as a PluginError naming the
actuator and the joint). Plants in several threads step in parallel, each calling its own hooks
(which take the GIL for the Python call); plants without Python actuators run no Python at all.

Each callback costs a Python call (about 3 µs per actuator and RK4 stage): an arm with one Python
actuator steps several times slower than with maniplab's engine plugins alone (see the
benchmarks).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import mujoco
import numpy as np

from maniplab.sim import native
from maniplab.sim.errors import PluginError

__all__ = ["Integrated", "PluginCallbacks", "PythonHooks"]


class Integrated(Protocol):
    """What MuJoCo integrates through the callbacks: an actuator model (or LuGre's bristles)."""

    @property
    def states(self) -> tuple[str, ...]: ...

    def derivatives(self, x: np.ndarray, u: float, q: float, v: float) -> np.ndarray: ...

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float: ...


@dataclasses.dataclass(frozen=True)
class _Entry:
    plugin: Integrated
    joint: int      # qpos/qvel index of the joint (one dof per joint)
    name: str       # the joint's name
    adr: int        # first activation
    k: int          # number of activations


class PluginCallbacks:
    """The act_dyn and act_bias callbacks of one plant's Python actuators.

    Args:
        model, data: the plant's.
        actuators: (actuator id, model, joint index) for each Python actuator.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData,
                 actuators: Sequence[tuple[int, Integrated, int]]) -> None:
        self.model = model
        self.data = data
        self._entries = {
            i: _Entry(p, j, model.joint(j).name, int(model.actuator_actadr[i]),
                      int(model.actuator_actnum[i]))
            for i, p, j in actuators
        }

    def _entry(self, m: mujoco.MjModel, d: mujoco.MjData, i: int) -> _Entry | None:
        if m is not self.model or d is not self.data:
            return None
        return self._entries.get(i)

    def act_dyn(self, m: mujoco.MjModel, d: mujoco.MjData, i: int) -> float:
        """MuJoCo's mjcb_act_dyn: writes the states' derivatives (returns the one of a 1-state)."""
        e = self._entry(m, d, i)
        if e is None or e.k == 0:
            return 0.0
        x = d.act[e.adr:e.adr + e.k]
        try:
            xdot = np.asarray(e.plugin.derivatives(x, d.ctrl[i], d.qpos[e.joint], d.qvel[e.joint]),
                              dtype=float)
        except Exception as exc:
            raise self._failure(e, "derivatives", exc, d.time) from exc
        if xdot.shape != (e.k,):
            raise PluginError(
                f"{_name(e)}.derivatives returned shape {xdot.shape}; expected ({e.k},)")
        if e.k == 1:
            return float(xdot[0])
        d.act_dot[e.adr:e.adr + e.k] = xdot
        return 0.0

    def act_bias(self, m: mujoco.MjModel, d: mujoco.MjData, i: int) -> float:
        """MuJoCo's mjcb_act_bias: the plugin's force (the actuator's gain is zero)."""
        e = self._entry(m, d, i)
        if e is None:
            return 0.0
        x = d.act[e.adr:e.adr + e.k] if e.k else _EMPTY
        try:
            return float(e.plugin.force(x, d.ctrl[i], d.qpos[e.joint], d.qvel[e.joint]))
        except Exception as exc:
            raise self._failure(e, "force", exc, d.time) from exc

    @staticmethod
    def _failure(e: _Entry, method: str, exc: Exception, t: float) -> PluginError:
        return PluginError(
            f"actuator plugin {_name(e)} of joint {e.name} failed in {method}() at "
            f"t = {t:.6g} s: {type(exc).__name__}: {exc}"
        )


_EMPTY = np.zeros(0)


def _name(e: _Entry) -> str:
    cls = type(e.plugin)
    return f"{cls.__module__}:{cls.__qualname__}"


class PythonHooks:
    """The C plant's hooks into Python, as ctypes function pointers, and the first exception any
    of them raised (``error``; the run stops after the step in which it was raised).

    Args:
        callbacks: the plant's Python actuators, or None.
        check: a per-step check of the states that have no bounds, returning the joint with a
            bad state or -1; or None.
    """

    def __init__(self, callbacks: PluginCallbacks | None,
                 check: Callable[[], int] | None) -> None:
        self.error: BaseException | None = None
        self._callbacks = callbacks
        self._checker = check
        self.actuator = native.ACTUATOR(self._actuator) if callbacks else native.ACTUATOR()
        self.check = native.CHECK(self._check) if check else native.CHECK()

    def _actuator(self, kind: int, i: int, out: Any) -> int:
        cb = self._callbacks
        assert cb is not None
        try:
            out[0] = (cb.act_dyn if kind == 0 else cb.act_bias)(cb.model, cb.data, i)
            return 0
        except BaseException as exc:  # noqa: BLE001 - handed to the caller after the step
            self.error = self.error or exc
            return 1

    def _check(self) -> int:
        assert self._checker is not None
        try:
            return self._checker()
        except BaseException as exc:  # noqa: BLE001 - handed to the caller after the step
            self.error = self.error or exc
            return -2

    def raise_error(self) -> None:
        """Raise the stored error (once)."""
        error, self.error = self.error, None
        if error is not None:
            raise error
