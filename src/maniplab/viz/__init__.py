"""Offscreen animation of runs: videos of one run, grids and overlays of several, as MP4 or GIF.

Rendering samples the stored states of a :class:`~maniplab.sim.run.Run` at the video's frame rate
(nothing is simulated again) and draws them with MuJoCo's OpenGL renderer, offscreen: with
``MUJOCO_GL=egl`` it runs on a machine without a display or GPU (Mesa's software rasteriser).

    frames = render(run, width=1280, height=720, fps=30)          # (F, 720, 1280, 3) uint8
    write_video(frames, "out/a.mp4")
    write_video(iter_grid([run_a, run_b]), "out/compare.mp4")     # streamed: one frame in memory

:func:`tracking_figure` plots closed-loop runs against their reference (``maniplab control``'s
figure).
"""

from __future__ import annotations

from maniplab.viz.camera import AUTO, Framing
from maniplab.viz.compare import (
    captions,
    frame_runs,
    grid_layout,
    iter_grid,
    iter_overlay,
    render_grid,
    render_overlay,
)
from maniplab.viz.gl import RenderError
from maniplab.viz.render import iter_frames, render
from maniplab.viz.tracking import tracking_figure
from maniplab.viz.video import write_video

__all__ = [
    "AUTO",
    "Framing",
    "RenderError",
    "captions",
    "frame_runs",
    "grid_layout",
    "iter_frames",
    "iter_grid",
    "iter_overlay",
    "render",
    "render_grid",
    "render_overlay",
    "tracking_figure",
    "write_video",
]
