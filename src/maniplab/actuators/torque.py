"""The ideal force/torque source: the command is the joint force."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, ClassVar, Literal

import mujoco
import numpy as np

from maniplab.actuators.base import ActuatorPlugin, Steady, set_command_range
from maniplab.actuators.drive import ForceDrive, ForceSourceDrive
from maniplab.schema import Positive, validated

if TYPE_CHECKING:
    from maniplab.spec import ControlSpec


@validated
class TorqueActuator:
    """An ideal force (prismatic) or torque (rotational) source: the command is the force.

    Attributes:
        type: "torque".
        limit: largest |force| in N or N·m, or None for no limit.
    """

    EXAMPLE: ClassVar[str] = "type: torque"

    type: Literal["torque"] = "torque"
    limit: Positive | None = None


class TorqueSource(ActuatorPlugin):
    """Ideal source: force = u (N on a prismatic joint, N·m on a rotational one), |u| <= limit.

    Stateless. In the MuJoCo model it is MuJoCo's own motor (gain 1, ``ctrlrange`` ±limit), which
    holds the force constant over each step, so MuJoCo alone drives it.
    """

    Params: ClassVar[type] = TorqueActuator
    command: ClassVar[str] = "tau"
    command_unit: ClassVar[str] = "N | N·m"
    params: TorqueActuator

    @property
    def command_limit(self) -> float | None:
        """The spec's ``limit`` (N or N·m), or None."""
        return self.params.limit

    def holding_range(self, q: float) -> tuple[float, float]:
        """±limit (unbounded without one)."""
        limit = math.inf if self.params.limit is None else self.params.limit
        return -limit, limit

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        """The command itself."""
        return float(u)

    def forces(self, x: np.ndarray, u: np.ndarray, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The commands, (N,)."""
        return np.asarray(u, dtype=float).copy()

    def steady(self, force: float, q: float, v: float) -> Steady:
        """The force itself is the command."""
        return Steady(np.zeros(0), force)

    @classmethod
    def drive(cls, actuators: Sequence[ActuatorPlugin], joints: Sequence[int], *, dt: float,
              settings: ControlSpec) -> ForceDrive:
        """The force itself, clipped (:class:`~maniplab.actuators.drive.ForceSourceDrive`, which
        the compiled cascade runs in C)."""
        return ForceSourceDrive(actuators, joints, dt=dt, settings=settings)

    def configure_mjcf(self, act: mujoco.MjsActuator) -> None:
        """MuJoCo's motor: gain 1, no bias, ``ctrlrange`` ±limit."""
        set_command_range(act, self.command_limit)

    def describe(self) -> str:
        """``torque |u|<=limit`` (``force`` on a prismatic joint)."""
        name = "force" if self.joint.prismatic else "torque"
        limit = self.params.limit
        return name + (f" |u|<={limit:g}" if limit else "")
