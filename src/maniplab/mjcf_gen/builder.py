"""Construction of the MuJoCo model of a spec with MuJoCo's MjSpec API.

:func:`build_mjspec` is the one place the model is put together; :func:`build_model` compiles it and
:mod:`maniplab.mjcf_gen.writer` serialises it. The model follows eq. (1) of the paper:

- one body per spec joint, ``link_<joint>`` (see :mod:`~maniplab.mjcf_gen.names`), with the joint
  (hinge or slide, about or along the joint's base axis) at the body's origin; the next joint's body
  sits at ``length * direction`` of this one (at its origin when the joint has no body);
- the body's inertial frame is the spec's ``com`` with the spec's full inertia (kg·m², about the COG,
  base axes); all bodies keep the base orientation (identity quaternions);
- the end-effector is a fixed body ``end_effector`` (no joint) on the last link at
  ``length_n * direction_n + offset`` holding the payload: its mass at ``com`` from there, with
  its inertia (none by default: a point mass);
- one actuator per joint named after it, as the joint's actuator model declares it
  (:meth:`~maniplab.actuators.ActuatorPlugin.configure_mjcf`): MuJoCo's motor for a ``torque``
  joint; for a hydraulic one an instance of the engine plugin ``maniplab.hydraulic`` with its
  two activation states (ΔP, Q) and every parameter, which MuJoCo integrates itself, in the plant
  and in any MuJoCo tool (:mod:`maniplab_native`); for a pinned cylinder an instance of
  ``maniplab.cylinder`` (states pA, pB, spool) acting on a spatial tendon between sites at its
  pins, ``<joint>/cylinder``, which MuJoCo draws (with the spec's shared ``supply:``, each
  such instance gets the pump's flow limit ``pump_flow``);
- the joints' friction as plain MuJoCo can model it: the viscous part as the joint's
  ``damping``, hybrid stick/slip friction as MuJoCo's dry friction ``frictionloss`` at the
  Coulomb level (MuJoCo has no stiction above it), and the limits as MuJoCo's soft joint limits;
  maniplab's plant replaces the last two with its exact friction/limit automaton
  (:mod:`maniplab.sim.plant_model`);
- after the arm's actuators, for each joint with LuGre friction, an actuator ``<joint>/lugre`` that is an
  instance of the engine plugin ``maniplab.lugre``: its one activation is the bristle state z,
  its force the bristles' (σ2, the viscous part, is the joint's damping in the plant);
- a keyframe ``initial`` holding the actuators' initial states (a pinned cylinder's chambers at
  tank pressure), where the plant starts: MuJoCo's own reset sets every activation to zero.

Compiler choices, all written to the MJCF:

- ``angle="radian"`` (MjSpec's default is degrees, which would scale the ranges);
- ``inertiafromgeom="false"``: the inertia is the spec's, geoms are decoration;
- ``boundmass = boundinertia = 1e-12``: MuJoCo refuses moving bodies without mass and inertia, but
  the spec allows bodyless joints, massless bodies, slender rods and point masses (an inertia with a
  zero principal moment). MuJoCo lifts any mass or principal moment below the bound to it, an
  absolute perturbation of 1e-12 kg or kg·m² that is invisible at the 1e-9 relative cross-checks.
  Whether each joint still moves real mass is checked after compiling
  (:func:`maniplab.mjcf_gen.checks.check_drives_mass`).
- the ``RK4`` integrator (the hydraulic states are stiff and smooth) and the step the arm's
  actuators need, at most 1 ms (:mod:`~maniplab.mjcf_gen.timestep`).
"""

from __future__ import annotations

import functools
import os

import mujoco
import numpy as np

from maniplab.actuators.base import Mount
from maniplab.actuators.hydraulic.pinned import MUJOCO_PLUGIN as CYLINDER_PLUGIN
from maniplab.actuators.plugin_mjcf import EnginePlugin, activate_plugins, set_plugin
from maniplab.builtin import resolve_spec
from maniplab.friction import FrictionModel
from maniplab.mjcb import suspended
from maniplab.mjcf_gen import checks, names, visuals
from maniplab.mjcf_gen.accuracy import AccurateStep, accurate_step
from maniplab.mjcf_gen.timestep import DEFAULT, StepLimit, default_step, step_limit
from maniplab.spec import (
    Body,
    EndEffector,
    Joint,
    ManipulatorSpec,
    Supply,
    inertia_matrix,
    model_of,
)

