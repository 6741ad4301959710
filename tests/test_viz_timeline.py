"""Video time: frame counts, interpolated positions, held modes, limits (no OpenGL)."""

from __future__ import annotations

import numpy as np
import pytest

import maniplab as ml
from maniplab.friction.modes import FrictionMode
from maniplab.sim.run import Run
from maniplab.viz.gl import RenderError
from maniplab.viz.timeline import frame_times, limit_modes, sample


def run_of(t: np.ndarray, q: np.ndarray, mode: np.ndarray | None = None,
           spec: str = "planar2") -> Run:
    signals = {"q": q} if mode is None else {"q": q, "mode": mode}
    return Run(t=t, signals=signals, spec=ml.builtin_spec(spec))


@pytest.mark.parametrize(("t0", "t1", "fps", "count"), [
    (0.0, 10.0, 30.0, 301),  # both ends shown
    (0.0, 1.0, 10.0, 11),
    (0.0, 0.999, 10.0, 10),  # the last state falls between frames
    (2.0, 2.0, 25.0, 1),  # a single sample: one frame
    (0.0, 0.3, 10.0, 4),  # 0.3 * 10 = 2.9999999999999996 in floating point
])
def test_frame_count(t0: float, t1: float, fps: float, count: int) -> None:
    times = frame_times(t0, t1, fps)
    assert len(times) == count and times[0] == t0
    np.testing.assert_allclose(np.diff(times), 1.0 / fps)


@pytest.mark.parametrize("fps", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_fps(fps: float) -> None:
    with pytest.raises(RenderError, match="fps"):
        frame_times(0.0, 1.0, fps)


def test_positions_are_interpolated_and_held_beyond_the_ends() -> None:
    t = np.array([0.0, 1.0, 2.0])
    q = np.array([[0.0, 1.0], [1.0, 1.0], [3.0, -1.0]])
    motion = sample(run_of(t, q), np.array([-1.0, 0.5, 1.5, 2.0, 5.0]))
    np.testing.assert_allclose(motion.q, [[0, 1], [0.5, 1], [2, 0], [3, -1], [3, -1]])


def test_modes_are_held_from_the_last_sample_at_or_before_each_frame() -> None:
    t = np.arange(11) / 10  # 0.0 ... 1.0 s, 10 Hz, as floats that are not multiples of 1/30
    mode = np.zeros((11, 2), dtype=int)
    mode[3:6, 1] = FrictionMode.STICK  # t = 0.3, 0.4, 0.5
    times = np.arange(31) / 30  # frames at 30 fps
    motion = sample(run_of(t, np.zeros((11, 2)), mode), times)
    sticking = np.flatnonzero(motion.modes[:, 1] == FrictionMode.STICK)
    # frames at 0.3 s (k = 9) through the last before 0.6 s (k = 17)
    assert sticking.tolist() == list(range(9, 18))
    assert not motion.modes[:, 0].any()


def test_a_mode_signal_of_the_wrong_shape_is_an_error() -> None:
    t = np.arange(3.0)
    with pytest.raises(RenderError, match=r"mode has shape \(3, 1\); expected \(3, 2\)"):
        sample(run_of(t, np.zeros((3, 2)), np.zeros((3, 1))), t)


def test_without_a_mode_signal_limits_come_from_the_positions() -> None:
    spec = ml.builtin_spec("crane3")  # slew [-3, 3], luff [-1.3, 0.3], telescope [0, 2]
    q = np.array([[0.0, 0.0, 1.0], [3.0, -1.3, 0.0], [3.5, 0.3, 2.0]])
    modes = limit_modes(spec, q)
    up, low, slip = FrictionMode.AT_UPPER, FrictionMode.AT_LOWER, FrictionMode.SLIP
    assert modes.tolist() == [[slip, slip, slip], [up, low, low], [up, up, up]]
    motion = sample(run_of(np.arange(3.0), q, spec="crane3"), np.arange(3.0))
    assert np.array_equal(motion.modes, modes)


def test_samples_between_frames_are_the_runs_own() -> None:
    t = np.arange(11) / 10  # 10 Hz
    q = np.column_stack([t, -t])
    motion = sample(run_of(t, q), frame_times(0.0, 1.0, 2.5))  # frames at 0, 0.4, 0.8 s
    assert motion.samples_between(0).shape == (0, 2)
    np.testing.assert_allclose(motion.samples_between(1)[:, 0], [0.1, 0.2, 0.3])
    np.testing.assert_allclose(motion.samples_between(2)[:, 0], [0.5, 0.6, 0.7])
    np.testing.assert_allclose(motion.samples_between(2, most=2)[:, 0], [0.5, 0.7])
