"""The plant's actuators: command limits, initial states, state bounds and the Python ones.

Every actuator is declared in the arm's MuJoCo model by its own model
(:meth:`~maniplab.actuators.ActuatorPlugin.configure_mjcf`,
:meth:`~maniplab.actuators.ActuatorPlugin.mujoco_plugin`): MuJoCo's motor for a torque source, an
instance of the engine plugin ``maniplab.hydraulic`` for a cylinder, so MuJoCo alone computes
them, with no Python per step. An actuator written in Python (one that declares neither) is a
``user`` actuator: MuJoCo integrates its states and asks its force through the act_dyn and
act_bias callbacks, which the plant in C installs while it steps and which call the actuator's
:meth:`~maniplab.actuators.ActuatorPlugin.derivatives` and
:meth:`~maniplab.actuators.ActuatorPlugin.force` (:mod:`maniplab.sim.callbacks`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco
import numpy as np

from maniplab.actuators import ActuatorPlugin
from maniplab.spec import ManipulatorSpec, model_of

_USER = (int(mujoco.mjtDyn.mjDYN_USER), int(mujoco.mjtGain.mjGAIN_USER),
         int(mujoco.mjtBias.mjBIAS_USER))


class Actuation:
    """The actuators of an arm in the plant.

    Args:
        spec: the arm.

    Attributes:
        models: the actuator model of each joint, (n,).
        limit: each joint's command limit (inf: none), list (n,).
        integrated: the joints whose actuator is written in Python (MuJoCo integrates it through
            the callbacks); set by :meth:`bind`.
        bounds: (joint, activation address, bound) of each state with a bound, set by
            :meth:`bind`.
        unbounded: the joints with states but no bounds (their ``check_state`` is called after
            every step), set by :meth:`bind`.
    """

    def __init__(self, spec: ManipulatorSpec) -> None:
        self.models: list[ActuatorPlugin] = [model_of(j) for j in spec.joints]
        self.n = len(self.models)
        self.limit = [math.inf if a.command_limit is None else float(a.command_limit)
                      for a in self.models]
        self.integrated: list[int] = []
        self.bounds: list[tuple[int, int, float]] = []
        self.unbounded: list[int] = []

    def bind(self, model: mujoco.MjModel) -> None:
        """The states' addresses and bounds in the compiled model, and which actuators are
        Python's (a ``user`` dynamics, gain or bias)."""
        self._adr = [int(a) for a in model.actuator_actadr[: self.n]]
        types = zip(model.actuator_dyntype, model.actuator_gaintype, model.actuator_biastype)
        self.integrated = [j for j, (dyn, gain, bias) in enumerate(types)
                           if j < self.n and (int(dyn) == _USER[0] or int(gain) == _USER[1]
                                              or int(bias) == _USER[2])]
        with_states = [j for j in range(self.n) if self.models[j].states]
        self.bounds = [(j, self._adr[j] + i, lim) for j in with_states
                       for i, lim in enumerate(self.models[j].state_limits() or ())
                       if not math.isinf(lim)]
        self.unbounded = [j for j in with_states if self.models[j].state_limits() is None]

    def reset(self, data: mujoco.MjData) -> None:
        """The actuators' initial states into ``data.act``."""
        for j, a in enumerate(self.models):
            k = len(a.states)
            if k:
                data.act[self._adr[j]:self._adr[j] + k] = a.initial_state()

    def clip(self, u: Sequence[float]) -> list[float]:
        """Commands clipped to ±limit."""
        return [x if -lim <= x <= lim else (lim if x > 0.0 else -lim)
                for x, lim in zip(u, self.limit)]

    def problem(self, j: int, act: np.ndarray, adr: int = -1) -> str:
        """What is wrong with joint j's states in ``act`` (na,): its ``check_state``, else the
        state at ``adr`` named with its bound."""
        a, start = self.models[j], self._adr[j]
        text = a.check_state(np.asarray(act[start:start + len(a.states)]))
        if text is not None or adr < 0:
            return text or f"the states of {a.label()} left their range"
        bound = next(lim for _, i, lim in self.bounds if i == adr)
        return f"{a.states[adr - start]} = {act[adr]:.4g} is beyond ±{bound:.4g}"

    def first_problem(self, act: np.ndarray) -> int:
        """The first joint among :attr:`unbounded` whose ``check_state`` finds a problem, or -1."""
        for j in self.unbounded:
            a, start = self.models[j], self._adr[j]
            if a.check_state(np.asarray(act[start:start + len(a.states)])) is not None:
                return j
        return -1

    def forces(self, q: np.ndarray, qd: np.ndarray, act: np.ndarray,
               ctrl: np.ndarray) -> np.ndarray:
        """Each actuator's force at N samples (arrays (N, n); act (N, na)), N or N·m, (N, n)."""
        tau = np.zeros_like(q)
        for j, a in enumerate(self.models):
            x = act[:, self._adr[j]:self._adr[j] + len(a.states)]
            tau[:, j] = a.forces(x, ctrl[:, j], q[:, j], qd[:, j])
        return tau

    def outputs(self, q: np.ndarray, act: np.ndarray) -> dict[str, np.ndarray]:
        """Each actuator's derived outputs at N samples (q (N, n), act (N, na)): name -> (N, n),
        NaN at joints without it."""
        out: dict[str, np.ndarray] = {}
        for j, a in enumerate(self.models):
            x = act[:, self._adr[j]:self._adr[j] + len(a.states)]
            for name, values in a.output_values(x, q[:, j]).items():
                out.setdefault(name, np.full(q.shape, np.nan))[:, j] = values
        return out
