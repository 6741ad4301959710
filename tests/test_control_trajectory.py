"""Minimum-jerk moves, arcs and via-point paths against the closed form and finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from maniplab.control.errors import TrajectoryError
from maniplab.control.kinematics import rotation_exp, rotation_log, rpy_to_matrix
from maniplab.control.trajectory import (
    ArcMove,
    Hold,
    MinJerkMove,
    Path,
    Pose,
    min_jerk,
    segment_placement,
)


def test_min_jerk_closed_form() -> None:
    # s = 10τ³ - 15τ⁴ + 6τ⁵: s(½) = ½, s'(½) = 15/8, peak s'' = 10/√3 at τ = ½ - √3/6
    assert min_jerk(0.0) == (0.0, 0.0, 0.0)
    assert min_jerk(1.0) == pytest.approx((1.0, 0.0, 0.0), abs=1e-15)
    assert min_jerk(0.5) == pytest.approx((0.5, 15 / 8, 0.0), abs=1e-15)
    assert min_jerk(0.5 - math.sqrt(3) / 6)[2] == pytest.approx(10 / math.sqrt(3))
    assert min_jerk(-1.0) == (0.0, 0.0, 0.0) and min_jerk(2.0)[0] == 1.0


def start_goal() -> tuple[Pose, Pose]:
    return (Pose.from_xyzrpy([1.0, 2.0, 0.5, 0.1, -0.2, 0.3]),
            Pose.from_xyzrpy([1.6, 1.2, 0.5, -0.1, 0.1, 0.9]))


def test_min_jerk_move_endpoints_and_midpoint() -> None:
    start, goal = start_goal()
    move = MinJerkMove(start, goal, 4.0, t0=1.0)
    for t, pose in ((0.0, start), (1.0, start), (5.0, goal), (9.0, goal)):
        ref = move.sample(t)
        np.testing.assert_allclose(ref.position, pose.position, atol=1e-14)
        np.testing.assert_allclose(ref.rotation, pose.rotation, atol=1e-14)
        assert not np.any(ref.twist) and np.allclose(ref.accel, 0.0, atol=1e-15)
    mid = move.sample(3.0)
    np.testing.assert_allclose(mid.position, 0.5 * (start.position + goal.position))
    # peak speed of a minimum-jerk move: 15/8 L/T
    assert np.linalg.norm(mid.velocity) == pytest.approx(15 / 8 * 1.0 / 4.0)


def finite_difference(traj, t: float, h: float = 1e-5):
    a, b = traj.sample(t - h), traj.sample(t + h)
    v = (b.position - a.position) / (2 * h)
    acc = (b.velocity - a.velocity) / (2 * h)
    # ω from Ṙ Rᵀ (base axes)
    w = rotation_log(b.rotation @ a.rotation.T) / (2 * h)
    wd = (b.angular_velocity - a.angular_velocity) / (2 * h)
    return v, acc, w, wd


@pytest.mark.parametrize("t", [0.3, 1.7, 2.5, 3.9])
def test_min_jerk_move_derivatives_by_finite_differences(t: float) -> None:
    move = MinJerkMove(*start_goal(), 4.0)
    ref = move.sample(t)
    v, acc, w, wd = finite_difference(move, t)
    np.testing.assert_allclose(ref.velocity, v, atol=1e-8)
    np.testing.assert_allclose(ref.acceleration, acc, atol=1e-7)
    np.testing.assert_allclose(ref.angular_velocity, w, atol=1e-8)
    np.testing.assert_allclose(ref.angular_acceleration, wd, atol=1e-7)


@pytest.mark.parametrize("t", [0.4, 1.0, 2.2])
def test_arc_move_stays_on_the_circle_and_differentiates(t: float) -> None:
    start = Pose([3.0, -1.0, 0.4], rpy_to_matrix(0.0, 0.0, -0.3))
    arc = ArcMove(start, np.array([0.0, 0.0, 2.0]), np.zeros(3), 0.5, 2.5)
    ref = arc.sample(t)
    assert np.linalg.norm(ref.position[:2]) == pytest.approx(np.hypot(3.0, -1.0))
    assert ref.position[2] == pytest.approx(0.4)
    v, acc, w, wd = finite_difference(arc, t)
    np.testing.assert_allclose(ref.velocity, v, atol=1e-8)
    np.testing.assert_allclose(ref.acceleration, acc, atol=1e-7)
    np.testing.assert_allclose(ref.angular_velocity, w, atol=1e-8)
    np.testing.assert_allclose(ref.angular_acceleration, wd, atol=1e-7)
    end = arc.end
    np.testing.assert_allclose(arc.sample(10.0).position, end.position, atol=1e-14)
    np.testing.assert_allclose(end.rotation, rotation_exp([0, 0, 0.5]) @ start.rotation)
    assert arc.length == pytest.approx(0.5 * np.hypot(3.0, -1.0))


def test_via_points_stop_at_each_pose_and_dwell() -> None:
    poses = [Pose([0.0, 0, 0]), Pose([1.0, 0, 0]), Pose([1.0, 1.0, 0])]
    path = Path.via_points(poses, [2.0, 3.0], dwell=0.5, t0=1.0)
    assert path.duration == pytest.approx(5.5)
    assert [type(s).__name__ for s in path.segments] == ["MinJerkMove", "Hold", "MinJerkMove"]
    for t, p in ((1.0, poses[0]), (3.0, poses[1]), (3.5, poses[1]), (6.5, poses[2]), (9.0, poses[2])):
        ref = path.sample(t)
        np.testing.assert_allclose(ref.position, p.position, atol=1e-14)
        assert np.linalg.norm(ref.velocity) < 1e-14
    assert path.sample(5.0).position[1] == pytest.approx(0.5)  # middle of the second move
    np.testing.assert_allclose(path.start.position, poses[0].position)
    np.testing.assert_allclose(path.end.position, poses[2].position)
    with pytest.raises(TrajectoryError, match="got 3 poses and 1 durations"):
        Path.via_points(poses, [1.0])


def test_segment_placement_manoeuvre() -> None:
    pick = Pose([0.4, -3.2, 0.0], rpy_to_matrix(0, 0, -1.45))
    path = segment_placement(pick, lift=0.3, ring_angle=0.25, push=0.2,
                             durations=(2.0, 4.0, 2.0), dwell=0.5)
    assert path.names == ("pick", "dwell", "rotate", "dwell", "push")
    assert path.duration == pytest.approx(9.0)
    lifted = path.sample(2.0)
    np.testing.assert_allclose(lifted.position, pick.position + [0, 0.3, 0], atol=1e-14)
    ring = path.sample(6.5)
    np.testing.assert_allclose(ring.rotation, rotation_exp([0, 0, 0.25]) @ pick.rotation, atol=1e-14)
    assert np.linalg.norm(ring.position[:2]) == pytest.approx(np.linalg.norm(lifted.position[:2]))
    home = path.sample(9.0)
    np.testing.assert_allclose(home.position, ring.position + [0, 0, 0.2], atol=1e-14)
    # the whole path is continuous in position and velocity
    ts = np.linspace(0, 9, 9001)
    P = np.array([path.sample(t).position for t in ts])
    V = np.array([path.sample(t).velocity for t in ts])
    assert np.abs(np.diff(P, axis=0)).max() < 1e-3 and np.abs(np.diff(V, axis=0)).max() < 1e-3


def test_hold_and_bad_durations() -> None:
    hold = Hold(Pose([1.0, 2.0, 3.0]), 2.0)
    assert hold.sample(1.0).position.tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(TrajectoryError, match="duration must be > 0, got 0.0"):
        MinJerkMove(*start_goal(), 0.0)
    with pytest.raises(TrajectoryError, match="expected 3 or 6 values"):
        Pose.from_xyzrpy([1.0, 2.0])
