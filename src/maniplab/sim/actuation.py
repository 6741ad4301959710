"""The plant's actuators: command limits, native groups, and the ones MuJoCo integrates.

On the plant's native route every actuator class that declares a native group
(:class:`~maniplab.actuators.NativeGroup`) is handled by it; every other actuator (all of them on
the callback route) is integrated by MuJoCo: its states are user activations whose derivatives and
force the plant's MuJoCo callbacks ask of the model (:mod:`~maniplab.sim.callbacks`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco
import numpy as np

from maniplab.actuators import ActuatorPlugin, NativeGroup
from maniplab.actuators.plugin_mjcf import clear_plugin
from maniplab.spec import ManipulatorSpec, model_of

_USER = mujoco.mjtDyn.mjDYN_USER


class Actuation:
    """The actuators of an arm in the plant.

    Args:
        spec: the arm.
        native_route: use the actuators' native groups where they declare one.
        dt: the plant's step, s.
        integrator: the plant's ``mujoco.mjtIntegrator`` value.

    Attributes:
        models: the actuator model of each joint, (n,).
        limit: each joint's command limit (inf: none), list (n,).
        groups: the native groups.
        integrated: the joints whose actuator MuJoCo integrates through the callbacks.
    """

    def __init__(self, spec: ManipulatorSpec, *, native_route: bool, dt: float,
                 integrator: int) -> None:
        self.models: list[ActuatorPlugin] = [model_of(j) for j in spec.joints]
        self.n = len(self.models)
        self.limit = [math.inf if a.command_limit is None else float(a.command_limit)
                      for a in self.models]
        by_class: dict[type[NativeGroup], list[int]] = {}
        for j, a in enumerate(self.models):
            group = type(a).native if native_route else None
            if group is not None:
                by_class.setdefault(group, []).append(j)
        self.groups = [group([self.models[j] for j in joints], joints, dt=dt, integrator=integrator)
                       for group, joints in by_class.items()]
        native = {j for joints in by_class.values() for j in joints}
        self.integrated = [j for j in range(self.n) if j not in native]
        self._checked = [j for j in range(self.n) if self.models[j].states]
        self._limits: list[tuple[int, int, float]] = []  # (joint, state, limit), set in bind

    def configure(self, s: mujoco.MjSpec) -> None:
        """The plant's model edits: each integrated actuator gets one user activation per state,
        a zero gain and a user bias (its force comes from the callbacks); the groups edit theirs."""
        actuators = {a.name: a for a in s.actuators}
        for j in self.integrated:
            act, k = actuators[self.models[j].joint.name], len(self.models[j].states)
            clear_plugin(s, act)
            act.dyntype = _USER if k else mujoco.mjtDyn.mjDYN_NONE
            act.actdim = k if k else -1
            act.actlimited = mujoco.mjtLimited.mjLIMITED_FALSE
            act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
            act.gainprm = [0.0] * 10
            act.biastype = mujoco.mjtBias.mjBIAS_USER
        for group in self.groups:
            group.configure(s)

    def bind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """The states' addresses and limits in the compiled model; the groups find theirs."""
        self._adr = [int(a) for a in model.actuator_actadr[: self.n]]
        self._limits = [(j, self._adr[j] + i, lim) for j in self._checked
                        for i, lim in enumerate(self.models[j].state_limits() or ())]
        limited = {j for j, _, _ in self._limits}
        self._unlimited = [j for j in self._checked if j not in limited]
        for group in self.groups:
            group.bind(model, data)

    def reset(self, data: mujoco.MjData) -> None:
        """The actuators' initial states into ``data.act``."""
        for j, a in enumerate(self.models):
            k = len(a.states)
            if k:
                data.act[self._adr[j]:self._adr[j] + k] = a.initial_state()
        self.resync(data)

    def resync(self, data: mujoco.MjData) -> None:
        """After a state change: the groups clear what they keep between steps."""
        for group in self.groups:
            group.reset(data)

    def clip(self, u: Sequence[float]) -> list[float]:
        """Commands clipped to ±limit."""
        return [x if -lim <= x <= lim else (lim if x > 0.0 else -lim)
                for x, lim in zip(u, self.limit)]

    def prepare(self, q: list[float], act: list[float], u: list[float],
                ctrl: list[float]) -> None:
        """Before a step (``ctrl`` starts with ``u``): the groups set the step's forces."""
        for group in self.groups:
            group.prepare(q, act, u, ctrl)

    def finish(self, q0: list[float], q1: list[float], act0: list[float], u: list[float],
               act1: list[float]) -> tuple[int, str] | None:
        """After a step: the groups advance their states; then every state is checked.

        Returns:
            None, or (joint, problem) for the first actuator whose states left their sane range
            (every actuator with states is checked, whoever integrates it).
        """
        for group in self.groups:
            problem = group.finish(q0, q1, act0, u, act1)
            if problem is not None:
                return problem
        for j, i, lim in self._limits:
            if not -lim <= act1[i] <= lim:  # NaN too
                state = self.models[j].states[i - self._adr[j]]
                return j, self._problem(j, act1) or f"{state} = {act1[i]:.4g} is beyond ±{lim:.4g}"
        for j in self._unlimited:
            text = self._problem(j, act1)
            if text is not None:
                return j, text
        return None

    def _problem(self, j: int, act: list[float]) -> str | None:
        a, adr = self.models[j], self._adr[j]
        return a.check_state(np.asarray(act[adr:adr + len(a.states)]))

    def forces(self, q: np.ndarray, qd: np.ndarray, act: np.ndarray,
               ctrl: np.ndarray) -> np.ndarray:
        """Each actuator's force at N samples (arrays (N, n); act (N, na)), N or N·m, (N, n)."""
        tau = np.zeros_like(q)
        for j, a in enumerate(self.models):
            x = act[:, self._adr[j]:self._adr[j] + len(a.states)]
            tau[:, j] = a.forces(x, ctrl[:, j], q[:, j], qd[:, j])
        return tau
