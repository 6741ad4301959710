"""One arm in a scene: its model and data, posed at a frame's joint positions, coloured by state."""

from __future__ import annotations

import mujoco
import numpy as np

from maniplab.mjcf_gen import build_mjspec, names
from maniplab.mjcf_gen.builder import compile_model
from maniplab.spec import ManipulatorSpec
from maniplab.viz import palette
from maniplab.viz.cylinders import BARREL, ROD, cylinder_parts, pinned_cylinders, tendon_segments
from maniplab.viz.gl import RenderError

AUTO_CAMERA = "maniplab_auto"
"""Name of the fixed camera added to every rendered model and placed by the automatic framing."""

HIDDEN_TENDONS = mujoco.mjNGROUP - 1
"""Tendon group of the pinned cylinders' tendons in a rendered model: scenes leave it out
(:class:`mujoco.MjvOption`'s default), the cylinders are drawn as barrel and rod instead."""

_NO_OBJECT = -1
_GHOST_GROWTH = 1.01  # ghosts are drawn this much larger: where they coincide with the solid arm
# (the base joint), equal depths would otherwise speckle


class ArmView:
    """The MuJoCo model of a spec with one pose, drawn into scenes.

    The model is the one :func:`~maniplab.build_model` makes, plus a fixed world camera
    :data:`AUTO_CAMERA` that :mod:`maniplab.viz.camera` places; its pinned cylinders' tendons are
    in group :data:`HIDDEN_TENDONS` (:meth:`add_cylinders` draws them).

    Args:
        spec: the arm.
    """

    def __init__(self, spec: ManipulatorSpec) -> None:
        self.spec = spec
        mjspec = build_mjspec(spec)
        mjspec.worldbody.add_camera(name=AUTO_CAMERA, mode=mujoco.mjtCamLight.mjCAMLIGHT_FIXED)
        self.model = compile_model(mjspec, spec)  # callbacks suspended while compiling
        self.data = mujoco.MjData(self.model)
        self.end_effector = self.model.site(names.END_EFFECTOR).id
        self._link_of = np.full(self.model.ngeom, _NO_OBJECT)
        self._joint_of = np.full(self.model.ngeom, _NO_OBJECT)
        for j, joint in enumerate(spec.joints):
            for table, name in ((self._link_of, names.link_geom_name(joint.name)),
                                (self._joint_of, names.joint_geom_name(joint.name))):
                geom = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, name)
                if geom >= 0:
                    table[geom] = j
        self.cylinders = pinned_cylinders(self.model, spec)
        """(tendon id, joint name, cylinder parameters) of each pinned cylinder."""
        for tendon, _, _ in self.cylinders:
            self.model.tendon_group[tendon] = HIDDEN_TENDONS

    def camera_id(self, name: str) -> int:
        """Id of the model camera ``name``; raises RenderError listing the cameras when unknown."""
        camera = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        if camera < 0:
            known = [self.model.camera(i).name for i in range(self.model.ncam)]
            known = [n for n in known if n != AUTO_CAMERA]
            raise RenderError(f"unknown camera '{name}'; expected auto or one of the model's: "
                              f"{', '.join(known)}")
        return camera

    def pose(self, q: np.ndarray) -> None:
        """Place the arm at joint positions ``q`` (shape (n,), rad or m): bodies, sites, cameras."""
        self.data.qpos[:] = q
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)  # the tracking camera follows the subtree COM
        mujoco.mj_tendon(self.model, self.data)  # cylinders are drawn along their tendons
        mujoco.mj_camlight(self.model, self.data)

    @property
    def end_effector_position(self) -> np.ndarray:
        """Position of the end-effector site in the current pose, m, shape (3,)."""
        return self.data.site_xpos[self.end_effector].copy()

    def colour(self, scene: mujoco.MjvScene, start: int, modes: np.ndarray,
               tint: palette.RGBA | None = None) -> None:
        """Colour this arm's geoms among ``scene.geoms[start:]``: links per index, joints per mode.

        Args:
            scene: a scene this arm's geoms were just added to.
            start: index of the first of them.
            modes: :class:`FrictionMode` per joint, shape (n,).
            tint: draw the whole arm in this colour, translucent (a ghost), joint states excepted.
        """
        for i in range(start, scene.ngeom):
            geom = scene.geoms[i]
            if geom.objtype == mujoco.mjtObj.mjOBJ_SITE:  # the end-effector marker starts the path;
                if geom.objid == self.end_effector:  # (a cylinder's pins keep their colour)
                    geom.rgba[:] = tint or palette.PATH  # red is kept for joint limits
                continue
            if geom.objtype not in (mujoco.mjtObj.mjOBJ_GEOM, mujoco.mjtObj.mjOBJ_TENDON):
                continue
            rgba = tint if geom.objtype == mujoco.mjtObj.mjOBJ_TENDON else \
                self.geom_colour(geom.objid, modes, tint)
            if rgba is not None:
                geom.rgba[:] = rgba
            if tint is not None:
                _ghost(geom)

    def add_cylinders(self, scene: mujoco.MjvScene, tint: palette.RGBA | None = None) -> None:
        """Add each pinned cylinder's barrel and rod in the current pose to ``scene`` (two
        cylinder geoms each, placed by :func:`~maniplab.viz.cylinders.cylinder_parts`), in
        :data:`~maniplab.viz.cylinders.BARREL` and :data:`~maniplab.viz.cylinders.ROD`, or in
        ``tint`` as a ghost (translucent, as :meth:`colour` draws the rest of the arm)."""
        if not self.cylinders:
            return
        segments = tendon_segments(self.model, self.data)
        eye = scene.camera[0].pos + scene.camera[1].pos  # twice the eyes' middle
        for tendon, _, cylinder in self.cylinders:
            for part, colour in zip(cylinder_parts(segments[tendon], cylinder), (BARREL, ROD)):
                if scene.ngeom >= scene.maxgeom:
                    return
                geom = scene.geoms[scene.ngeom]
                _place_part(geom, *part, colour if tint is None else tint)
                geom.camdist = float(np.linalg.norm(geom.pos - 0.5 * eye))
                if tint is not None:
                    _ghost(geom)
                scene.ngeom += 1

    def geom_colour(self, geom: int, modes: np.ndarray,
                    tint: palette.RGBA | None = None) -> palette.RGBA | None:
        """Colour of model geom ``geom`` with joint ``modes`` (shape (n,)): a joint's state colour,
        else ``tint``, else its link's colour; None keeps the model's own."""
        joint = self._joint_of[geom]
        if joint != _NO_OBJECT:
            state = palette.JOINT_STATES.get(int(modes[joint]))
            if state is not None:
                return state
        if tint is not None:
            return tint
        link = self._link_of[geom]
        return palette.link_colour(int(link)) if link != _NO_OBJECT else None


