"""The valve-controlled hydraulic cylinder of the paper's eq. (4).

States ΔP (differential pressure, Pa) and Q (valve flow, m³/s); command i_v (valve current, A):

    (V/E) dΔP/dt + Le ΔP + A v = Q                 (cylinder: compressibility, leakage, piston)
    Q + τ dQ/dt = i_v C sqrt(max(0, 1 - |ΔP|/Ps))  (valve: first-order lag, flow against load)

and the joint force is A ΔP (N, or N·m with A in m³/rad). :class:`HydraulicCylinder` is the
plugin form (one joint, derivatives for any integrator); :class:`HydraulicBank` is the plant's
native update of all hydraulic joints at once.

The native scheme (why and how accurate: see :class:`HydraulicBank`) keeps the stiff part, the
oil spring k = A²E/V between ΔP and the piston's motion, inside MuJoCo's RK4 step as an affine
actuator force ``b0 - k q`` plus the ramp of the flow's pressure rise, and advances the slow
parts (valve flow, leakage) between steps with exact exponential updates and a midpoint
correction, which makes it second order in dt.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from maniplab.actuators.plugin import ActuatorPlugin
from maniplab.spec import HydraulicActuator

PRESSURE_LIMIT = 10.0
"""A run whose |ΔP| exceeds this many times the supply pressure is declared unstable."""


class HydraulicCylinder(ActuatorPlugin):
    """Eq. (4) on one joint: states (ΔP, Q), command i_v clipped at ±current_limit."""

    Params: ClassVar[type] = HydraulicActuator
    states: ClassVar[tuple[str, ...]] = ("dP", "Q")
    state_units: ClassVar[tuple[str, ...]] = ("Pa", "m³/s")
    command: ClassVar[str] = "iv"
    command_unit: ClassVar[str] = "A"

    @property
    def command_limit(self) -> float:
        """``current_limit``, A."""
        return self.params.current_limit

    def valve_flow(self, dP: float, u: float) -> float:
        """Steady-state valve flow i_v C sqrt(max(0, 1 - |ΔP|/Ps)), m³/s."""
        p = self.params
        return u * p.valve_gain * np.sqrt(max(0.0, 1.0 - abs(dP) / p.supply_pressure))

    def derivatives(self, x: np.ndarray, u: float, q: float, v: float) -> np.ndarray:
        """(dΔP/dt, dQ/dt) of eq. (4), Pa/s and m³/s²."""
        p = self.params
        dP, Q = x[0], x[1]
        return np.array([
            p.bulk_modulus / p.volume * (Q - p.leakage * dP - p.area * v),
            (self.valve_flow(dP, u) - Q) / p.valve_tau,
        ])

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        """A ΔP, N or N·m."""
        return float(self.params.area * x[0])


def phi1(x: float) -> float:
    """(1 - e^-x) / x, with its limit 1 at x = 0 (x >= 0)."""
    return -math.expm1(-x) / x if x > 1e-12 else 1.0 - 0.5 * x


class HydraulicBank:
    """Native-route update of eq. (4) for h hydraulic joints (lists of length h).

    Per step of length dt, with q, ΔP, Q and i_v at the step's start:

    1. :meth:`prepare`: the valve target Q* = i_v C sqrt(1 - |ΔP|/Ps) and the flow volume over
       the step, ∫Q = Q* dt + (Q - Q*) τ (1 - e^(-dt/τ)) (exact for a constant target). MuJoCo then
       steps with the actuator force ``b0 - k q``, k = A²E/V, b0 = A ΔP + k q_n, plus the force
       A (E/V) r s of the flow's pressure rise a time s into the step, r = (∫Q - Le ΔP dt)/dt (the
       plant's ``<joint>/flow`` integrator actuator): in every RK4 stage the force is the
       cylinder's A ΔP at that instant, the oil spring following the piston and the flow's rise
       its ramp. (Applied as a constant, its mid-step value, the rise put the force at the step's
       start half a step's rise off, 300 N·m on the erector's moving q2, and made local position
       errors of c dt³/12m, c the rise per second: on the erector's stiff coupled modes 200 times
       RK4's own.)
    2. :meth:`finish`: ΔP' = e^(-λ dt) ΔP + (E/V) φ1(λ dt) (∫Q - A Δq), λ = Le E/V, with Δq the
       step's exact displacement; the valve target is then re-evaluated at the mid-step pressure
       (ΔP + ΔP')/2, ∫Q and ΔP' recomputed, and Q' = Q* + (Q - Q*) e^(-dt/τ).

    Measured on a 1-DOF lift against a Radau solution (tests/test_sim_hydraulic.py): relative
    errors 3.8e-4 (ΔP) and 6.5e-6 (position) at dt = 1e-3 s, 9.4e-5 and 1.6e-6 at 5e-4 s (second
    order).

    The arithmetic is plain Python over the joints: for the few joints of an arm it is about three
    times faster than numpy, whose cost per call (~0.5 µs) exceeds the work on six numbers.

    Args:
        cylinders: the joints' hydraulic parameters.
        dt: the plant's step, s.
        joints: each cylinder's joint index in the plant's lists (default 0..h-1).
        adrs: each cylinder's ΔP address in the plant's activation list; Q is the next one
            (default 0, 2, 4, ...).
    """

    def __init__(self, cylinders: Sequence[HydraulicActuator], dt: float,
                 joints: Sequence[int] | None = None, adrs: Sequence[int] | None = None) -> None:
        self.dt = dt
        self.lanes = [_Lane.of(c, dt) for c in cylinders]
        joints = range(len(cylinders)) if joints is None else joints
        adrs = range(0, 2 * len(cylinders), 2) if adrs is None else adrs
        # the arithmetic below, folded into as few constants per cylinder as it needs
        self._before = [
            (j, a, c.valve_gain, c.inv_supply, c.dt - c.valve_memory, c.valve_memory,
             c.area, c.leakage, 1.0 / c.dt, c.spring)
            for j, a, c in zip(joints, adrs, self.lanes)
        ]
        self._after = [
            (j, a, c.area, c.valve_gain, c.inv_supply, c.decay, c.gain, c.valve_decay,
             c.dt - c.valve_memory, c.valve_memory)
            for j, a, c in zip(joints, adrs, self.lanes)
        ]
        self._flow = [0.0] * len(cylinders)

    @property
    def spring(self) -> list[float]:
        """Oil spring k = A²E/V of each cylinder, N/m or N·m/rad."""
        return [lane.spring for lane in self.lanes]

    def prepare(self, q: Sequence[float], act: Sequence[float], u: Sequence[float],
                b0: list[float]) -> list[float]:
        """The cylinders' forces over the coming step: ``b0 - k q`` plus the flow's ramp.

        Args:
            q: joint positions (all joints), rad or m.
            act: activations (ΔP Pa, Q m³/s at the cylinders' addresses).
            u: clipped commands (valve currents A at the cylinders' joints).
            b0: written at the cylinders' joints: A ΔP + k q, N or N·m (the force at the step's
                start is then A ΔP, and the oil spring follows the piston).

        Returns:
            Each cylinder's mean net oil flow over the step, (∫Q - Le ΔP dt) / dt, m³/s: the
            flow's pressure rise a time s into the step is (E/V) × rate × s.
        """
        flows, rates = [], []
        for j, a, gain_v, inv_ps, rest, memory, area, leakage, per_dt, spring in self._before:
            p, f = act[a], act[a + 1]
            root = 1.0 - abs(p) * inv_ps
            target = u[j] * gain_v * math.sqrt(root) if root > 0.0 else 0.0
            flow = target * rest + f * memory  # ∫Q over the step
            flows.append(flow)
            rates.append(flow * per_dt - leakage * p)
            b0[j] = area * p + spring * q[j]
        self._flow = flows
        return rates

    def finish(self, q0: Sequence[float], q1: Sequence[float], act0: Sequence[float],
               u: Sequence[float], act1: list[float]) -> bool:
        """Write (ΔP, Q) at the step's end into ``act1``.

        Args:
            q0, q1: joint positions at the step's start and end (all joints), rad or m.
            act0: activations at the step's start (as given to :meth:`prepare`).
            u: the commands of the step.
            act1: activations to update.

        Returns:
            False if a pressure left ±PRESSURE_LIMIT × Ps (or is NaN): the run is unstable.
        """
        sane = True
        for (j, a, area, gain_v, inv_ps, decay, gain, valve_decay, rest, memory), flow in zip(
                self._after, self._flow):
            p, f = act0[a], act0[a + 1]
            swept = area * (q1[j] - q0[j])
            held = decay * p
            mid = 0.5 * (p + held + gain * (flow - swept))  # predicted mid-step ΔP
            root = 1.0 - abs(mid) * inv_ps
            target = u[j] * gain_v * math.sqrt(root) if root > 0.0 else 0.0
            p1 = held + gain * (target * rest + f * memory - swept)
            act1[a] = p1
            act1[a + 1] = target + (f - target) * valve_decay
            sane = sane and abs(p1) * inv_ps <= PRESSURE_LIMIT
        return sane


@dataclasses.dataclass(frozen=True)
class _Lane:
    """One cylinder's constants for a step dt."""

    area: float
    c: float            # E/V, Pa/m³
    leakage: float      # Le, m³/(s Pa)
    valve_gain: float
    inv_supply: float
    decay: float        # e^(-λ dt)
    gain: float         # (E/V) φ1(λ dt)
    valve_decay: float  # e^(-dt/τ)
    valve_memory: float # τ (1 - e^(-dt/τ))
    spring: float       # A² E/V
    dt: float

    @classmethod
    def of(cls, p: HydraulicActuator, dt: float) -> _Lane:
        c = p.bulk_modulus / p.volume
        lam = p.leakage * c
        return cls(
            area=p.area, c=c, leakage=p.leakage, valve_gain=p.valve_gain,
            inv_supply=1.0 / p.supply_pressure, decay=math.exp(-lam * dt),
            gain=c * phi1(lam * dt), valve_decay=math.exp(-dt / p.valve_tau),
            valve_memory=-p.valve_tau * math.expm1(-dt / p.valve_tau), spring=p.area**2 * c, dt=dt,
        )
