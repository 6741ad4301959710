"""Native groups: actuators the plant advances itself on its native route, without callbacks.

On the plant's native route (the default) every actuator class that declares a ``native`` group
is handled by one instance of it for all its joints; the others are integrated by MuJoCo through
the plant's callbacks. A group may change the plant's MuJoCo model before it is compiled (e.g. a
bias law, helper actuators) and acts before and after each MuJoCo step.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import mujoco

if TYPE_CHECKING:
    from maniplab.actuators.base import ActuatorPlugin


class NativeGroup:
    """The native form of all actuators of one class (the base does nothing: MuJoCo's actuator
    as :meth:`~maniplab.actuators.base.ActuatorPlugin.configure_mjcf` declares it is exact).

    Args:
        actuators: the actuators, one per joint.
        joints: their joint indices (= actuator ids, = dof indices), (k,).
        dt: the plant's step, s.
        integrator: the plant's ``mujoco.mjtIntegrator`` value.
    """

    def __init__(self, actuators: Sequence[ActuatorPlugin], joints: Sequence[int], *, dt: float,
                 integrator: int) -> None:
        self.actuators = list(actuators)
        self.joints = list(joints)
        self.dt = dt
        self.integrator = integrator

    def configure(self, s: mujoco.MjSpec) -> None:
        """Change the plant's model before it is compiled (actuator ``<joint name>`` drives each
        joint); added actuators must be appended, after the arm's."""

    def bind(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Find what the group needs in the compiled model (addresses, parameter views)."""

    def reset(self, data: mujoco.MjData) -> None:
        """After a reset or a state change: clear what the group keeps between steps."""

    def prepare(self, q: Sequence[float], act: Sequence[float], u: Sequence[float],
                ctrl: list[float]) -> None:
        """Before a step: set the step's forces. ``ctrl`` holds every actuator's control (the
        arm's first, ``u`` already written there); a group writes its helpers' entries."""

    def finish(self, q0: Sequence[float], q1: Sequence[float], act0: Sequence[float],
               u: Sequence[float], act1: list[float]) -> tuple[int, str] | None:
        """After a step: advance the group's states in ``act1`` from ``act0`` and the step's
        displacement q0 -> q1.

        Returns:
            None, or (joint index, problem) when a state left its sane range (the run is
            unstable).
        """
        return None
