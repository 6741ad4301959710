"""The end-effector's path, traced behind it as a polyline added to the scene.

Lines, not capsules: a few hundred capsules triple the time per frame on a software rasteriser,
lines cost a fifth more than no path at all.
"""

from __future__ import annotations

import itertools

import mujoco
import numpy as np

from maniplab.viz import palette

_SPACING = 1.0 / 150.0  # a new point once the tip moved this fraction of the scene's size
_MAX_POINTS = 600  # past this, every other point is dropped (long videos stay cheap to draw)
_IDENTITY = np.eye(3).flatten()


class Trail:
    """Positions the end-effector has passed, thinned to a drawable number of segments.

    Args:
        scale: size of the scene, m (the automatic framing's radius); sets the point spacing.
        width: line width, pixels.
        colour: RGBA of the line.
    """

    def __init__(self, scale: float, width: float, colour: palette.RGBA = palette.PATH) -> None:
        self.spacing, self.width = _SPACING * scale, width
        self.colour = np.asarray(colour, dtype=np.float32)
        self.points: list[np.ndarray] = []

    def extend(self, position: np.ndarray) -> None:
        """Record the end-effector at ``position`` (shape (3,), m) if it moved far enough."""
        if self.points and np.linalg.norm(position - self.points[-1]) < self.spacing:
            return
        self.points.append(np.array(position, dtype=float))
        if len(self.points) > _MAX_POINTS:
            self.points = self.points[:-1:2] + self.points[-1:]

    def add_to(self, scene: mujoco.MjvScene, tip: np.ndarray) -> None:
        """Add the path, from the first point to ``tip`` (the current position), to ``scene``."""
        path = self.points + [np.asarray(tip, dtype=float)]
        for start, end in itertools.pairwise(path):
            if scene.ngeom >= scene.maxgeom:
                return
            if not np.any(end != start):  # the tip rests on the last point: nothing to draw
                continue
            geom = scene.geoms[scene.ngeom]
            mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_LINE, np.zeros(3), np.zeros(3),
                                _IDENTITY, self.colour)
            mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_LINE, self.width, start, end)
            geom.category = mujoco.mjtCatBit.mjCAT_DECOR
            scene.ngeom += 1


def max_segments() -> int:
    """Most segments one trail adds to a scene (for sizing it)."""
    return _MAX_POINTS + 1


def line_width(height: int) -> float:
    """Path width, pixels, for an image ``height`` pixels high."""
    return max(1.5, height / 240.0)
