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
