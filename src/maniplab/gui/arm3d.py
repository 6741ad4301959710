"""An arm in a viser (three.js) scene: one frame per MuJoCo body holding its geoms' meshes, posed
from joint positions.

The geometry is the MuJoCo model's (:class:`~maniplab.viz.arm.ArmView`): the same boxes,
capsules and cylinders the videos show, placed by MuJoCo's own forward kinematics, and coloured
as the videos colour them (links per index; a joint blue while it sticks, red at a limit).
Hydraulic cylinders pinned to the links are drawn as barrel and rod along their pin line; the rod
slides out of the barrel with the stroke.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import trimesh

from maniplab.friction.modes import FrictionMode
from maniplab.spec import ManipulatorSpec
from maniplab.viz import palette
from maniplab.viz.arm import ArmView
from maniplab.viz.cylinders import BARREL, ROD, cylinder_parts, pinned_cylinders, tendon_segments

_SEGMENTS = 24  # facets around a cylinder or capsule
_TENDON_WIDTH = 0.08  # m
GHOST_GROWTH = 1.01
"""A ghost's geoms are drawn this much larger about their centres (as the videos draw them): a
ghost over the solid arm never lies at the solid's depth."""


def geom_mesh(model: Any, geom: int) -> trimesh.Trimesh | None:
    """The surface of MuJoCo geom ``geom`` in its own frame (m), or None for a plane."""
    kind, size = int(model.geom_type[geom]), model.geom_size[geom]
    t = mujoco.mjtGeom
    if kind == t.mjGEOM_BOX:
        return trimesh.creation.box(extents=2.0 * size)
    if kind == t.mjGEOM_CAPSULE:
        return trimesh.creation.capsule(height=2.0 * size[1], radius=size[0], count=[_SEGMENTS, 8])
    if kind == t.mjGEOM_CYLINDER:
        return trimesh.creation.cylinder(radius=size[0], height=2.0 * size[1], sections=_SEGMENTS)
    if kind in (t.mjGEOM_SPHERE, t.mjGEOM_ELLIPSOID):
        sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        sphere.apply_scale(size if kind == t.mjGEOM_ELLIPSOID else size[0])
        return sphere
    if kind == t.mjGEOM_MESH:
        mesh = int(model.geom_dataid[geom])
        v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
        return trimesh.Trimesh(model.mesh_vert[v0:v0 + nv], model.mesh_face[f0:f0 + nf],
                               process=False)
    return None


def _rgb(colour: palette.RGBA | np.ndarray) -> tuple[int, int, int]:
    return palette.to_uint8(tuple(float(c) for c in colour[:4]))  # type: ignore[arg-type]


