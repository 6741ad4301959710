"""Comparison videos of several runs: a grid of tiles side by side, or an overlay with ghosts.

Both share one clock (from the earliest start to the latest end; a run that ended holds its last
state) and, with the automatic camera, one framing of all the motions, so equal poses look equal.
Each run is named by the parameters in which it differs from the others (:func:`captions`), as in
the comparison plots (:mod:`maniplab.viz.plots`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from maniplab.sim import params
from maniplab.sim.run import Run
from maniplab.viz import overlay_text as text
from maniplab.viz import palette
from maniplab.viz.arm import ArmView
from maniplab.viz.camera import AUTO, Framing, frame_motions
from maniplab.viz.frames import FrameStream, collect
from maniplab.viz.gl import RenderError
from maniplab.viz.look import Look
from maniplab.viz.plot_strip import PlotStrip, select
from maniplab.viz.render import SceneComposition, check_size, state_key, strip_height
from maniplab.viz.scene import SceneView
from maniplab.viz.timeline import Motion, frame_times, run_span, sample

# --- captions -----------------------------------------------------------------------------------


def parameters(run: Run) -> dict[str, Any]:
    """The run's parameters as flat dotted paths: the spec's, then ``meta.*`` scalars (its label
    left out), as :meth:`maniplab.sim.runset.RunSet.parameters` gives them."""
    flat = params.flatten_spec(run.spec)
    flat.update({f"meta.{k}": v for k, v in run.meta.items()
                 if k != "label" and isinstance(v, (str, int, float, bool))})
    return flat


def captions(runs: Sequence[Run]) -> list[str]:
    """One line per run naming the parameters in which it differs from the others
    ("payload=3000, q2 leakage=1e-11"); the runs' labels when nothing differs."""
    names = [run.label for run in runs]
    if len(runs) < 2:
        return names
    return params.labels([parameters(run) for run in runs], names)


# --- grid ---------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class GridLayout:
    """Where the parts of a grid frame go, pixels.

    Attributes:
        cols: tiles per row.
        rows: rows of tiles.
        header: height of the top bar (time stamp, joint-state key); 0 without text.
        band: height of a tile's caption band.
        tile_width: width of a tile's 3-D view.
        tile_height: height of a tile's 3-D view (the band is above it).
        strip: height of the plot strip at the bottom; 0 without one.
    """

    cols: int
    rows: int
    header: int
    band: int
    tile_width: int
    tile_height: int
    strip: int

    def view_origin(self, k: int) -> tuple[int, int]:
        """Column and row of the top-left pixel of tile ``k``'s 3-D view."""
        row, col = divmod(k, self.cols)
        return col * self.tile_width, self.header + row * (self.band + self.tile_height) + self.band


DEFAULT_ASPECT = 4.0 / 3.0
"""Motion aspect assumed for a grid's layout when the camera is not the automatic one."""


def grid_layout(count: int, width: int, height: int, *, cols: int | None = None,
                text_bar: bool = True, plot: str | None = None,
                aspect: float = DEFAULT_ASPECT) -> GridLayout:
    """The layout of ``count`` tiles in a ``width`` x ``height`` frame.

    Without ``cols``, the number of columns that shows the arms largest: the one whose tiles hold
    the largest picture of width/height ``aspect`` (the motion's, as the camera sees it).

    Raises:
        RenderError: the tiles would be too small.
    """
    band = text.text_patch("Ag", caption_size(height)).shape[0]
    header = band if text_bar else 0
    strip = strip_height(height, plot)
    free = height - header - strip

    def tile(c: int) -> tuple[int, int]:
        return width // c, free // math.ceil(count / c) - band

    if cols is None:
        cols = max(range(1, count + 1), key=lambda c: min(tile(c)[0], tile(c)[1] * aspect))
    if cols < 1:
        raise RenderError(f"cols must be at least 1, got {cols}")
    tile_width, tile_height = tile(cols)
    if tile_width < 8 or tile_height < 8:
        raise RenderError(f"{count} tiles do not fit a {width}x{height} frame; render a larger one")
    return GridLayout(cols, math.ceil(count / cols), header, band, tile_width, tile_height, strip)


def caption_size(height: int) -> int:
    """Font size of the captions in a frame ``height`` pixels high."""
    return max(9, round(0.8 * text.font_size(height)))


