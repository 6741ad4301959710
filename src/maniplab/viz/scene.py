"""The 3-D view of one or more runs at each frame: arms, joint states, paths, camera and lights.

One run is drawn as it is (links in their colours, joints by state). Several runs in one scene
(an overlay) draw the first as the reference and the others as translucent ghosts, each in its
run colour; the floor, base, lights and camera are the first run's.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from maniplab.viz import camera as cameras
from maniplab.viz import palette
from maniplab.viz.arm import HIDDEN_TENDONS, ArmView
from maniplab.viz.canvas import Canvas
from maniplab.viz.look import Look
from maniplab.viz.timeline import Motion
from maniplab.viz.trail import Trail, line_width, max_segments

if TYPE_CHECKING:
    from typing_extensions import Self

_SPARE_GEOMS = 200  # labels, decor, and room for MuJoCo's own additions


class SceneView:
    """Renders frames of ``motions`` (all sampled at the same times) into images.

    Use as a context manager (or call :meth:`close`): it owns an OpenGL context.

    Args:
        motions: the runs at the video's frames; the first is opaque, the others are ghosts.
        width: image width, pixels.
        height: image height, pixels.
        look: camera, shadows, antialiasing and path (its text and plot fields are not used here).

    Raises:
        RenderError: no OpenGL backend, or an unknown camera.
    """

    def __init__(self, motions: Sequence[Motion], width: int, height: int, look: Look) -> None:
        self.motions = list(motions)
        self.arms = [ArmView(m.run.spec) for m in self.motions]
        camera = look.camera
        if isinstance(camera, str) and camera == cameras.AUTO:
            camera = cameras.frame_motions(self.arms, self.motions)
        self.cameras = cameras.resolve(camera, self.arms, width / height)
        # the path's point spacing follows the size of what is in view
        if isinstance(camera, cameras.Framing):
            scale = camera.size
        else:
            scale = float(self.arms[0].model.stat.extent)
        single = len(self.motions) == 1
        self.trails = [Trail(scale, line_width(height),
                             palette.PATH if single else palette.run_colour(k))
                       for k in range(len(self.motions))] if look.trace else []
        self.tints = [None] + [palette.run_colour(k) for k in range(1, len(self.motions))]
        self.option = mujoco.MjvOption()
        self.option.tendongroup[HIDDEN_TENDONS] = 0  # pinned cylinders: barrel and rod instead
        self.perturb = mujoco.MjvPerturb()
        maxgeom = sum(a.model.ngeom + a.model.nsite + a.model.nwrap + 2 * len(a.cylinders)
                      for a in self.arms) + _SPARE_GEOMS
        self.scene = mujoco.MjvScene(self.arms[0].model,
                                     maxgeom=maxgeom + len(self.trails) * max_segments())
        self.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = look.shadows
        # reflections on the floor double the cost of a frame and add little
        self.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        self.canvas = Canvas(self.arms[0].model, width, height, samples=look.samples)
        self._next = 0

    def frame(self, k: int) -> np.ndarray:
        """Image of frame ``k``, uint8, shape (height, width, 3); reused by the next call.

        Frames must be drawn in order (0, 1, 2, ...): the paths grow as they go.
        """
        if k != self._next:
            raise ValueError(f"frames are drawn in order; expected frame {self._next}, got {k}")
        self._next += 1
        for arm, motion, trail in zip(self.arms, self.motions, self.trails):
            for q in motion.samples_between(k):
                arm.pose(q)
                trail.extend(arm.end_effector_position)
        scene, all_geoms = self.scene, int(mujoco.mjtCatBit.mjCAT_ALL)
        for i, (arm, motion) in enumerate(zip(self.arms, self.motions)):
            arm.pose(motion.q[k])
            start = scene.ngeom
            if i == 0:
                mujoco.mjv_updateScene(arm.model, arm.data, self.option, None, self.cameras[0],
                                       all_geoms, scene)
                start = 0
            else:
                mujoco.mjv_addGeoms(arm.model, arm.data, self.option, self.perturb,
                                    int(mujoco.mjtCatBit.mjCAT_DYNAMIC), scene)
            arm.colour(scene, start, motion.modes[k], self.tints[i])
            arm.add_cylinders(scene, self.tints[i])
        for arm, trail in zip(self.arms, self.trails):
            tip = arm.end_effector_position
            trail.add_to(scene, tip)
            trail.extend(tip)
        return self.canvas.draw(scene)

    def close(self) -> None:
        """Free the OpenGL context."""
        self.canvas.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()

