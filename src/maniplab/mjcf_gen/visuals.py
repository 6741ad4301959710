"""Visual geometry of the generated model: links, joints, payload, floor, lights and cameras.

Everything here is for people and renderers only. Every geom has ``contype = conaffinity = 0`` (no
contacts) and the compiler never derives inertia from geoms, so nothing here changes the dynamics.
Sizes scale with the arm's reach R (:func:`~maniplab.mjcf_gen.reach.reach`), so a 2 m textbook arm
and a 6 m segment erector both look right:

- links are capsules from the joint to the next joint, as thick as a solid steel rod of the body's
  mass and length, clipped to [0.012 R, 0.05 R]; a body with mass but (almost) no length is a sphere
  at its COG;
- rotational joints are cylinders along the joint axis, as thick as the link they turn (or the last
  link before them); prismatic joints are rails (boxes along the axis covering the travel) on the
  body before the joint, so the next body visibly slides along them;
- the payload is a box of ``end_effector.box_size`` with a small red site at its centre;
- the floor is a checker plane perpendicular to gravity, 1.05 R below the base along gravity
  (which may point along -y, as in the erector), so the arm never reaches it;
- camera ``track`` follows the arm's centre of mass (mode ``trackcom``) from 2 R; camera
  ``overview`` is fixed and sees the whole reach around the base from 2.3 R. Both look along the
  first level rotation axis (so a planar arm moves across the image), slightly from above and the
  side, with image-up against gravity. A ``targetbodycom`` camera would always take world +z as
  image-up, which turns arms whose gravity is not along -z on their side (and is undefined when
  looking along z);
- a shadow-casting spot light from above, a directional fill light from the cameras' side, and a
  1920x1080 offscreen buffer for video.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from maniplab.mjcf_gen import names
from maniplab.mjcf_gen.reach import reach as arm_reach
from maniplab.spec import EndEffector, Joint, ManipulatorSpec

_STEEL_DENSITY = 7850.0  # kg/m³: a link is drawn as thick as a solid steel rod of its mass
_THIN, _THICK = 0.012, 0.05  # link radius bounds, fractions of the reach
_SHORT = 1e-3  # links shorter than this fraction of the reach are drawn as a sphere, if at all
_JOINT_SCALE = 1.25  # joint cylinders are this much thicker than the links they connect
_FLOOR_DEPTH = 1.05  # floor distance below the base, in reaches
_TRACK_DISTANCE = 2.0  # camera distances, in reaches; at fovy 45° and 16:9 the overview
_OVERVIEW_DISTANCE = 2.3  # sees (almost all of) a sphere of radius R around the base
_OFFSCREEN = (1920, 1080)  # offscreen buffer for video, pixels

_COLOURS = {
    "link": (0.95, 0.68, 0.10, 1.0),  # hydraulic-machine yellow
    "joint": (0.22, 0.23, 0.26, 1.0),
    "rail": (0.62, 0.64, 0.68, 1.0),
    "payload": (0.63, 0.61, 0.57, 1.0),  # concrete
    "base": (0.35, 0.36, 0.38, 1.0),
}
_MARKER_RGBA = (0.9, 0.1, 0.1, 1.0)
_NO_CONTACT = {"contype": 0, "conaffinity": 0}


@dataclasses.dataclass(frozen=True)
class Scene:
    """Sizes and directions derived from a spec for drawing it.

    Attributes:
        reach: R, m.
        up: unit vector against gravity (z when gravity is zero), shape (3,).
        view: unit vector from the viewed point towards the cameras, shape (3,).
        com0: the arm's centre of mass at q = 0 (the base when massless), m, shape (3,).
        link_radius: capsule radius per joint's body, m (0 without length).
        joint_radius: cylinder radius per joint, m.
    """

    reach: float
    up: np.ndarray
    view: np.ndarray
    com0: np.ndarray
    link_radius: tuple[float, ...]
    joint_radius: tuple[float, ...]


def scene_of(spec: ManipulatorSpec) -> Scene:
    """Sizes and directions for drawing ``spec``."""
    reach = arm_reach(spec)
    links = tuple(_link_radius(j, reach) for j in spec.joints)
    # a joint is as thick as its own link or, without one, the link before it (or the first link)
    previous = next((r for r in links if r > 0.0), _THIN * reach)
    joints = []
    for radius in links:
        previous = radius or previous
        joints.append(_JOINT_SCALE * previous)
    up = _up(spec.gravity)
    return Scene(reach, up, _view(spec, up), _com0(spec), links, tuple(joints))


def _link_radius(joint: Joint, reach: float) -> float:
    body = joint.body
    if body is None or body.length < _SHORT * reach:
        return 0.0
    solid = math.sqrt(body.mass / (_STEEL_DENSITY * math.pi * body.length))
    return min(max(solid, _THIN * reach), _THICK * reach)


def _up(gravity: tuple[float, float, float]) -> np.ndarray:
    g = np.asarray(gravity, dtype=float)
    norm = np.linalg.norm(g)
    return -g / norm if norm > 0.0 else np.array([0.0, 0.0, 1.0])


def _view(spec: ManipulatorSpec, up: np.ndarray) -> np.ndarray:
    """Look along the first horizontal rotation axis (the arm moves across the image), else from -y."""
    rotation_axes = [j.axis_vector for j in spec.joints if not j.prismatic]
    level = next((a for a in rotation_axes if abs(float(a @ up)) < 0.5), None)
    if level is None:  # the base axis most nearly level (one is within 55° of level)
        level = min((-np.eye(3)[1], np.eye(3)[0], np.eye(3)[2]), key=lambda a: abs(float(a @ up)))
    level = level - (level @ up) * up
    level /= np.linalg.norm(level)
    side = np.cross(up, level)
    direction = level + 0.25 * up + 0.25 * side
    return direction / np.linalg.norm(direction)


def _com0(spec: ManipulatorSpec) -> np.ndarray:
    origin = np.zeros(3)
    weighted, mass = np.zeros(3), 0.0
    for joint in spec.joints:
        if joint.body:
            weighted += joint.body.mass * (origin + np.asarray(joint.body.com))
            mass += joint.body.mass
        origin = origin + joint.offset
    ee = spec.end_effector
    weighted += ee.mass * (origin + np.asarray(ee.offset))
    mass += ee.mass
    return weighted / mass if mass > 0.0 else np.zeros(3)


# --- assets and world ---------------------------------------------------------------------------


def add_assets(s: mujoco.MjSpec, scene: Scene) -> None:
    """Textures (floor grid, sky) and the materials the geoms use."""
    for name, rgba in _COLOURS.items():
        s.add_material(name=name, rgba=list(rgba))
    s.add_texture(
        name="grid",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=[0.32, 0.34, 0.36],
        rgb2=[0.26, 0.28, 0.30],
        mark=mujoco.mjtMark.mjMARK_EDGE,
        markrgb=[0.45, 0.47, 0.50],
        width=512,
        height=512,
    )
    square = scene.reach / 5.0
    floor = s.add_material(name=names.FLOOR, texrepeat=[0.5 / square] * 2, texuniform=True)
    floor.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "grid"
    floor.reflectance = 0.1
    s.add_texture(
        name="sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.58, 0.68, 0.78],  # sky and ground alike: gravity need not point along -z
        rgb2=[0.36, 0.40, 0.45],
        width=512,
        height=3072,
    )


def set_visual(s: mujoco.MjSpec, scene: Scene) -> None:
    """Offscreen size for video, headlight, and the statistic the free camera starts from."""
    s.visual.global_.offwidth, s.visual.global_.offheight = _OFFSCREEN
    s.visual.headlight.ambient = [0.3, 0.3, 0.3]
    s.visual.headlight.diffuse = [0.4, 0.4, 0.4]
    s.stat.extent = 1.5 * scene.reach
    s.stat.center = list(scene.com0)


def add_world(s: mujoco.MjSpec, scene: Scene) -> None:
    """Floor, base block (its top face at the base origin), lights and cameras, all in the world."""
    world, r = s.worldbody, scene.reach
    quat = np.zeros(4)
    mujoco.mju_quatZ2Vec(quat, scene.up)
    world.add_geom(
        name=names.FLOOR,
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        pos=list(-_FLOOR_DEPTH * r * scene.up),
        quat=list(quat),
        size=[3.0 * r, 3.0 * r, r / 5.0],
        material=names.FLOOR,
        **_NO_CONTACT,
    )
    half = 1.2 * scene.joint_radius[0]
    world.add_geom(
        name="base",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=list(-half * scene.up),
        size=[half] * 3,
        material="base",
        **_NO_CONTACT,
    )
    _add_lights(world, scene)
    _add_cameras(world, scene)


def _add_lights(world: mujoco.MjsBody, scene: Scene) -> None:
    """A shadow-casting spot from above (sharper shadows than a directional light) and a fill light."""
    side = np.cross(scene.up, scene.view)
    above = scene.com0 + scene.reach * (3.0 * scene.up - 0.6 * side + 0.4 * scene.view)
    world.add_light(
        name="sun",
        type=mujoco.mjtLightType.mjLIGHT_SPOT,
        pos=list(above),
        dir=list((scene.com0 - above) / np.linalg.norm(scene.com0 - above)),
        cutoff=55.0,
        diffuse=[0.7, 0.7, 0.7],
        castshadow=True,
    )
    world.add_light(
        name="fill",
        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
        pos=list(3.0 * scene.reach * scene.view),
        dir=list(-scene.view),
        diffuse=[0.25, 0.25, 0.25],
        castshadow=False,
    )


def _add_cameras(world: mujoco.MjsBody, scene: Scene) -> None:
    quat = _look_quat(scene.view, scene.up)
    world.add_camera(
        name=names.TRACK_CAMERA,
        mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM,
        pos=list(scene.com0 + _TRACK_DISTANCE * scene.reach * scene.view),
        quat=list(quat),
    )
    world.add_camera(
        name=names.OVERVIEW_CAMERA,
        mode=mujoco.mjtCamLight.mjCAMLIGHT_FIXED,
        pos=list(_OVERVIEW_DISTANCE * scene.reach * scene.view),
        quat=list(quat),
    )


def _look_quat(back: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Camera orientation looking along -back with image-up ``up`` (a camera looks along its -z)."""
    z = back / np.linalg.norm(back)
    y = up - (up @ z) * z
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([x, y, z]).flatten())
    return quat


