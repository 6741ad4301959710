"""Runs replayed in 3D: the first run solid, the others as ghosts in their comparison colours, each
joint coloured by its stick/slip/limit state, the end-effector paths traced.

:class:`Replay` drives the GUI's Watch tab (frame by frame, from the timeline). The
self-contained HTML replays (:func:`maniplab.gui.player.replay_html`) have a player of their own
(:mod:`maniplab.gui.player`: WebGL, every frame's poses computed by MuJoCo and inline), with
play, pause, a scrubbing slider and a speed control; both frame the arms alike
(:func:`framing`). The page needs no network and no server.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import math
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from maniplab.errors import ManiplabError
from maniplab.gui.arm3d import Arm3D
from maniplab.sim.run import Run
from maniplab.spec import ManipulatorSpec
from maniplab.viz import palette
from maniplab.viz.timeline import Motion, frame_times, run_span, sample

PATH_WIDTH = 0.03
"""Width of a traced end-effector path, m."""

MAX_FRAMES = 3000
"""Frames a replay holds at most (100 s at 30 fps): an HTML replay stays a few megabytes."""


class ReplayError(ManiplabError):
    """Runs that cannot be replayed (none, or no samples)."""


class Replay:
    """Runs in one scene, shown at frame times ``t0 + k / fps``.

    Args:
        scene: a viser scene API.
        runs: the runs (at least one); run k > 0 is drawn as a ghost of colour ``run_colour(k)``.
        fps: frames per second of run time, 1/s (lowered so that at most :data:`MAX_FRAMES`).
        prefix: scene-tree name under which the arms go.
    """

    def __init__(self, scene: Any, runs: Sequence[Run], fps: float = 30.0,
                 prefix: str = "/replay") -> None:
        self.fps, self.times = replay_frames(runs, fps)
        self.motions: list[Motion] = [sample(run, self.times) for run in runs]
        self.arms = [Arm3D(scene, f"{prefix}/run{k}", run.spec,
                           tint=None if k == 0 else palette.run_colour(k))
                     for k, run in enumerate(runs)]
        self.traced = [_end_effector(arm, motion) for arm, motion in zip(self.arms, self.motions)]
        self.paths = [scene.add_line_segments(
            f"{prefix}/path{k}", points=_segments(points),
            colors=palette.to_uint8(palette.PATH if len(runs) == 1 else palette.run_colour(k)),
            thickness=PATH_WIDTH) for k, points in enumerate(self.traced)]
        self.show(0)

    @property
    def frames(self) -> int:
        """Number of frames."""
        return len(self.times)

    def frame_at(self, t: float) -> int:
        """The frame showing time ``t`` (s), clamped to the replay."""
        k = math.floor((t - float(self.times[0])) * self.fps + 1e-6)
        return int(min(max(k, 0), self.frames - 1))

    def show(self, frame: int) -> None:
        """Pose every arm at frame ``frame``."""
        for arm, motion in zip(self.arms, self.motions):
            arm.pose(motion.q[frame], motion.modes[frame])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The box of every arm at the frame shown and of every traced path, m."""
        boxes = [arm.bounds() for arm in self.arms]
        lo = np.min([b[0] for b in boxes] + [p.min(axis=0) for p in self.traced], axis=0)
        hi = np.max([b[1] for b in boxes] + [p.max(axis=0) for p in self.traced], axis=0)
        return lo, hi

    def remove(self) -> None:
        """Take the replay out of the scene."""
        for arm in self.arms:
            arm.remove()
        for path in self.paths:
            path.remove()


def replay_frames(runs: Sequence[Run], fps: float) -> tuple[float, np.ndarray]:
    """The frame rate (``fps``, 1/s, lowered so that at most :data:`MAX_FRAMES`) and the frame
    times, s, shape (F,), of a replay of ``runs``; ReplayError when there is none to replay."""
    if not runs:
        raise ReplayError("no runs to replay: select at least one")
    try:
        t0, t1 = run_span(list(runs))
    except ManiplabError as exc:
        raise ReplayError(str(exc)) from None
    fps = min(fps, (MAX_FRAMES - 1) / max(t1 - t0, 1e-9))
    return fps, frame_times(t0, t1, fps)


def _end_effector(arm: Arm3D, motion: Motion) -> np.ndarray:
    """End-effector positions at the frames, m, shape (F, 3)."""
    points = np.empty((len(motion.times), 3))
    for k, q in enumerate(motion.q):
        arm.view.pose(q)
        points[k] = arm.end_effector
    return points


def _segments(points: np.ndarray) -> np.ndarray:
    """Consecutive points joined, shape (F-1, 2, 3) (one degenerate segment for a single point)."""
    if len(points) < 2:
        return np.repeat(points[:1, None, :], 2, axis=1).astype(np.float32)
    return np.stack([points[:-1], points[1:]], axis=1).astype(np.float32)