MASS_BOUND = 1e-12
"""``compiler.boundmass`` and ``boundinertia``: kg and kg·m²."""

TIMESTEP = DEFAULT
"""Default ``option.timestep`` when the arm allows it, s."""

INTEGRATOR = mujoco.mjtIntegrator.mjINT_RK4
"""Default ``option.integrator``."""

_TRIANGLE_MARGIN = 1e-12  # relative; MuJoCo's own eigen-solver errs by ~1e-15

SpecLike = ManipulatorSpec | str | os.PathLike[str]


def build_mjspec(spec: SpecLike, timestep: float | None = None) -> mujoco.MjSpec:
    """The MuJoCo model of ``spec`` as an (uncompiled) MjSpec.

    Args:
        spec: a spec, a spec file or a built-in spec name.
        timestep: its ``option.timestep``, s; default: the step the plant derives for the arm
            (stability and accuracy, :mod:`~maniplab.mjcf_gen.accuracy`; measured once per arm).

    Returns:
        A fresh MjSpec; compile it with ``.compile()`` or use :func:`build_model`, which also checks it.

    Raises:
        SpecError: ``spec`` names no file or built-in, or the file is invalid.
    """
    spec = resolve_spec(spec)
    s = _arm(spec)
    s.option.timestep = timestep if timestep is not None else arm_accuracy(spec).dt
    return s


def arm_accuracy(spec: ManipulatorSpec) -> AccurateStep:
    """The step the arm's accuracy allows within its stability limit's default step
    (:func:`~maniplab.mjcf_gen.accuracy.accurate_step`, measured once per arm)."""
    return accurate_step(spec, default_step(arm_step_limit(spec)), _compiled_arm)


def _compiled_arm(spec: ManipulatorSpec) -> mujoco.MjModel:
    """The compiled MuJoCo model of ``spec``, not checked, its warnings kept quiet."""
    with suspended():
        return checks.compile_quietly(_arm(spec), spec)[0]


@functools.lru_cache(maxsize=64)
def arm_step_limit(spec: ManipulatorSpec) -> StepLimit:
    """The largest step ``spec``'s actuators allow (see :mod:`~maniplab.mjcf_gen.timestep`)."""
    with suspended():
        model, _ = checks.compile_quietly(_arm(spec), spec)  # compile_model shows warnings
    return step_limit(spec, model)


def _arm(spec: ManipulatorSpec) -> mujoco.MjSpec:
    """The MjSpec of ``spec`` with the default step."""
    s = mujoco.MjSpec()
    s.modelname = spec.name
    _configure(s, spec)
    scene = visuals.scene_of(spec)
    visuals.set_visual(s, scene)
    visuals.add_assets(s, scene)
    visuals.add_world(s, scene)
    parent, at = s.worldbody, np.zeros(3)
    mounts = []
    for index, joint in enumerate(spec.joints):
        body = _add_link(parent, joint, at)
        visuals.decorate_link(body, parent, joint, index, scene)
        mounts.append(Mount(s, parent, body, at))
        parent, at = body, joint.offset
    tip = _add_end_effector(parent, spec.end_effector, at)
    visuals.decorate_end_effector(tip, spec.end_effector, scene)
    for joint, mount in zip(spec.joints, mounts):
        _add_actuator(s, joint, mount)
    if spec.supply is not None:
        _share_supply(s, spec.supply)
    for joint in spec.joints:
        if joint.friction.model is FrictionModel.lugre:
            _add_bristles(s, joint)
    _add_initial_key(s, spec)
    activate_plugins(s)
    return s


