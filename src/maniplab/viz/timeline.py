"""Video time: frame times, and a run's states sampled at them (rendering never re-simulates).

Frame k shows time ``t0 + k / fps``; a video of a run from t0 to t1 has ``floor((t1 - t0) fps) + 1``
frames, so the first and the last state are both shown (a 10 s run at 30 fps gives 301 frames).
Joint positions are interpolated linearly between the run's samples; discrete states (friction
mode) are held: a frame shows the mode of the last sample at or before its time.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from maniplab.friction.modes import FrictionMode
from maniplab.sim.run import Run
from maniplab.spec import ManipulatorSpec
from maniplab.viz.gl import RenderError

_TIME_TOLERANCE = 1e-9  # s per s of run time: t0 + k/fps and the run's own sample times agree


def frame_times(t0: float, t1: float, fps: float) -> np.ndarray:
    """Times of the frames of a video from ``t0`` to ``t1`` s at ``fps``; shape (F,), s."""
    if not (fps > 0 and math.isfinite(fps)):
        raise RenderError(f"fps must be a positive number, got {fps}")
    if not t1 >= t0:
        raise RenderError(f"the run ends ({t1} s) before it starts ({t0} s)")
    count = math.floor((t1 - t0) * fps + 1e-6) + 1
    return t0 + np.arange(count) / fps


def run_span(runs: list[Run]) -> tuple[float, float]:
    """First and last time over ``runs``, s."""
    for run in runs:
        if len(run.t) == 0:
            raise RenderError(f"run '{run.label}' has no samples")
    return min(float(r.t[0]) for r in runs), max(float(r.t[-1]) for r in runs)


def sample_positions(run: Run, times: np.ndarray) -> np.ndarray:
    """Joint positions at ``times``, linearly interpolated (held before the first and after the last
    sample); shape (F, n), rad or m."""
    q = np.asarray(run.q, dtype=float)
    if q.ndim != 2 or q.shape[1] != run.spec.n:
        raise RenderError(f"run '{run.label}': q has shape {q.shape}; expected (N, {run.spec.n})")
    return np.column_stack([np.interp(times, run.t, q[:, j]) for j in range(q.shape[1])])


def sample_modes(run: Run, times: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Friction/limit mode of each joint at ``times``; shape (F, n), :class:`FrictionMode` values.

    Uses the run's ``mode`` signal (held from the last sample at or before each time). A run without
    one (e.g. torque-driven) is SLIP everywhere except at or beyond a joint limit, judged from ``q``
    (shape (F, n)).
    """
    if "mode" in run:
        modes = np.asarray(run["mode"]).astype(int)
        if modes.shape != (len(run.t), run.spec.n):
            raise RenderError(f"run '{run.label}': mode has shape {modes.shape}; expected "
                              f"({len(run.t)}, {run.spec.n})")
        tolerance = _TIME_TOLERANCE * max(1.0, float(np.max(np.abs(run.t))))
        index = np.searchsorted(run.t, times + tolerance, side="right") - 1
        return modes[np.clip(index, 0, len(run.t) - 1)]
    return limit_modes(run.spec, q)


def limit_modes(spec: ManipulatorSpec, q: np.ndarray) -> np.ndarray:
    """AT_LOWER / AT_UPPER where ``q`` (shape (F, n)) is at or beyond a joint's limit, else SLIP."""
    modes = np.full(q.shape, int(FrictionMode.SLIP))
    for j, joint in enumerate(spec.joints):
        if joint.limits is None:
            continue
        lo, hi = joint.limits
        margin = 1e-9 * max(hi - lo, 1.0)
        modes[q[:, j] <= lo + margin, j] = int(FrictionMode.AT_LOWER)
        modes[q[:, j] >= hi - margin, j] = int(FrictionMode.AT_UPPER)
    return modes


@dataclasses.dataclass(frozen=True, eq=False)
class Motion:
    """A run sampled at the frames of a video.

    Attributes:
        run: the run.
        times: frame times, s, shape (F,).
        q: joint positions, rad or m, shape (F, n).
        modes: :class:`FrictionMode` values per joint, shape (F, n).
    """

    run: Run
    times: np.ndarray
    q: np.ndarray
    modes: np.ndarray

    def samples_between(self, k: int, most: int = 200) -> np.ndarray:
        """The run's own joint positions at its samples strictly between frames k-1 and k (none for
        k = 0), at most ``most`` of them (evenly thinned); shape (m, n), rad or m.

        A path traced through these stays true to the run at any frame rate.
        """
        if k == 0:
            return np.zeros((0, self.q.shape[1]))
        t = self.run.t
        lo = int(np.searchsorted(t, self.times[k - 1], side="right"))
        hi = int(np.searchsorted(t, self.times[k], side="left"))
        step = max(1, -(-(hi - lo) // most))
        return np.asarray(self.run.q, dtype=float)[lo:hi:step]


def sample(run: Run, times: np.ndarray) -> Motion:
    """``run`` at ``times`` (shape (F,), s)."""
    q = sample_positions(run, times)
    return Motion(run, times, q, sample_modes(run, times, q))
