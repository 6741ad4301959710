"""The plant's MuJoCo model: the spec's arm (``mjcf_gen``) plus what the plant's scheme needs.

Changes to the arm's model, all made on the MjSpec before compiling:

- MuJoCo's own joint-limit constraints, contacts (the arm's geoms are drawing only) and its
  auto-reset on bad accelerations are disabled (the limit automaton holds joints at their limits;
  a NaN must reach the instability check); collision detection alone was 12 % of a step;
- viscous friction (``friction.viscous``, LuGre's σ2) becomes the joint's damping, so MuJoCo
  integrates it inside the step;
- each LuGre joint gets an extra actuator ``<joint>/lugre`` with one user activation, the bristle
  state z (``/`` cannot occur in a joint name, so the name is free); it has no force when the
  plant advances z itself (the native route), and a user bias when MuJoCo integrates z through
  the plant's callbacks;
- then the actuators' edits (:meth:`maniplab.sim.actuation.Actuation.configure`): callback
  actuators, and the native groups' bias laws and helper actuators, which follow all others.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco

from maniplab.friction import FrictionModel
from maniplab.mjcf_gen import build_mjspec
from maniplab.mjcf_gen.builder import compile_model
from maniplab.sim.layout import LUGRE_SUFFIX
from maniplab.spec import ManipulatorSpec

_USER = mujoco.mjtDyn.mjDYN_USER


def build_plant_model(spec: ManipulatorSpec, *, dt: float, integrator: int,
                      lugre_integrated: bool,
                      configure: Callable[[mujoco.MjSpec], None]) -> mujoco.MjModel:
    """Compile the plant's model of ``spec``.

    Args:
        spec: the arm.
        dt: time step, s.
        integrator: a ``mujoco.mjtIntegrator`` value.
        lugre_integrated: LuGre's z is integrated by MuJoCo through callbacks (callback route).
        configure: the actuators' edits, applied last.

    Returns:
        The model; actuator i < n drives joint i, LuGre state actuators follow, then the
        actuators the native groups added.
    """
    s = build_mjspec(spec)
    s.option.timestep = dt
    s.option.integrator = integrator
    s.option.disableflags |= (mujoco.mjtDisableBit.mjDSBL_LIMIT
                              | mujoco.mjtDisableBit.mjDSBL_CONTACT
                              | mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    joints = {j.name: j for j in s.joints}
    for joint in spec.joints:
        joints[joint.name].damping = [joint.friction.damping, 0.0, 0.0]
        if joint.friction.model is FrictionModel.lugre:
            _add_bristles(s, joint.name, integrated=lugre_integrated)
    configure(s)
    return compile_model(s, spec)


def _add_bristles(s: mujoco.MjSpec, joint: str, *, integrated: bool) -> None:
    """The bristle state's actuator: no force of its own on the native route; on the callback
    route MuJoCo integrates z and takes the friction force from the callbacks."""
    act = s.add_actuator(name=joint + LUGRE_SUFFIX, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    act.dyntype = _USER
    act.actdim = 1
    act.actlimited = mujoco.mjtLimited.mjLIMITED_FALSE
    act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    act.gainprm = [0.0] * 10
    act.biastype = mujoco.mjtBias.mjBIAS_USER if integrated else mujoco.mjtBias.mjBIAS_NONE
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
