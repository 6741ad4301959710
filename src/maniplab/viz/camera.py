"""Cameras: the automatic framing of a whole motion, and the spec's named cameras.

The automatic camera looks from the direction of the spec's own cameras (along the first level
rotation axis, slightly from above and the side, image-up against gravity; see
:mod:`maniplab.mjcf_gen.visuals`). It collects the corners of every geom's bounding box (the floor
excepted) at every frame, and moves sideways and back until all of them fit the image with a small
margin: the whole motion stays in view, as large as it can be. (Bounding spheres would frame a
3 m concrete segment seen edge-on as if it were 3 m wide.)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import mujoco
import numpy as np

from maniplab.mjcf_gen.visuals import scene_of
from maniplab.viz.arm import AUTO_CAMERA, ArmView
from maniplab.viz.gl import RenderError
from maniplab.viz.timeline import Motion

AUTO = "auto"
"""The ``camera`` argument that asks for the automatic framing."""

_MARGIN = 1.06  # the swept geoms fill the image to 1/_MARGIN of its half-width or half-height
_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)


@dataclasses.dataclass(frozen=True, eq=False)
class Framing:
    """What the automatic camera must show, and from where it looks.

    Attributes:
        points: corners of the geoms' bounding boxes over the motion, m, shape (K, 3).
        view: unit vector from the scene towards the camera, shape (3,).
        up: unit vector that points up in the image, shape (3,).
    """

    points: np.ndarray
    view: np.ndarray
    up: np.ndarray

    @property
    def size(self) -> float:
        """Half the largest extent of the swept geoms, m."""
        return float(np.max(np.ptp(self.points, axis=0))) / 2.0

    @property
    def aspect(self) -> float:
        """Width over height of the swept geoms as the camera sees them (ignoring perspective)."""
        x, y, _ = _camera_axes(self.view, self.up)
        return float(np.ptp(self.points @ x) / max(np.ptp(self.points @ y), 1e-9))


def frame_motions(arms: Sequence[ArmView], motions: Sequence[Motion]) -> Framing:
    """The framing that shows every arm over its whole motion (one shared view for comparisons).

    Args:
        arms: one view per motion (their poses are changed).
        motions: the runs sampled at the video's frames.
    """
    points = np.vstack([_swept(arm, motion.q) for arm, motion in zip(arms, motions, strict=True)])
    scene = scene_of(arms[0].spec)
    return Framing(points, scene.view, scene.up)


def _swept(arm: ArmView, q: np.ndarray) -> np.ndarray:
    """Corners of the arm's geoms' bounding boxes at every pose of ``q``, m, shape (K, 3)."""
    model = arm.model
    geoms = np.flatnonzero(model.geom_type != mujoco.mjtGeom.mjGEOM_PLANE)
    aabb = model.geom_aabb[geoms]  # (centre, half-size) in the geom's frame
    local = aabb[:, None, :3] + _CORNERS[None] * aabb[:, None, 3:]  # (G, 8, 3)
    points = []
    for pose in q:
        arm.pose(pose)
        rotation = arm.data.geom_xmat[geoms].reshape(-1, 3, 3)
        points.append(arm.data.geom_xpos[geoms, None] + local @ rotation.transpose(0, 2, 1))
    return np.concatenate(points).reshape(-1, 3)


def place(arm: ArmView, framing: Framing, aspect: float) -> int:
    """Place ``arm``'s automatic camera so ``framing`` fits an image of ``aspect`` (width/height).

    Returns:
        The camera's id.
    """
    camera = arm.camera_id(AUTO_CAMERA)
    x, y, z = _camera_axes(framing.view, framing.up)
    tan_height = math.tan(math.radians(arm.model.cam_fovy[camera]) / 2.0)
    tan_width = tan_height * aspect
    across, along, depth = framing.points @ x, framing.points @ y, framing.points @ z
    mid_x = 0.5 * (np.min(across) + np.max(across))
    mid_y = 0.5 * (np.min(along) + np.max(along))
    # a point at depth d (towards the camera) is in view when its offset fits the frustum there
    distance = max(np.max(depth + _MARGIN * np.abs(across - mid_x) / tan_width),
                   np.max(depth + _MARGIN * np.abs(along - mid_y) / tan_height))
    arm.model.cam_pos[camera] = mid_x * x + mid_y * y + distance * z
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([x, y, z]).flatten())
    arm.model.cam_quat[camera] = quat
    return camera


def _camera_axes(back: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Image right, image up, and backwards (a camera looks along its -z), shape (3,) each."""
    z = back / np.linalg.norm(back)
    y = up - (up @ z) * z
    y /= np.linalg.norm(y)
    return np.cross(y, z), y, z


def resolve(camera: str | Framing, arms: Sequence[ArmView],
            aspect: float) -> list[mujoco.MjvCamera]:
    """One MjvCamera per arm for ``camera``: a :class:`Framing` or a model camera's name.

    Raises:
        RenderError: ``camera`` names no camera of the models.
    """
    if not isinstance(camera, (str, Framing)):
        raise RenderError(f"camera must be 'auto', a camera name or a Framing, got {camera!r}")
    cameras = []
    for arm in arms:
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
        if isinstance(camera, Framing):
            cam.fixedcamid = place(arm, camera, aspect)
        else:
            cam.fixedcamid = arm.camera_id(camera)
        cameras.append(cam)
    return cameras
