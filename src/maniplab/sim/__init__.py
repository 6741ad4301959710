"""Simulation: the plant (MuJoCo model + actuators), inputs, runs and their storage."""

from maniplab.sim import signals
from maniplab.sim.errors import InputError, InstabilityError, PluginError, SimulationError
from maniplab.sim.plant import Plant
from maniplab.sim.run import UNITS, Run, RunFileError
from maniplab.sim.simulate import simulate
from maniplab.sim.state import PlantState

__all__ = [
    "UNITS",
    "InputError",
    "InstabilityError",
    "Plant",
    "PlantState",
    "PluginError",
    "Run",
    "RunFileError",
    "SimulationError",
    "signals",
    "simulate",
]
