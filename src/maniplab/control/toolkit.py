"""What a controller of your own needs from the arm's actuators, for every actuator type.

:class:`ActuatorMaps` answers, per joint and through the actuator interface (so lumped and
pinned cylinders, torque joints and plugins alike):

- the command limits and the top speeds (the no-load joint speed at full command);
- the valve inversion: the command that makes each joint exert a force at a speed (the steady
  state of :meth:`~maniplab.actuators.ActuatorPlugin.steady`), vectorised over joints and samples;
- the torque ↔ pressure maps: the actuator states that hold a force at rest (ΔP of a lumped
  cylinder, pA and pB of a pinned one), and the force given states;
- for pinned cylinders, the moment arm r(q) and the chamber areas.

Each answer is an array over the joints, NaN where a joint's actuator has no such quantity.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from maniplab.actuators import ActuatorPlugin, CapabilityError
from maniplab.actuators.hydraulic.pinned import PinnedCylinder
from maniplab.builtin import resolve_spec
from maniplab.spec import model_of


class ActuatorMaps:
    """The actuators of an arm, as maps a controller computes with.

    Args:
        spec: the arm (a spec, a spec file or a built-in name).

    Attributes:
        spec: the arm.  n: its joints.
        actuators: each joint's actuator model.
    """

    def __init__(self, spec: Any) -> None:
        self.spec = resolve_spec(spec)
        self.n = self.spec.n
        self.actuators: list[ActuatorPlugin] = [model_of(j) for j in self.spec.joints]

    @property
    def command_limits(self) -> np.ndarray:
        """The largest command of each joint (its actuator clips at ±it): A of a valve, N or
        N·m of a torque joint; inf where unlimited, (n,)."""
        return np.array([math.inf if a.command_limit is None else a.command_limit
                         for a in self.actuators])

    @property
    def top_speeds(self) -> np.ndarray:
        """Each joint's speed at full command with no load, rad/s or m/s (inf: not limited),
        (n,)."""
        return np.array([a.top_speed for a in self.actuators])

    def commands(self, tau: Any, q: Any, qd: Any) -> np.ndarray:
        """The commands that make the joints exert ``tau`` steadily at (q, q̇): the valve
        inversion of the hydraulic joints (G2 of the paper), the force itself on torque joints.

        Args:
            tau: joint forces, N·m or N, (n,) or (K, n).
            q: joint positions, rad or m, same shape.
            qd: joint speeds, rad/s or m/s, same shape.

        Returns:
            Commands, the shape of ``tau``: ±inf where no command within the limit gives the
            force at that speed (the valve cannot pass the flow), NaN where the actuator
            declares no steady state.
        """
        return self._each(tau, q, qd, lambda a, f, x, v: a.steady(f, x, v).u)

    def holding_states(self, tau: Any, q: Any) -> dict[str, np.ndarray]:
        """The actuator states that hold ``tau`` at rest at q (torque → pressure): name (``dP``;
        ``pA``, ``pB``, ``spool``; a plugin's) -> values, the shape of ``tau`` (NaN at joints
        without that state)."""
        tau, q = np.broadcast_arrays(np.asarray(tau, dtype=float), np.asarray(q, dtype=float))
        names = sorted({s for a in self.actuators for s in a.states})
        out = {name: np.full(tau.shape, np.nan) for name in names}
        for index in np.ndindex(tau.shape):
            a = self.actuators[index[-1]]
            if not a.states:
                continue
            try:
                x = a.holding(float(tau[index]), float(q[index]))
            except CapabilityError:
                continue
            for name, value in zip(a.states, x):
                out[name][index] = value
        return out

    def forces(self, states: dict[str, Any], q: Any, qd: Any | None = None) -> np.ndarray:
        """The joint forces the actuators exert in ``states`` (pressure → torque), N·m or N.

        Args:
            states: name -> values (n,) or (K, n), as :meth:`holding_states` gives them (a
                joint whose states are missing or NaN gets NaN).
            q: joint positions, (n,) or (K, n).
            qd: joint speeds (default 0).
        """
        q = np.asarray(q, dtype=float)
        qd = np.zeros_like(q) if qd is None else np.asarray(qd, dtype=float)
        values = {k: np.broadcast_to(np.asarray(v, dtype=float), q.shape)
                  for k, v in states.items()}
        out = np.full(q.shape, np.nan)
        for index in np.ndindex(q.shape):
            a = self.actuators[index[-1]]
            if not a.states or any(s not in values for s in a.states):
                continue
            x = np.array([values[s][index] for s in a.states])
            if np.isfinite(x).all():
                out[index] = a.force(x, 0.0, float(q[index]), float(qd[index]))
        return out

    def moment_arms(self, q: Any) -> np.ndarray:
        """The moment arm r(q) of each pinned cylinder, m (joint torque = r × cylinder force,
        piston speed = r × joint speed); NaN at other joints; the shape of ``q``."""
        q = np.asarray(q, dtype=float)
        out = np.full(q.shape, np.nan)
        for j, a in enumerate(self.actuators):
            if isinstance(a, PinnedCylinder):
                out[..., j] = a.geometry.arm(q[..., j])
        return out

    @property
    def chamber_areas(self) -> np.ndarray:
        """The cap-side and rod-side areas of each pinned cylinder, m², (n, 2); NaN elsewhere."""
        out = np.full((self.n, 2), np.nan)
        for j, a in enumerate(self.actuators):
            if isinstance(a, PinnedCylinder):
                out[j] = a.params.cylinder.cap_area, a.params.cylinder.rod_area
        return out

    def _each(self, tau: Any, q: Any, qd: Any, one: Any) -> np.ndarray:
        tau, q, qd = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (tau, q, qd)))
        out = np.full(tau.shape, np.nan)
        for index in np.ndindex(tau.shape):
            try:
                out[index] = one(self.actuators[index[-1]], float(tau[index]), float(q[index]),
                                 float(qd[index]))
            except CapabilityError:
                continue
        return out