class Arm3D:
    """One arm drawn under scene node ``prefix``.

    Each MuJoCo body is one scene frame (``{prefix}/body{b}``) and its geoms are meshes fixed
    in it at their place in the body (``model.geom_pos``, ``geom_quat``): posing the arm sends
    one position and orientation per body that moved, not per geom. Colours are sent only when
    a joint's state changes them, a cylinder's size only when its length changes.

    Args:
        scene: a viser scene API (``server.scene``).
        prefix: scene-tree name of the arm, e.g. ``"/arm"``.
        spec: the arm.
        tint: draw the arm as a translucent ghost of this colour (joint states still shown),
            its geoms :data:`GHOST_GROWTH` larger.
        labels: name each joint in the scene, at its axis (MuJoCo's joint anchor).
        view: the arm's :class:`ArmView`, when made already.
    """

    def __init__(self, scene: Any, prefix: str, spec: ManipulatorSpec,
                 tint: palette.RGBA | None = None, labels: bool = False,
                 view: ArmView | None = None) -> None:
        self.view = view if view is not None else ArmView(spec)
        self.prefix, self.tint = prefix, tint
        model = self.view.model
        self._opacity = palette.GHOST_ALPHA if tint is not None else None
        self._meshes: list[tuple[int, Any]] = []  # geom, its mesh (posed in its body's frame)
        self._bodies: dict[int, Any] = {}  # body -> its frame (the world's bodies: none)
        self._colours: dict[int, tuple[int, int, int]] = {}
        self._surfaces: dict[int, np.ndarray] = {}  # vertices in each geom's frame, m
        self._placed: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # handle -> pose sent
        self._scales: dict[int, tuple[float, float, float]] = {}  # handle -> scale sent
        rest = np.full(spec.n, int(FrictionMode.SLIP))
        grow = GHOST_GROWTH if tint is not None else 1.0
        for geom in range(model.ngeom):
            surface = geom_mesh(model, geom)
            if surface is None:
                continue
            body = int(model.geom_bodyid[geom])
            if body > 0 and body not in self._bodies:
                self._bodies[body] = scene.add_frame(f"{prefix}/body{body}", show_axes=False)
            parent = f"{prefix}/body{body}" if body > 0 else prefix
            name = (model.geom(geom).name or f"geom{geom}").replace("/", "_")
            colour = self._colour(geom, rest)
            handle = scene.add_mesh_simple(
                f"{parent}/{name}", vertices=np.asarray(surface.vertices * grow, dtype=np.float32),
                faces=np.asarray(surface.faces, dtype=np.uint32), color=colour,
                opacity=self._opacity, flat_shading=False, cast_shadow=False,
                receive_shadow=False, position=model.geom_pos[geom].copy(),
                wxyz=model.geom_quat[geom].copy())
            self._meshes.append((geom, handle))
            self._colours[geom] = colour
            self._surfaces[geom] = np.asarray(surface.vertices, dtype=float)
        self._tendons = None
        self.cylinders: list[tuple[int, Any, Any, Any]] = []  # tendon, params, barrel, rod
        unit = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=_SEGMENTS)
        unit.apply_translation((0.0, 0.0, 0.5))  # from z = 0 to 1: placed at its start, scaled
        unit_vertices = np.asarray(unit.vertices, dtype=np.float32)
        unit_faces = np.asarray(unit.faces, dtype=np.uint32)
        for k, joint, cylinder in pinned_cylinders(model, spec):
            parts = [scene.add_mesh_simple(
                f"{prefix}/cylinders/{joint}/{part}", vertices=unit_vertices, faces=unit_faces,
                color=_rgb(tint or colour), opacity=self._opacity, flat_shading=False,
                cast_shadow=False, receive_shadow=False)
                for part, colour in (("barrel", BARREL), ("rod", ROD))]
            self.cylinders.append((k, cylinder, *parts))
        self._joint_ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
                           for name in spec.joint_names]
        self.labels = [scene.add_label(f"{prefix}/labels/{name}", text=name, font_screen_scale=0.8,
                                       anchor="bottom-left")
                       for name in spec.joint_names] if labels else []
        drawn = {k for k, *_ in self.cylinders}
        if model.ntendon > len(drawn):  # a tendon that is no pinned cylinder: a line
            self._tendons = scene.add_line_segments(
                f"{prefix}/tendons", points=np.zeros((model.ntendon, 2, 3), dtype=np.float32),
                colors=_rgb(tint or (0.35, 0.37, 0.40, 1.0)), thickness=_TENDON_WIDTH)
        self._segments: np.ndarray | None = None  # the tendon line's points sent
        self.visible = True

    def _colour(self, geom: int, modes: np.ndarray) -> tuple[int, int, int]:
        own = self.view.geom_colour(geom, modes, self.tint)
        if own is not None:
            return _rgb(own)
        model = self.view.model
        material = int(model.geom_matid[geom])
        return _rgb(model.mat_rgba[material] if material >= 0 else model.geom_rgba[geom])

    def pose(self, q: np.ndarray, modes: np.ndarray | None = None) -> None:
        """Place the arm at joint positions ``q`` (shape (n,), rad or m) and colour its joints by
        ``modes`` (:class:`FrictionMode` per joint, shape (n,); default: all slipping)."""
        view = self.view
        view.pose(np.asarray(q, dtype=float))
        modes = np.full(view.spec.n, int(FrictionMode.SLIP)) if modes is None else modes
        for body, frame in self._bodies.items():
            self._place(frame, view.data.xpos[body], view.data.xquat[body])
        for geom, handle in self._meshes:
            colour = self._colour(geom, modes)
            if colour != self._colours[geom]:
                handle.color = colour
                self._colours[geom] = colour
        for j, label in enumerate(self.labels):
            here = view.data.xanchor[self._joint_ids[j]]
            if not np.array_equal(label.position, here):
                label.position = here.copy()
        segments = tendon_segments(view.model, view.data)
        if self._tendons is not None and (self._segments is None or
                                          not np.array_equal(self._segments, segments)):
            self._tendons.points = segments
            self._segments = segments
        for k, cylinder, barrel, rod in self.cylinders:
            for handle, (start, wxyz, scale) in zip((barrel, rod),
                                                    cylinder_parts(segments[k], cylinder)):
                self._place(handle, start, wxyz)
                size = (float(scale[0]), float(scale[1]), float(scale[2]))
                if self._scales.get(id(handle)) != size:  # a size is a mesh's property: the
                    handle.scale = size  # page builds the mesh anew, so only when it changed
                    self._scales[id(handle)] = size

    def _place(self, handle: Any, position: np.ndarray, wxyz: np.ndarray) -> bool:
        """Move ``handle`` to ``position`` and ``wxyz`` when it is not there already (a replay
        sends only what moved); returns whether it moved."""
        position, wxyz = np.array(position, dtype=float), np.array(wxyz, dtype=float)
        last = self._placed.get(id(handle))
        if last is not None and np.array_equal(last[0], position) and \
                np.array_equal(last[1], wxyz):
            return False
        handle.position, handle.wxyz = position, wxyz
        self._placed[id(handle)] = (position, wxyz)
        return True

    def drawn_pose(self, geom: int) -> tuple[np.ndarray, np.ndarray]:
        """Where the page draws geom ``geom``, from what was sent it: its body's frame composed
        with the geom's place in the body: world position (m, shape (3,)) and rotation matrix
        (shape (3, 3))."""
        handle = dict(self._meshes)[geom]
        local = _matrix(np.asarray(handle.wxyz, dtype=float))
        body = int(self.view.model.geom_bodyid[geom])
        frame = self._bodies.get(body)
        if frame is None:
            return np.asarray(handle.position, dtype=float), local
        rotation = _matrix(np.asarray(frame.wxyz, dtype=float))
        return (np.asarray(frame.position, dtype=float) +
                rotation @ np.asarray(handle.position, dtype=float), rotation @ local)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The arm's box in the current pose (every vertex drawn, the floor left out): lowest and
        highest world coordinates, m, each shape (3,)."""
        data = self.view.data
        points = [data.geom_xpos[g] + vertices @ data.geom_xmat[g].reshape(3, 3).T
                  for g, vertices in self._surfaces.items()]
        if not points:
            here = np.asarray(self.end_effector, dtype=float)
            return here - 0.5, here + 0.5
        every = np.vstack(points)
        return every.min(axis=0), every.max(axis=0)

    @property
    def end_effector(self) -> np.ndarray:
        """End-effector position in the current pose, m, shape (3,)."""
        return self.view.end_effector_position

    def _nodes(self) -> list[Any]:
        """Every scene node of the arm that is no child of another."""
        nodes = list(self._bodies.values())
        nodes += [h for g, h in self._meshes if int(self.view.model.geom_bodyid[g]) == 0]
        nodes += [part for _, _, barrel, rod in self.cylinders for part in (barrel, rod)]
        nodes += self.labels
        return nodes + ([self._tendons] if self._tendons is not None else [])

    def set_visible(self, visible: bool) -> None:
        """Show or hide the arm (a body's frame hides its geoms with it)."""
        if visible == self.visible:
            return
        for node in self._nodes():
            node.visible = visible
        self.visible = visible

    def remove(self) -> None:
        """Take the arm out of the scene."""
        for node in self._nodes():
            node.remove()


def _matrix(wxyz: np.ndarray) -> np.ndarray:
    rotation = np.empty(9)
    mujoco.mju_quat2Mat(rotation, wxyz)
    return rotation.reshape(3, 3)


def looks(view: ArmView) -> bytes:
    """What an arm's drawing depends on: its geoms (type, size, place, colour, material), bodies,
    joints, tendons' sites and its cylinders' dimensions. Two arms that look the same have the
    same bytes (an edit of a mass or a valve changes nothing drawn)."""
    model, spec = view.model, view.spec
    parts = [model.geom_type, model.geom_size, model.geom_pos, model.geom_quat, model.geom_rgba,
             model.geom_matid, model.geom_bodyid, model.geom_dataid, model.mat_rgba,
             model.body_pos, model.body_quat, model.body_parentid, model.jnt_type,
             model.jnt_axis, model.jnt_pos, model.site_pos, model.wrap_objid, model.mesh_vert]
    cylinders = repr([(j.name, getattr(j.actuator, "cylinder", None)) for j in spec.joints])
    return b"".join(np.ascontiguousarray(p).tobytes() for p in parts) + cylinders.encode() + \
        repr(list(spec.joint_names)).encode()
