"""A linear spring actuator that no test imports itself: tests load it by name only, to check
that a spec naming it resolves only once the module was named on purpose."""

from __future__ import annotations

import numpy as np

from maniplab.actuators import ActuatorPlugin, parameters
from maniplab.schema import Positive


class LinearSpring(ActuatorPlugin):
    """A torsion spring with its rest angle as the command: torque k (u - q), N·m."""

    @parameters
    class Params:
        stiffness: Positive

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        return self.params.stiffness * (u - q)
