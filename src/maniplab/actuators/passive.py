"""A passive joint: no actuator. It swings under gravity and the arm's motion, against the joint's
own friction and damping (its ``friction:`` section: viscous, Coulomb, stick/slip) and within its
limits: a grapple's rotator link, a hook on its rope.

A universal joint (a grapple's link swinging about two axes) is two passive rotational joints
whose axes cross, the first with a body of no length.
"""

from __future__ import annotations

from typing import ClassVar, Literal

import mujoco
import numpy as np

from maniplab.actuators.base import ActuatorPlugin, set_command_range
from maniplab.schema import validated


@validated
class PassiveJoint:
    """A joint without an actuator.

    Attributes:
        type: "passive".
    """

    EXAMPLE: ClassVar[str] = "type: passive"

    type: Literal["passive"] = "passive"


class Passive(ActuatorPlugin):
    """No force: the joint is free (its friction and limits act as on any joint). Controllers
    leave it to swing (:attr:`passive`): the cascade controls the actuated joints and the point
    the passive ones hang from, and reports their sway."""

    Params: ClassVar[type] = PassiveJoint
    command: ClassVar[str] = "u"
    passive: ClassVar[bool] = True
    params: PassiveJoint

    @property
    def command_limit(self) -> float | None:
        """None: there is no command (any is ignored)."""
        return None

    def holding_range(self, q: float) -> tuple[float, float]:
        """(0, 0): it holds no load."""
        return 0.0, 0.0

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        """0."""
        return 0.0

    def forces(self, x: np.ndarray, u: np.ndarray, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Zeros, (N,)."""
        return np.zeros(len(np.atleast_1d(q)))

    def configure_mjcf(self, act: mujoco.MjsActuator) -> None:
        """MuJoCo's motor with zero gain: the joint keeps an actuator slot (the arm's commands
        stay one per joint) that applies nothing in any MuJoCo tool."""
        act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        act.gainprm = [0.0] * 10
        act.biastype = mujoco.mjtBias.mjBIAS_NONE
        set_command_range(act, None)

    def describe(self) -> str:
        """``passive``."""
        return "passive"