def frame_runs(runs: Sequence[Run], fps: float = 30.0) -> Framing:
    """The automatic camera's framing of all ``runs`` together, as grids and overlays use it."""
    runs = _non_empty(runs)
    times = frame_times(*run_span(runs), fps)
    return _auto_framing([sample(run, times) for run in runs])


class Grid:
    """The composition of a grid video (see :func:`render_grid` for the arguments)."""

    def __init__(self, runs: Sequence[Run], width: int, height: int, fps: float, look: Look,
                 cols: int | None = None) -> None:
        check_size(width, height)
        runs = _non_empty(runs)
        self.width, self.height = width, height
        t0, t1 = run_span(runs)
        self.times = frame_times(t0, t1, fps)
        motions = [sample(run, self.times) for run in runs]
        look = dataclasses.replace(look, camera=_shared_camera(look.camera, motions))
        aspect = look.camera.aspect if isinstance(look.camera, Framing) else DEFAULT_ASPECT
        self.layout = layout = grid_layout(len(runs), width, height, cols=cols,
                                           text_bar=look.text, plot=look.plot, aspect=aspect)
        size = caption_size(height)
        self.captions = [text.text_patch(c, size, background=palette.BACKGROUND,
                                         swatch=palette.run_colour(k), width=layout.tile_width)
                         for k, c in enumerate(captions(runs))]
        self.stamp_size = size if look.text else 0
        modes = np.concatenate([m.modes for m in motions], axis=1)
        self.key = state_key(modes, size) if look.text else None
        self.strip = _strip(runs, look.plot, width, layout.strip, t0, t1)
        self.views: list[SceneView] = []
        try:
            for motion in motions:
                self.views.append(SceneView([motion], layout.tile_width, layout.tile_height, look))
        except BaseException:
            self.close()
            raise

    def compose(self, k: int, out: np.ndarray) -> None:
        """Draw frame ``k`` into ``out`` (uint8, shape (height, width, 3))."""
        layout = self.layout
        out[:] = palette.to_uint8(palette.BACKGROUND)
        for i, view in enumerate(self.views):
            x, y = layout.view_origin(i)
            out[y:y + layout.tile_height, x:x + layout.tile_width] = view.frame(k)
            text.blend(out, self.captions[i], x, y - layout.band)
        if self.stamp_size:
            stamp = text.text_patch(f"t = {self.times[k]:.2f} s", self.stamp_size,
                                    background=palette.BACKGROUND)
            text.blend(out, stamp, self.width - stamp.shape[1], 0)
        if self.key is not None:
            text.blend(out, self.key, 0, 0)
        if self.strip is not None:
            self.strip.draw(out[self.height - layout.strip:], self.times[k])

    def close(self) -> None:
        """Free the OpenGL contexts."""
        for view in self.views:
            view.close()


def render_grid(runs: Sequence[Run], *, width: int = 1280, height: int = 720, fps: float = 30.0,
                camera: str | Framing = AUTO, cols: int | None = None, shadows: bool = False,
                antialias: bool = True, trace: bool = True, text: bool = True,
                plot: str | None = None, progress: bool | None = None) -> np.ndarray:
    """Frames of a video with one tile per run, side by side, each captioned with what differs.

    Args:
        runs: the runs (any arms; usually variants of one).
        width: frame width, pixels.
        height: frame height, pixels (top bar, captions and plot strip included).
        fps: frames per second.
        camera: as in :func:`~maniplab.viz.render.render`; "auto" frames all runs alike
            (:func:`frame_runs`).
        cols: tiles per row (default: the layout with the largest tiles).
        shadows: draw shadows.
        antialias: smooth edges (4x multisampling).
        trace: draw each end-effector's path.
        text: a top bar with the time stamp and the joint-state key.
        plot: a strip of one signal under the tiles, a curve per run in its colour ("q:q2").
        progress: show a progress bar (default: when stderr is a terminal).

    Returns:
        uint8 RGB frames, shape (F, height, width, 3). Tile k's 3-D view is
        ``render(runs[k], camera=frame_runs(runs, fps), text=False)`` at the tile's size
        (:func:`grid_layout`).
    """
    look = Look(camera, shadows, antialias, trace, text, plot)
    grid = Grid(runs, width, height, fps, look, cols)
    return collect(grid, f"rendering {len(grid.views)} runs", progress)


