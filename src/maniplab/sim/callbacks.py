"""MuJoCo actuator callbacks for plugin actuators, installed only while their plant steps.

MuJoCo's ``mjcb_act_dyn`` and ``mjcb_act_bias`` are process-global. A plant whose actuators run on
the callback route (plugins, or every actuator with ``Plant(..., route="callbacks")``) installs its
own pair, :class:`PluginCallbacks`, inside :func:`installed`; a plant without any keeps everyone
else's away from its user actuators inside :func:`suspended`, and models are compiled inside it
too. Both scopes (:mod:`maniplab.mjcb`, re-exported here) hold one process-wide re-entrant lock,
so plants in different threads take turns, while a plant may still step another one from inside
its own controller (the inner scope installs the inner plant's pair and gives the outer one
back); they restore whatever was installed before, also when the step raises.

The callbacks answer only for their own plant's model and data; for any other model they behave
as if no callback were installed (zero activation derivatives, zero user bias), so states of two
plants never mix. A plant on the native route uses no callbacks at all.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Protocol

import mujoco
import numpy as np

from maniplab.mjcb import installed, suspended
from maniplab.sim.errors import PluginError

__all__ = ["Integrated", "PluginCallbacks", "installed", "suspended"]


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
    """The act_dyn and act_bias callbacks of one plant's callback-route actuators.

    Args:
        model, data: the plant's.
        actuators: (actuator id, model, joint index) for each callback-route actuator.
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
