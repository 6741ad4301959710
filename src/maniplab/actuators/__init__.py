"""Actuators: the interface every joint actuator implements, the registry of actuator types, the
built-in torque source and hydraulic cylinder, and the drives controllers use.

Every actuator is an :class:`ActuatorPlugin`; users add their own by subclassing it and naming
the class in a spec (see :mod:`~maniplab.actuators.registry`).
"""

from maniplab.actuators.base import (
    ActuatorPlugin,
    Bound,
    CapabilityError,
    Jacobians,
    Steady,
    parameters,
)
from maniplab.actuators.drive import ForceDrive, StaticDrive
from maniplab.actuators.hydraulic import HydraulicActuator, HydraulicCylinder
from maniplab.actuators.registry import (
    ENTRY_POINT_GROUP,
    PluginLookupError,
    register,
    registered,
    resolve,
)
from maniplab.actuators.torque import TorqueActuator, TorqueSource

__all__ = [
    "ENTRY_POINT_GROUP",
    "ActuatorPlugin",
    "Bound",
    "CapabilityError",
    "ForceDrive",
    "HydraulicActuator",
    "HydraulicCylinder",
    "Jacobians",
    "PluginLookupError",
    "StaticDrive",
    "Steady",
    "TorqueActuator",
    "TorqueSource",
    "parameters",
    "register",
    "registered",
    "resolve",
]
