"""Actuators and joint friction: torque source, hydraulic valve-cylinder, hybrid friction, LuGre."""

from maniplab.actuators.modes import FrictionMode

__all__ = ["FrictionMode"]