def _ghost(geom: mujoco.MjvGeom) -> None:
    """Make a scene geom a ghost's: translucent, casting no shadow, a little larger."""
    geom.rgba[3] = palette.GHOST_ALPHA
    geom.transparent = 1
    geom.castshadow = 0
    geom.size[:] = geom.size * _GHOST_GROWTH


def _place_part(geom: mujoco.MjvGeom, start: np.ndarray, wxyz: np.ndarray,
                scale: tuple[float, float, float], rgba: palette.RGBA) -> None:
    """Make ``geom`` a cylinder part: from ``start`` (m, shape (3,)) along the z axis of the
    rotation ``wxyz`` (shape (4,)), radius ``scale[0]`` and length ``scale[2]`` (m), in colour
    ``rgba``, opaque (a ghost is made translucent after)."""
    rotation = np.empty(9)
    mujoco.mju_quat2Mat(rotation, np.asarray(wxyz, dtype=float))
    radius, length = float(scale[0]), float(scale[2])
    middle = np.asarray(start, dtype=float) + 0.5 * length * rotation[2::3]  # the z column
    mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_CYLINDER, np.zeros(3), middle, rotation,
                        np.asarray(rgba, dtype=np.float32))
    geom.size[:] = (radius, radius, 0.5 * length)  # (mjv_initGeom reads a model geom's sizes)
    geom.objtype, geom.objid = mujoco.mjtObj.mjOBJ_UNKNOWN, -1
    geom.category = mujoco.mjtCatBit.mjCAT_DECOR
    geom.transparent = 0
    geom.castshadow = 1
    geom.segid = -1
