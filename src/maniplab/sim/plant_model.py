"""The plant's MuJoCo model: the spec's arm (``mjcf_gen``) plus what the plant's scheme needs.

Changes to the arm's model, all made on the MjSpec before compiling:

- MuJoCo's own joint-limit constraints, contacts (the arm's geoms are drawing only) and its
  auto-reset on bad accelerations are disabled (the limit automaton holds joints at their limits;
  a NaN must reach the instability check); collision detection alone was 12 % of a step;
- viscous friction (``friction.viscous``, LuGre's σ2) becomes the joint's damping, so MuJoCo
  integrates it inside the step;
- a hydraulic actuator on the native route gets a fixed zero gain and an affine bias
  ``b0 - k q`` (k = A²E/V, b0 = A ΔP + k q at the step's start, set before every step; see
  :class:`~maniplab.actuators.hydraulic.HydraulicBank`); its user dynamics keep ΔP and Q in
  ``d.act`` untouched by MuJoCo's integrator. Each also gets an actuator ``<joint>/flow`` with
  integrator dynamics and the fixed gain A E/V: the plant sets its activation to zero and its
  control to the step's net oil flow into the cylinder (m³/s) before every step, so MuJoCo's RK4
  sees the flow's pressure rise as the ramp it is, A (E/V) ∫Q, in every stage. These follow
  all other actuators;
- an actuator on the callback route (plugins) gets one user activation per state, a zero gain
  and a user bias: MuJoCo integrates its states and asks for its force through the plant's
  callbacks (:mod:`maniplab.sim.callbacks`);
- each LuGre joint gets an extra actuator ``<joint>/lugre`` with one user activation, the bristle
  state z (``/`` cannot occur in a joint name, so the name is free); it has no force on the native
  route (the plant applies LuGre's force), and a user bias on the callback route.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco

from maniplab.actuators.hydraulic import HydraulicBank
from maniplab.mjcf_gen import build_mjspec
from maniplab.mjcf_gen.builder import compile_model
from maniplab.spec import FrictionModel, HydraulicActuator, ManipulatorSpec

LUGRE_SUFFIX = "/lugre"
"""Name of a LuGre joint's bristle-state actuator: ``<joint>/lugre``."""

FLOW_SUFFIX = "/flow"
"""Name of a native hydraulic joint's flow actuator: ``<joint>/flow``."""

_USER = mujoco.mjtDyn.mjDYN_USER


def build_plant_model(spec: ManipulatorSpec, *, dt: float, integrator: int,
                      native: Sequence[bool], states: Sequence[int],
                      lugre_integrated: bool = False) -> mujoco.MjModel:
    """Compile the plant's model of ``spec``.

    Args:
        spec: the arm.
        dt: time step, s.
        integrator: a ``mujoco.mjtIntegrator`` value.
        native: per joint, whether its actuator runs on the native route.
        states: per joint, the number of states of its actuator (callback route).
        lugre_integrated: LuGre's z is integrated by MuJoCo through callbacks (callback route).

    Returns:
        The model; actuator i < n drives joint i, LuGre state actuators follow, then the flow
        actuators of the native hydraulic joints (in joint order).
    """
    s = build_mjspec(spec)
    s.option.timestep = dt
    s.option.integrator = integrator
    s.option.disableflags |= (mujoco.mjtDisableBit.mjDSBL_LIMIT
                              | mujoco.mjtDisableBit.mjDSBL_CONTACT
                              | mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    actuators = {a.name: a for a in s.actuators}
    joints = {j.name: j for j in s.joints}
    for joint, is_native, k in zip(spec.joints, native, states):
        act = actuators[joint.name]
        if is_native and isinstance(joint.actuator, HydraulicActuator):
            _affine_cylinder(act, joint.actuator, dt)
        elif not is_native:
            _callback_actuator(act, k)
        if joint.friction.model is not FrictionModel.none:
            joints[joint.name].damping = [joint.friction.viscous, 0.0, 0.0]
        if joint.friction.model is FrictionModel.lugre:
            _add_bristles(s, joint.name, integrated=lugre_integrated)
    for joint, is_native in zip(spec.joints, native):
        if is_native and isinstance(joint.actuator, HydraulicActuator):
            _add_flow(s, joint.name, joint.actuator)
    return compile_model(s, spec)


def _affine_cylinder(act: mujoco.MjsActuator, cylinder: HydraulicActuator, dt: float) -> None:
    act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    act.gainprm = [0.0] * 10
    act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
    spring = float(HydraulicBank([cylinder], dt).spring[0])
    act.biasprm = [0.0, -spring] + [0.0] * 8


def _add_flow(s: mujoco.MjSpec, joint: str, cylinder: HydraulicActuator) -> None:
    """The cylinder's flow actuator: activation = oil volume let in since the step's start (m³),
    control = its rate (m³/s), force = A (E/V) × activation, the flow's pressure rise."""
    act = s.add_actuator(name=joint + FLOW_SUFFIX, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    act.dyntype = mujoco.mjtDyn.mjDYN_INTEGRATOR
    act.actlimited = mujoco.mjtLimited.mjLIMITED_FALSE
    act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    act.gainprm = [cylinder.area * cylinder.bulk_modulus / cylinder.volume] + [0.0] * 9
    act.biastype = mujoco.mjtBias.mjBIAS_NONE
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE


def _callback_actuator(act: mujoco.MjsActuator, k: int) -> None:
    act.dyntype = _USER if k else mujoco.mjtDyn.mjDYN_NONE
    act.actdim = k if k else -1
    act.actlimited = mujoco.mjtLimited.mjLIMITED_FALSE
    act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
    act.gainprm = [0.0] * 10
    act.biastype = mujoco.mjtBias.mjBIAS_USER


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
