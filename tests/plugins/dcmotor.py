"""A DC motor with gearbox and current dynamics, written against maniplab's plugin interface only.

Armature circuit L di/dt = u - R i - K N q̇ (back-EMF of the motor shaft, which turns N times
faster than the joint); joint torque η N K i. State: the current i (A); command: the voltage u (V).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from maniplab.actuators import ActuatorPlugin, Steady, parameters
from maniplab.schema import Positive


@parameters
class DCMotorParams:
    """Motor and gearbox: R Ω, L H, K N·m/A (= V·s/rad), gear ratio N, efficiency η, voltage V."""

    resistance: Positive
    inductance: Positive
    torque_constant: Positive
    gear_ratio: Positive = 1.0
    efficiency: Positive = 1.0
    voltage_limit: Positive = 48.0


class GearedDCMotor(ActuatorPlugin):
    """DC motor behind a gearbox, driving a rotational joint."""

    Params: ClassVar[type] = DCMotorParams
    states: ClassVar[tuple[str, ...]] = ("current",)
    state_units: ClassVar[tuple[str, ...]] = ("A",)
    command: ClassVar[str] = "voltage"
    command_unit: ClassVar[str] = "V"

    @property
    def command_limit(self) -> float:
        return self.params.voltage_limit

    def derivatives(self, x: np.ndarray, u: float, q: float, v: float) -> np.ndarray:
        p = self.params
        return np.array([(u - p.resistance * x[0] - p.torque_constant * p.gear_ratio * v)
                         / p.inductance])

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        p = self.params
        return p.efficiency * p.gear_ratio * p.torque_constant * x[0]

    def steady(self, force: float, q: float, v: float) -> Steady:
        """The current that gives ``force`` and the voltage that holds it at speed v."""
        p = self.params
        current = force / (p.efficiency * p.gear_ratio * p.torque_constant)
        return Steady(np.array([current]), p.resistance * current
                      + p.torque_constant * p.gear_ratio * v)


class Faulty(GearedDCMotor):
    """A motor whose model raises after ``t > 0.05 s`` worth of current (to test error handling)."""

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        if x[0] > 1.0:
            raise ValueError("winding burnt")
        return super().force(x, u, q, v)


class Spring(ActuatorPlugin):
    """A stateless plugin: a torsion spring with its rest angle as the command."""

    @parameters
    class Params:
        stiffness: Positive

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        return self.params.stiffness * (u - q)