def build_model(spec: SpecLike) -> mujoco.MjModel:
    """The compiled MuJoCo model of ``spec``, checked to be simulable.

    Args:
        spec: a spec, a spec file or a built-in spec name.

    Returns:
        The model; qpos, qvel and ctrl follow the spec's joint order.

    Raises:
        SpecError: ``spec`` names no file or built-in, or the file is invalid.
        ModelError: MuJoCo refuses the model, or a joint drives no mass or inertia, or two joints
            move the arm the same way (the message names the file and the joints).
    """
    spec = resolve_spec(spec)
    return compile_model(build_mjspec(spec), spec)


def compile_model(s: mujoco.MjSpec, spec: ManipulatorSpec) -> mujoco.MjModel:
    """Compile ``s``, the MjSpec of ``spec`` (possibly changed, as the plant's is), and check it.

    MuJoCo calls the process-global actuator callbacks while compiling, when Python ones cannot be
    handed the model yet; so none is called for it (:func:`maniplab.mjcb.suspended`, in this
    thread only: the callbacks installed stay in place).

    Raises:
        ModelError: as :func:`build_model`.
    """
    with suspended():
        return checks.compile_arm(s, spec)


def _configure(s: mujoco.MjSpec, spec: ManipulatorSpec) -> None:
    s.compiler.degree = False
    s.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    s.compiler.boundmass = MASS_BOUND
    s.compiler.boundinertia = MASS_BOUND
    s.option.gravity = list(spec.gravity)
    s.option.timestep = TIMESTEP
    s.option.integrator = INTEGRATOR
    # a measured supply pressure at a step's start and end, then the times each actuator's two
    # lines burst (a run's scenario; cylinder.c)
    s.nuserdata = 2 + 2 * len(spec.joints)


def _add_link(parent: mujoco.MjsBody, joint: Joint, at: np.ndarray) -> mujoco.MjsBody:
    """The body moved by ``joint``, placed at ``at`` in ``parent`` (m), with its joint and inertia."""
    body = parent.add_body(name=names.body_name(joint.name), pos=list(at))
    _set_inertial(body, joint.body or Body())
    limited = mujoco.mjtLimited.mjLIMITED_TRUE if joint.limits else mujoco.mjtLimited.mjLIMITED_FALSE
    f = joint.friction
    body.add_joint(
        name=joint.name,
        type=mujoco.mjtJoint.mjJNT_SLIDE if joint.prismatic else mujoco.mjtJoint.mjJNT_HINGE,
        axis=list(joint.axis_vector),
        range=list(joint.limits) if joint.limits else [0.0, 0.0],
        limited=limited,
        damping=[f.damping, 0.0, 0.0],
        frictionloss=f.coulomb if f.model is FrictionModel.hybrid else 0.0,
    )
    return body


def _set_inertial(body: mujoco.MjsBody, link: Body) -> None:
    assert link.com is not None and link.inertia is not None  # Body fills in their defaults
    body.explicitinertial = True
    body.mass = link.mass
    body.ipos = list(link.com)
    body.fullinertia = list(compilable_inertia(link.inertia))


def compilable_inertia(inertia: tuple[float, ...]) -> tuple[float, ...]:
    """The spec's inertia, shifted just enough that MuJoCo accepts it as a rigid body's.

    MuJoCo requires the principal moments to satisfy A + B >= C exactly (after lifting each to
    ``boundinertia``), but finds them by an eigen-decomposition that errs by ~1e-15 relative, so a
    flat plate (A + B = C) or a rotated heavy rod fails at random. When the margin A + B - C is below
    1e-12 C, this adds the missing margin to all three moments (an isotropic shift, which keeps the
    principal axes); the change is at most 1e-12 relative, plus whatever violation within its
    1e-9 tolerance the spec validation accepted.

    Args:
        inertia: [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] about the COG, kg·m².

    Returns:
        The same, possibly with a small constant added to Ixx, Iyy and Izz.
    """
    low, mid, high = np.linalg.eigvalsh(inertia_matrix(inertia))
    shortfall = _TRIANGLE_MARGIN * high - (max(low, MASS_BOUND) + mid - high)
    if high <= 0.0 or shortfall <= 0.0:
        return tuple(float(v) for v in inertia)
    return tuple(float(v) + shortfall for v in inertia[:3]) + tuple(float(v) for v in inertia[3:])


