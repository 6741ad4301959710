"""The hydraulic actuators: the valve-controlled cylinder of the paper's eq. (4) (a lumped ΔP and a
constant lever, integrated by MuJoCo through the ``maniplab.hydraulic`` engine plugin) and the
pinned two-chamber cylinder (``maniplab.cylinder``): parameters, laws, models and drives."""

from maniplab.actuators.hydraulic.cylinder import PRESSURE_LIMIT, HydraulicCylinder
from maniplab.actuators.hydraulic.drive import PressureDrive, PressureLoop
from maniplab.actuators.hydraulic.params import HydraulicActuator
from maniplab.actuators.hydraulic.pinned import PinnedCylinder
from maniplab.actuators.hydraulic.valve import valve_current, valve_flow

# `type: hydraulic` with a `cylinder:` section is the pinned two-chamber cylinder
HydraulicCylinder.variants = (PinnedCylinder,)

__all__ = [
    "PRESSURE_LIMIT",
    "HydraulicActuator",
    "HydraulicCylinder",
    "PinnedCylinder",
    "PressureDrive",
    "PressureLoop",
    "valve_current",
    "valve_flow",
]