# --- the arm ------------------------------------------------------------------------------------


def decorate_link(
    body: mujoco.MjsBody, parent: mujoco.MjsBody, joint: Joint, index: int, scene: Scene
) -> None:
    """Geoms of joint ``index``: its cylinder (on ``body``) or rail (on ``parent``), and its link.

    Args:
        body: the joint's MuJoCo body (frame j after the joint's motion).
        parent: the body before the joint (the world for the first joint).
        joint: the spec joint.
        index: 0-based joint index.
        scene: sizes.
    """
    radius = scene.joint_radius[index]
    axis = joint.axis_vector
    if joint.prismatic:
        at = np.asarray(body.pos, dtype=float)  # shared orientation: the joint's place in parent
        lo, hi = joint.limits if joint.limits else (-2.0 * radius, 2.0 * radius)
        parent.add_geom(
            name=names.joint_geom_name(joint.name),
            type=mujoco.mjtGeom.mjGEOM_BOX,
            pos=list(at + 0.5 * (lo + hi) * axis),
            size=list(0.6 * radius + (0.5 * (hi - lo) + 0.4 * radius) * axis),
            material="rail",
            **_NO_CONTACT,
        )
    else:
        body.add_geom(
            name=names.joint_geom_name(joint.name),
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            fromto=[*(-0.9 * radius * axis), *(0.9 * radius * axis)],
            size=[radius, 0.0, 0.0],
            material="joint",
            **_NO_CONTACT,
        )
    _add_link_shape(body, joint, scene.link_radius[index], scene.reach)


