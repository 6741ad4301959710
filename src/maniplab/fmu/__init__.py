"""The arm's plant as an FMU (FMI 2.0 co-simulation) for Simulink, OpenModelica, Dymola, FMPy.

``maniplab fmu SPEC -o arm.fmu`` (:func:`build_fmu`) compiles maniplab's plant in C (MuJoCo's
step with the friction/limit automaton and the hydraulic engine plugins) with the arm's settings
into a self-contained FMU: MuJoCo's library is inside, so the target needs no Python and no
maniplab. Inputs ``u.<joint>`` (valve current, force or torque), outputs ``q``, ``qd``, the
actuator states (``dP``, ``Q``, chamber pressures) and ``mode`` per joint, parameters ``payload``,
``viscous.<joint>``, ``leakage.<joint>``, ``supply_pressure.<joint>`` and ``q0.<joint>``.
"""

from __future__ import annotations

from maniplab.fmu.build import build_fmu
from maniplab.fmu.errors import FmuError

__all__ = ["FmuError", "build_fmu"]