def reach(spec: ManipulatorSpec) -> float:
    """The arm's length: its bodies end to end, m (at least 1)."""
    return max(sum(j.body.length for j in spec.joints if j.body), 1.0)


def up_axis(spec: ManipulatorSpec) -> int:
    """Index (0, 1, 2) of the world axis closest to straight up (against gravity; z without)."""
    gravity = np.asarray(spec.gravity, dtype=float)
    return int(np.argmax(np.abs(gravity))) if np.any(gravity) else 2


FOV = 50.0
"""The camera's vertical field of view, degrees (a photographer's normal lens: less distortion
than viser's 75)."""


@dataclasses.dataclass(frozen=True)
class Framing:
    """Where a scene of arms is looked at from, and its floor grid and axes.

    Attributes:
        up_axis: index (0, 1, 2) of the world axis closest to up.
        up: the upward unit vector, shape (3,).
        grid: the floor grid's width, m (square, centred at the origin).
        cell: a grid cell, m.
        section: a grid section (a heavier line), m.
        axes_length, axes_radius: the world axes drawn at the origin, m.
        look_at, position: the camera's target and position, m, each shape (3,).
        fov: the camera's vertical field of view, degrees.
    """

    up_axis: int
    up: np.ndarray
    grid: float
    cell: float
    section: float
    axes_length: float
    axes_radius: float
    look_at: np.ndarray
    position: np.ndarray
    fov: float = FOV


def framing(specs: Sequence[ManipulatorSpec],
            box: tuple[np.ndarray, np.ndarray] | None = None) -> Framing:
    """The framing :func:`stage` sets up for arms ``specs`` (sized to the longest): the camera
    looks from the front right, above, at the middle of ``box`` (the arms' lowest and highest
    points, m) from where the box's enclosing sphere fills the view's height (without a box: at
    the middle of the reach)."""
    first = specs[0] if specs else None
    up = up_axis(first) if first else 2
    sign = -np.sign(first.gravity[up]) if first and first.gravity[up] else 1.0
    axes = np.eye(3)
    upward = sign * axes[up]
    length = max((reach(spec) for spec in specs), default=5.0)
    size = 2.0 * math.ceil(length * 1.2)
    along = axes[0] if up != 0 else axes[1]
    side = np.cross(upward, along)
    direction = 0.4 * along - 0.85 * side + 0.5 * upward
    direction /= np.linalg.norm(direction)
    if box is None:
        middle = 0.4 * length * along + 0.2 * length * upward
        distance = length * float(np.linalg.norm(0.4 * along - 0.85 * side + 0.5 * upward))
    else:
        lo, hi = (np.asarray(b, dtype=float) for b in box)
        middle = 0.5 * (lo + hi)
        radius = max(0.5 * float(np.linalg.norm(hi - lo)), 0.2)
        distance = 1.08 * radius / math.sin(math.radians(FOV) / 2.0)
    return Framing(up_axis=up, up=upward, grid=size, cell=max(size / 40.0, 0.1),
                   section=max(size / 8.0, 0.5), axes_length=max(0.1 * length, 0.2),
                   axes_radius=max(0.004 * length, 0.005), look_at=middle,
                   position=middle + distance * direction)


def stage(server: Any, specs: Sequence[ManipulatorSpec],
          box: tuple[np.ndarray, np.ndarray] | None = None) -> float:
    """The up direction (against gravity), floor grid and initial camera of a scene showing arms
    ``specs``, as :func:`framing` finds them. The world's axes are drawn at the origin (x red,
    y green, z blue). Returns the grid's cell size, m."""
    frame = framing(specs, box)
    server.scene.set_up_direction(tuple(frame.up))
    plane = {0: "yz", 1: "xz", 2: "xy"}[frame.up_axis]
    server.scene.add_grid("/floor", width=frame.grid, height=frame.grid, plane=plane,
                          cell_size=frame.cell, section_size=frame.section)
    server.scene.add_frame("/axes", axes_length=frame.axes_length, axes_radius=frame.axes_radius)
    server.initial_camera.fov = math.radians(frame.fov)
    server.initial_camera.look_at = tuple(frame.look_at)
    server.initial_camera.position = tuple(frame.position)
    server.initial_camera.up = tuple(frame.up)
    return frame.cell


@contextlib.contextmanager
def recording_server() -> Iterator[Any]:
    """A viser server on a free localhost port that no page connects to, for recordings (its
    banners, which viser prints whatever ``verbose`` says, are swallowed)."""
    import viser

    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=_free_port(), verbose=False)
        try:
            yield server
        finally:
            server.stop()


def _free_port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port
