"""Inverse kinematics within the joint limits, against scipy's bounded least squares run here from
many starts: every reachable target is reached within the limits, and an unreachable one is
reported with the true closest miss."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import least_squares

import maniplab as ml
from maniplab.control.ik import solve
from maniplab.control.point_to_point import plan_move
from maniplab.control.trajectory import Pose

ARMS = Path(__file__).parent / "arms"
CORPUS = ["erector", "crane3", "planar2", *sorted(str(p) for p in ARMS.glob("*.yaml"))]


def limits(spec: ml.ManipulatorSpec) -> tuple[np.ndarray, np.ndarray]:
    lower = np.array([j.limits[0] if j.limits else -np.pi for j in spec.joints])
    upper = np.array([j.limits[1] if j.limits else np.pi for j in spec.joints])
    return lower, upper


def closest_miss(model: ml.AnalyticModel, target: np.ndarray, starts: int = 40) -> float:
    """The smallest position miss over bounded least-squares solves from many random starts."""
    spec = model.spec
    lower = np.array([j.limits[0] if j.limits else -np.inf for j in spec.joints])
    upper = np.array([j.limits[1] if j.limits else np.inf for j in spec.joints])
    low, high = limits(spec)
    rng = np.random.default_rng(1)
    best = np.inf
    for _ in range(starts):
        result = least_squares(lambda q: model.fk(q)[:3, 3] - target, rng.uniform(low, high),
                               jac=lambda q: model.jacobian(q)[:3], bounds=(lower, upper),
                               method="trf", xtol=1e-14, ftol=1e-14)
        best = min(best, float(np.linalg.norm(model.fk(result.x)[:3, 3] - target)))
    return best


@pytest.mark.parametrize("name", CORPUS, ids=lambda n: Path(n).stem)
def test_every_reachable_target_is_reached_within_the_limits(name: str) -> None:
    spec = ml.resolve_spec(name)
    model = ml.AnalyticModel(spec)
    low, high = limits(spec)
    rng = np.random.default_rng(7)
    for _ in range(10):
        q_true, start = rng.uniform(low, high), rng.uniform(low, high)
        target = Pose.from_matrix(model.fk(q_true))
        task = "pose" if spec.n >= 6 else "position"
        found = solve(model, target, start, task=task, tol=1e-8)
        assert found.reached, (q_true, start, found.miss)
        limited = np.array([j.limits is not None for j in spec.joints])
        assert np.all((found.q >= low - 1e-12) & (found.q <= high + 1e-12) | ~limited)


@pytest.mark.parametrize("name", ["erector", "crane3", "tests/arms/excavator.yaml"])
def test_an_unreachable_target_reports_the_true_closest_miss(name: str) -> None:
    spec = ml.resolve_spec(name)
    model = ml.AnalyticModel(spec)
    low, high = limits(spec)
    target = model.fk(high)[:3, 3] * 3.0  # three times as far out as a corner of the limits
    found = solve(model, Pose(target, np.eye(3)), np.clip(np.zeros(spec.n), low, high),
                  task="position")
    assert not found.reached
    assert found.miss <= closest_miss(model, target) * (1 + 1e-6) + 1e-9


def test_the_erector_reaches_a_target_that_wound_a_joint_beyond_its_limits() -> None:
    """The target that used to be refused ("needs joint q1 at -6.058, beyond its limits")."""
    spec = ml.builtin_spec("erector")
    plan = plan_move(spec, [3.3, 0.5, 0.1], start=None, duration=5.0)
    low, high = limits(spec)
    assert np.all(plan.q_goal >= low) and np.all(plan.q_goal <= high)
    model = ml.AnalyticModel(spec)
    assert np.linalg.norm(model.fk(plan.q_goal)[:3, 3] - [3.3, 0.5, 0.1]) < 1e-4


@pytest.mark.parametrize("name", ["erector", "erector_pinned", str(ARMS / "erector7.yaml")])
def test_a_redundant_arm_follows_a_path_with_the_least_joint_motion(name: str) -> None:
    """The path IK of an arm with more joints than the task has rows follows the minimum-norm
    motion: the joint path of q̇ = J⁺ ẋ integrated in small steps (an independent reference, from
    the start of the path), not wherever the solver's iterations drift in the null space."""
    from maniplab.control.feasibility import JointPath
    from maniplab.control.trajectory import MinJerkMove

    spec = ml.resolve_spec(name)
    model = ml.AnalyticModel(spec)
    q0 = np.array([-0.18, 1.27, 0.0, 0.0, 0.0, 0.0, 0.0][:spec.n])
    start = Pose.from_matrix(model.fk(q0))
    goal = Pose(start.position + np.array([0.4, -0.6, 0.05]), start.rotation)
    path = JointPath.of(model, start, goal, q0, "position")
    move, q, steps = MinJerkMove(start, goal, 1.0), q0.copy(), 4000
    reference = [q0.copy()]
    for k in range(steps):  # midpoint rule on the minimum-norm velocity
        t = (k + 0.5) / steps
        x_dot = (move.sample(t + 0.5 / steps).position - move.sample(t - 0.5 / steps).position)
        mid = q + 0.5 * np.linalg.pinv(model.jacobian(q)[:3]) @ x_dot
        q = q + np.linalg.pinv(model.jacobian(mid)[:3]) @ x_dot
        reference.append(q.copy())
    at = np.round(path.tau * steps).astype(int)
    np.testing.assert_allclose(path.q, np.array(reference)[at], atol=2e-3)