def iter_grid(runs: Sequence[Run], *, width: int = 1280, height: int = 720, fps: float = 30.0,
              camera: str | Framing = AUTO, cols: int | None = None, shadows: bool = False,
              antialias: bool = True, trace: bool = True, text: bool = True,
              plot: str | None = None, progress: bool | None = None) -> FrameStream:
    """The frames of :func:`render_grid` one at a time."""
    look = Look(camera, shadows, antialias, trace, text, plot)
    grid = Grid(runs, width, height, fps, look, cols)
    return FrameStream(grid, f"rendering {len(grid.views)} runs", progress)


# --- overlay ------------------------------------------------------------------------------------


class Overlay(SceneComposition):
    """The composition of an overlay video (see :func:`render_overlay` for the arguments)."""

    def __init__(self, runs: Sequence[Run], width: int, height: int, fps: float,
                 look: Look) -> None:
        check_size(width, height)
        runs = _non_empty(runs)
        self.width, self.height = width, height
        t0, t1 = run_span(runs)
        self.times = frame_times(t0, t1, fps)
        motions = [sample(run, self.times) for run in runs]
        strip = strip_height(height, look.plot)
        self.view_height = height - strip
        self.font = text.font_size(self.view_height)
        size = caption_size(self.view_height)
        names = captions(runs)
        if len(runs) > 1:
            names[0] += " (solid)"
        self.runs_key = _stack([text.text_patch(c, size, swatch=palette.run_colour(k),
                                                width=width // 2) for k, c in enumerate(names)])
        self.text = look.text
        modes = np.concatenate([m.modes for m in motions], axis=1)
        self.key = state_key(modes, size) if look.text else None
        self.strip = _strip(runs, look.plot, width, strip, t0, t1)
        look = dataclasses.replace(look, camera=_shared_camera(look.camera, motions))
        self.view = SceneView(motions, width, self.view_height, look)


def render_overlay(runs: Sequence[Run], *, width: int = 1280, height: int = 720,
                   fps: float = 30.0, camera: str | Framing = AUTO, shadows: bool = False,
                   antialias: bool = True, trace: bool = True, text: bool = True,
                   plot: str | None = None, progress: bool | None = None) -> np.ndarray:
    """Frames of a video with all runs in one scene: the first solid, the others as ghosts.

    Each variant is a translucent ghost in its run colour (the key at the top right names what
    differs); joint states keep their colours; each end-effector path is traced in its run colour.
    Arguments as in :func:`render_grid` (``text``: time stamp, run key and joint-state key).

    Returns:
        uint8 RGB frames, shape (F, height, width, 3).
    """
    look = Look(camera, shadows, antialias, trace, text, plot)
    overlay = Overlay(runs, width, height, fps, look)
    return collect(overlay, f"rendering {len(runs)} runs", progress)


def iter_overlay(runs: Sequence[Run], *, width: int = 1280, height: int = 720,
                 fps: float = 30.0, camera: str | Framing = AUTO, shadows: bool = False,
                 antialias: bool = True, trace: bool = True, text: bool = True,
                 plot: str | None = None, progress: bool | None = None) -> FrameStream:
    """The frames of :func:`render_overlay` one at a time."""
    look = Look(camera, shadows, antialias, trace, text, plot)
    overlay = Overlay(runs, width, height, fps, look)
    return FrameStream(overlay, f"rendering {len(runs)} runs", progress)


# --- shared -------------------------------------------------------------------------------------


def _non_empty(runs: Sequence[Run]) -> list[Run]:
    runs = list(runs)
    if not runs:
        raise RenderError("no runs to render")
    return runs


def _shared_camera(camera: str | Framing, motions: Sequence[Motion]) -> str | Framing:
    """The automatic camera framed once for all motions; other cameras unchanged."""
    if isinstance(camera, str) and camera == AUTO:
        return _auto_framing(motions)
    return camera


def _auto_framing(motions: Sequence[Motion]) -> Framing:
    """The automatic camera's framing of all motions together."""
    return frame_motions([ArmView(m.run.spec) for m in motions], motions)


def _strip(runs: Sequence[Run], plot: str | None, width: int, height: int, t0: float,
           t1: float) -> PlotStrip | None:
    if not plot:
        return None
    curves, title = select(runs, plot)
    return PlotStrip(curves, title, width, height, t0, t1)


def _stack(patches: Sequence[np.ndarray]) -> np.ndarray:
    """Patches one above the other, right-aligned; RGBA, shape (sum h, max w, 4)."""
    width = max(p.shape[1] for p in patches)
    return np.concatenate([np.pad(p, ((0, 0), (width - p.shape[1], 0), (0, 0))) for p in patches])