def _add_link_shape(body: mujoco.MjsBody, joint: Joint, radius: float, reach: float) -> None:
    link = joint.body
    if link is None:
        return
    if link.length >= _SHORT * reach:
        body.add_geom(
            name=names.link_geom_name(joint.name),
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0.0, 0.0, 0.0, *joint.offset],
            size=[radius, 0.0, 0.0],
            material="link",
            **_NO_CONTACT,
        )
    elif link.mass > 0.0:
        assert link.com is not None  # Body.__post_init__ fills in a com that was not given
        solid = (3.0 * link.mass / (4.0 * math.pi * _STEEL_DENSITY)) ** (1.0 / 3.0)
        body.add_geom(
            name=names.link_geom_name(joint.name),
            type=mujoco.mjtGeom.mjGEOM_SPHERE,
            pos=list(link.com),
            size=[min(max(solid, _THIN * reach), _THICK * reach), 0.0, 0.0],
            material="link",
            **_NO_CONTACT,
        )


def decorate_end_effector(body: mujoco.MjsBody, ee: EndEffector, scene: Scene) -> None:
    """The payload box and the ``end_effector`` site at the payload's centre."""
    body.add_geom(
        name=names.PAYLOAD,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(0.5 * ee.box_size),
        material="payload",
        **_NO_CONTACT,
    )
    body.add_site(
        name=names.END_EFFECTOR,
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[0.01 * scene.reach, 0.0, 0.0],
        rgba=list(_MARKER_RGBA),
    )
