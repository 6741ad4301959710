"""Videos of one run: the arm's motion, a time stamp, the joint-state key and a plot strip."""

from __future__ import annotations

import numpy as np

from maniplab.sim.run import Run
from maniplab.viz import overlay_text as text
from maniplab.viz import palette
from maniplab.viz.camera import AUTO, Framing
from maniplab.viz.frames import FrameStream, collect
from maniplab.viz.gl import RenderError
from maniplab.viz.look import Look
from maniplab.viz.plot_strip import PlotStrip, select
from maniplab.viz.scene import SceneView
from maniplab.viz.timeline import frame_times, run_span, sample

STRIP = 0.25
"""Height of the plot strip, fraction of the frame height."""


def render(run: Run, *, width: int = 1280, height: int = 720, fps: float = 30.0,
           camera: str | Framing = AUTO, shadows: bool = False, antialias: bool = True,
           trace: bool = True, text: bool = True, plot: str | None = None,
           progress: bool | None = None) -> np.ndarray:
    """Frames of a video of ``run``, sampled from its stored states (nothing is simulated).

    Args:
        run: the run; its spec gives the arm.
        width: frame width, pixels.
        height: frame height, pixels (the plot strip, if any, included).
        fps: frames per second; frame k shows time ``run.t[0] + k / fps``.
        camera: "auto" (frames the whole motion), a camera of the model ("track" follows the arm's
            centre of mass, "overview" is fixed), or a :class:`~maniplab.viz.camera.Framing`.
        shadows: draw shadows (about half the frame rate on a software renderer).
        antialias: smooth edges by 4x multisampling (without it, about 2.5x the frame rate on a
            software renderer, with jagged edges).
        trace: draw the end-effector's path.
        text: draw the time stamp (top left) and the key to the joint-state colours (bottom left).
        plot: draw a strip of one signal under the animation, "SIGNAL" or "SIGNAL:COLUMN"
            (e.g. "q", "q:q2", "dP:q1", "ee_pos:z").
        progress: show a progress bar (default: when stderr is a terminal).

    Returns:
        uint8 RGB frames, shape (F, height, width, 3), F = floor(duration * fps) + 1.

    Raises:
        RenderError: no OpenGL backend can start, an unknown camera or signal, a bad size or fps.
    """
    look = Look(camera, shadows, antialias, trace, text, plot)
    return collect(SingleRun(run, width, height, fps, look), f"rendering {run.label}", progress)


def iter_frames(run: Run, *, width: int = 1280, height: int = 720, fps: float = 30.0,
                camera: str | Framing = AUTO, shadows: bool = False, antialias: bool = True,
                trace: bool = True, text: bool = True, plot: str | None = None,
                progress: bool | None = None) -> FrameStream:
    """The frames of :func:`render` one at a time (for long videos: memory stays at one frame)."""
    look = Look(camera, shadows, antialias, trace, text, plot)
    return FrameStream(SingleRun(run, width, height, fps, look), f"rendering {run.label}",
                       progress)


def check_size(width: int, height: int) -> None:
    """Raise RenderError unless ``width`` and ``height`` are positive integers."""
    for name, value in (("width", width), ("height", height)):
        if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < 1:
            raise RenderError(f"{name} must be a positive number of pixels, got {value!r}")


def strip_height(height: int, plot: str | None) -> int:
    """Pixels of a frame ``height`` high taken by the plot strip."""
    return round(STRIP * height) if plot else 0


def state_key(modes: np.ndarray, size: int) -> np.ndarray | None:
    """Key to the joint-state colours that occur in ``modes`` (any shape), RGBA patch, or None."""
    entries = []
    if np.any(modes == 1):
        entries.append(("stick", palette.STICK))
    if np.any(modes >= 2):
        entries.append(("at limit", palette.LIMIT))
    if not entries:
        return None
    patches = [text.text_patch(label, size, swatch=colour) for label, colour in entries]
    height = max(p.shape[0] for p in patches)
    return np.concatenate([np.pad(p, ((0, height - p.shape[0]), (0, 0), (0, 0))) for p in patches],
                          axis=1)


class SceneComposition:
    """Drawing shared by one-scene videos: the scene, the time stamp, the joint-state key, an
    optional key of the runs (top right) and the plot strip. Subclasses set the attributes."""

    width: int
    height: int
    times: np.ndarray  # frame times, s, shape (F,)
    view_height: int  # pixels above the plot strip
    font: int  # font size of the time stamp, pixels
    text: bool  # draw the time stamp and the keys
    key: np.ndarray | None  # the joint-state key, RGBA patch
    strip: PlotStrip | None
    view: SceneView
    runs_key: np.ndarray | None = None

    def compose(self, k: int, out: np.ndarray) -> None:
        """Draw frame ``k`` into ``out`` (uint8, shape (height, width, 3))."""
        view = out[:self.view_height]
        view[:] = self.view.frame(k)
        margin = self.font // 2
        if self.text:
            if self.runs_key is not None:
                text.blend(view, self.runs_key, -margin, margin)
            text.blend(view, text.stamp(self.times[k], self.font), margin, margin)
        if self.key is not None:
            text.blend(view, self.key, margin, -margin)
        if self.strip is not None:
            self.strip.draw(out[self.view_height:], self.times[k])

    def close(self) -> None:
        """Free the OpenGL context."""
        self.view.close()


class SingleRun(SceneComposition):
    """The composition of one run's video (see :func:`render` for the arguments)."""

    def __init__(self, run: Run, width: int, height: int, fps: float, look: Look) -> None:
        check_size(width, height)
        self.width, self.height = width, height
        t0, t1 = run_span([run])
        self.times = frame_times(t0, t1, fps)
        motion = sample(run, self.times)
        self.view_height = height - strip_height(height, look.plot)
        self.strip = None
        if look.plot:
            curves, title = select([run], look.plot)
            self.strip = PlotStrip(curves, title, width, height - self.view_height, t0, t1)
        self.font = text.font_size(self.view_height)
        self.text = look.text
        self.key = state_key(motion.modes, self.font) if look.text else None
        self.view = SceneView([motion], width, self.view_height, look)
