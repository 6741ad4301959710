"""The 3-D view of one or more runs at each frame: arms, joint states, paths, camera and lights.

One run is drawn as it is (links in their colours, joints by state). Several runs in one scene
(an overlay) draw the first as the reference and the others as translucent ghosts, each in its
run colour; the floor, base, lights and camera are the first run's.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from maniplab.viz import camera as cameras
from maniplab.viz import palette
from maniplab.viz.arm import ArmView
from maniplab.viz.canvas import Canvas
from maniplab.viz.look import Look
from maniplab.viz.timeline import Motion
from maniplab.viz.trail import Trail, line_width, max_segments

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
        camera = look.camera
        self.arms = [ArmView(m.run.spec) for m in self.motions]
        framing = camera if isinstance(camera, cameras.Framing) else None
        if camera == cameras.AUTO:
            framing = cameras.frame_motions(self.arms, self.motions)
        self.cameras = cameras.resolve(framing or camera, self.arms, width / height)
        scale = framing.size if framing else _scale(self.arms[0])
        single = len(self.motions) == 1
        self.trails = [Trail(scale, line_width(height),
                             palette.PATH if single else palette.run_colour(k))
                       for k in range(len(self.motions))] if look.trace else []
        self.tints = [None] + [palette.run_colour(k) for k in range(1, len(self.motions))]
        self.option = mujoco.MjvOption()
        self.perturb = mujoco.MjvPerturb()
        maxgeom = sum(a.model.ngeom + a.model.nsite for a in self.arms) + _SPARE_GEOMS
        self.scene = mujoco.MjvScene(self.arms[0].model,
                                     maxgeom=maxgeom + len(self.trails) * max_segments())
        self.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = look.shadows
        # reflections on the floor double the cost of a frame and add little
        self.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        self.canvas = Canvas(self.arms[0].model, width, height, samples=look.samples)
        self._next = 0

    @property
    def frame_count(self) -> int:
        """F, the number of frames."""
        return len(self.motions[0].times)

    def frame(self, k: int) -> np.ndarray:
        """Image of frame ``k``, uint8, shape (height, width, 3); reused by the next call.

        Frames must be drawn in order (0, 1, 2, ...): the paths grow as they go.
        """
        if k != self._next:
            raise ValueError(f"frames are drawn in order; expected frame {self._next}, got {k}")
        self._next += 1
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
        for arm, trail in zip(self.arms, self.trails):
            tip = arm.end_effector_position
            trail.add_to(scene, tip)
            trail.extend(tip)
        return self.canvas.draw(scene)

    def close(self) -> None:
        """Free the OpenGL context."""
        self.canvas.close()

    def __enter__(self) -> SceneView:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


def _scale(arm: ArmView) -> float:
    """Size of the scene for a named camera: the model's extent, m."""
    return float(arm.model.stat.extent)
