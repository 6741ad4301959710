"""The ideal force/torque source: the command is the joint force."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from maniplab.actuators.plugin import ActuatorPlugin
from maniplab.spec import TorqueActuator


class TorqueSource(ActuatorPlugin):
    """Ideal source: force = u (N on a prismatic joint, N·m on a rotational one), |u| <= limit.

    Stateless. On the plant's native route it is MuJoCo's own motor actuator (gain 1, the command
    written to ``ctrl``), so MuJoCo holds the force constant over each step.
    """

    Params: ClassVar[type] = TorqueActuator
    command: ClassVar[str] = "tau"
    command_unit: ClassVar[str] = "N | N·m"

    @property
    def command_limit(self) -> float | None:
        """The spec's ``limit`` (N or N·m), or None."""
        return self.params.limit

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        """The command itself."""
        return float(u)
