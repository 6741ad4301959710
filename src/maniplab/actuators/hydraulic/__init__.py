"""The valve-controlled hydraulic cylinder (the paper's eq. 4): its parameters, valve law, model,
native plant update and controller drive."""

from maniplab.actuators.hydraulic.bank import PRESSURE_LIMIT, HydraulicBank
from maniplab.actuators.hydraulic.cylinder import HydraulicCylinder
from maniplab.actuators.hydraulic.drive import PressureDrive, PressureLoop
from maniplab.actuators.hydraulic.params import HydraulicActuator
from maniplab.actuators.hydraulic.valve import valve_current, valve_flow

__all__ = [
    "PRESSURE_LIMIT",
    "HydraulicActuator",
    "HydraulicBank",
    "HydraulicCylinder",
    "PressureDrive",
    "PressureLoop",
    "valve_current",
    "valve_flow",
]
