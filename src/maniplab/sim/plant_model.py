"""The plant's MuJoCo model: the spec's arm (``mjcf_gen``) plus what the plant's scheme needs.

Changes to the arm's model, all made on the MjSpec before compiling:

- MuJoCo's own joint-limit constraints and dry friction (``frictionloss``, the exported file's
  stand-in for hybrid friction), contacts (the arm's geoms are drawing only) and its auto-reset
  on bad accelerations are disabled: the friction/limit automaton holds joints that stick or sit
  on their limits, and a NaN must reach the instability check; collision detection alone was 12 %
  of a step;
- viscous friction (``friction.viscous``, LuGre's σ2) is the joint's damping, as in the exported
  file, so MuJoCo integrates it inside the step.

The actuators are the arm's as the exported MJCF declares them: MuJoCo's motors, maniplab's engine
plugins (the hydraulic cylinders, LuGre's bristles ``<joint>/lugre``), and ``user`` actuators for
the ones written in Python.
"""

from __future__ import annotations

import mujoco

from maniplab.mjcf_gen import build_mjspec
from maniplab.mjcf_gen.builder import compile_model
from maniplab.spec import ManipulatorSpec


def build_plant_model(spec: ManipulatorSpec, *, dt: float, integrator: int) -> mujoco.MjModel:
    """Compile the plant's model of ``spec``.

    Args:
        spec: the arm.
        dt: MuJoCo's time step, s.
        integrator: a ``mujoco.mjtIntegrator`` value.

    Returns:
        The model; actuator i < n drives joint i, LuGre's bristle actuators follow.
    """
    return compile_model(plant_mjspec(spec, dt=dt, integrator=integrator), spec)


DISABLED = ("limit", "frictionloss", "contact", "autoreset")
"""MuJoCo features the plant turns off (the names of MJCF's ``<option><flag>`` attributes)."""


def plant_mjspec(spec: ManipulatorSpec, *, dt: float, integrator: int) -> mujoco.MjSpec:
    """The MjSpec that :func:`build_plant_model` compiles (the arguments are the same)."""
    s = build_mjspec(spec, timestep=dt)
    s.option.integrator = integrator
    for name in DISABLED:
        s.option.disableflags |= getattr(mujoco.mjtDisableBit, f"mjDSBL_{name.upper()}")
    return s
