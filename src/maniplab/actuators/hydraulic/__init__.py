"""The valve-controlled hydraulic cylinder (the paper's eq. 4): its parameters, valve law, model
(integrated by MuJoCo through the ``maniplab.hydraulic`` engine plugin) and controller drive."""

from maniplab.actuators.hydraulic.cylinder import PRESSURE_LIMIT, HydraulicCylinder
from maniplab.actuators.hydraulic.drive import PressureDrive, PressureLoop
from maniplab.actuators.hydraulic.params import HydraulicActuator
from maniplab.actuators.hydraulic.valve import valve_current, valve_flow

__all__ = [
    "PRESSURE_LIMIT",
    "HydraulicActuator",
    "HydraulicCylinder",
    "PressureDrive",
    "PressureLoop",
    "valve_current",
    "valve_flow",
]
