"""Simulation: the plant (MuJoCo model + actuators), inputs, runs and their storage."""

from maniplab.sim.run import UNITS, Run, RunFileError

__all__ = ["UNITS", "Run", "RunFileError"]