def _add_end_effector(parent: mujoco.MjsBody, ee: EndEffector, at: np.ndarray) -> mujoco.MjsBody:
    """Fixed body at the end-effector point ``at + offset`` in the last link (m), holding the
    payload: its mass at ``com`` from the point, with its inertia (zero: a point mass)."""
    body = parent.add_body(name=names.END_EFFECTOR, pos=list(at + np.asarray(ee.offset)))
    _set_inertial(body, Body(mass=ee.mass, com=ee.com, inertia=ee.inertia))
    return body


def _add_actuator(s: mujoco.MjSpec, joint: Joint, mount: Mount) -> None:
    """The actuator named after ``joint``, as its actuator model declares it
    (:meth:`~maniplab.actuators.ActuatorPlugin.configure_mjcf`) and on what it acts
    (:meth:`~maniplab.actuators.ActuatorPlugin.mount`: the joint, or a cylinder's tendon)."""
    act = s.add_actuator(name=joint.name, target=joint.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    model = model_of(joint)
    model.configure_mjcf(act)
    model.mount(act, mount)
    plugin = model.mujoco_plugin()
    if plugin is not None:
        set_plugin(s, act, plugin)


def _share_supply(s: mujoco.MjSpec, supply: Supply) -> None:
    """Every pinned cylinder draws from one pump (the spec's ``supply``): its plugin instance gets
    the pump's flow ``pump_flow`` (``maniplab_native/cylinder.c`` lowers their shared supply
    pressure when their valves would draw more), a load-sensing pump's margin
    ``pump_ls_margin`` and the pump's response time ``pump_response``."""
    extra = {"pump_flow": repr(float(supply.max_flow))}
    if supply.ls_margin is not None:
        extra["pump_ls_margin"] = repr(float(supply.ls_margin))
    if supply.response is not None:
        extra["pump_response"] = repr(float(supply.response))
    for instance in s.plugins:
        if instance.plugin_name == CYLINDER_PLUGIN:
            instance.config = {**instance.config, **extra}


def _act_size(act: mujoco.MjsActuator) -> int:
    """The activations MuJoCo gives ``act``: its ``actdim``, else one when it has dynamics."""
    if act.actdim >= 0:
        return int(act.actdim)
    return 0 if act.dyntype == mujoco.mjtDyn.mjDYN_NONE else 1


def _add_initial_key(s: mujoco.MjSpec, spec: ManipulatorSpec) -> None:
    """Keyframe ``initial`` (the model's first): the arm at rest at q = 0 with each actuator's
    initial states (:meth:`~maniplab.actuators.ActuatorPlugin.initial_state`), the state the
    plant starts from. MuJoCo resets every activation to zero, which for a pinned cylinder means
    both chambers at 0 Pa instead of tank pressure; ``mj_resetDataKeyframe(m, d, 0)`` starts a
    plain MuJoCo run where ``ml.simulate`` starts."""
    initial = {joint.name: model_of(joint).initial_state() for joint in spec.joints}
    act: list[float] = []
    for actuator in s.actuators:
        size = _act_size(actuator)
        values = np.zeros(size)
        x = initial.get(actuator.name, np.zeros(0))[:size]
        values[: len(x)] = x
        act.extend(float(v) for v in values)
    s.add_key(name=names.INITIAL_KEY, act=act)


def _add_bristles(s: mujoco.MjSpec, joint: Joint) -> None:
    """LuGre's bristles on ``joint``: actuator ``<joint>/lugre``, an instance of the engine plugin
    ``maniplab.lugre`` with state z and no control."""
    act = s.add_actuator(name=joint.name + names.LUGRE_SUFFIX, target=joint.name,
                         trntype=mujoco.mjtTrn.mjTRN_JOINT)
    act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
    f = joint.friction
    set_plugin(s, act, EnginePlugin(names.LUGRE_PLUGIN, 1, {
        "sigma0": f.sigma0, "sigma1": f.sigma1, "coulomb": f.coulomb, "static": f.static,
        "stribeck_velocity": f.stribeck_velocity}))
