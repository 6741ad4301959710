"""Defects a forestry knuckle-boom crane found (issue 33), on tests/arms/knuckle_crane.yaml: slew
(lumped), boom and jib (pinned cylinders), telescope (prismatic, lumped), rotator (lumped, its
axis through the tip: redundant for the tip's position), one shared pump."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import maniplab as ml
from maniplab.control.feasibility import JointPath
from maniplab.control.point_to_point import plan_move

CRANE = Path(__file__).parent / "arms" / "knuckle_crane.yaml"
START = [-1.29, -0.44, 1.48, 0.77, 0.0]
TARGET = [7.654, -1.621, 0.035]


@pytest.fixture(scope="module")
def crane() -> tuple[ml.ManipulatorSpec, ml.AnalyticModel]:
    spec = ml.resolve_spec(CRANE)
    return spec, ml.AnalyticModel(spec)


def test_a_joint_the_tip_does_not_need_takes_no_motion_in_the_plan(crane) -> None:
    """Before: the rotator swung in the planner's joint path on the round-off of its Jacobian
    column, and the 5 s move was stretched to 54.7 s ("joint rotator would need more than 80 %
    of its actuator's command range"); in the executed run the rotator never moved."""
    spec, model = crane
    plan = plan_move(spec, TARGET, start=START, duration=5.0, model=model)
    path = JointPath.of(model, plan.move.start, plan.move.goal, plan.q_start, plan.task)
    assert np.ptp(path.q[:, 4]) < 1e-9
    assert plan.q_goal[4] == pytest.approx(START[4], abs=1e-9)
    assert plan.move.duration < 1.5 * 5.0, plan.note()
    assert "rotator" not in (plan.note() or "")
