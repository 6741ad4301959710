"""Actuators and joint friction: torque source, hydraulic valve-cylinder, hybrid friction, LuGre.

Every actuator is an :class:`ActuatorPlugin` (see :mod:`~maniplab.actuators.plugin`); users add
their own by subclassing it and naming the class in a spec.
"""

from maniplab.actuators.hydraulic import HydraulicCylinder
from maniplab.actuators.modes import FrictionMode
from maniplab.actuators.plugin import (
    ENTRY_POINT_GROUP,
    ActuatorPlugin,
    PluginLookupError,
    parameters,
    register,
    registered,
    resolve,
)
from maniplab.actuators.torque import TorqueSource

__all__ = [
    "ENTRY_POINT_GROUP",
    "ActuatorPlugin",
    "FrictionMode",
    "HydraulicCylinder",
    "PluginLookupError",
    "TorqueSource",
    "parameters",
    "register",
    "registered",
    "resolve",
]
