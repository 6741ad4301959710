"""The erector's controller validation cases, shared by ``examples/`` and ``maniplab demo``.

The acceptance move (1 m in 4 s in the plane of the lifting joints) and the segment placement
manoeuvre (lift the segment off the feeder, turn it about the tunnel axis to its ring position,
push it home), and how a case is run: the plant starts at rest on the reference's first pose with
the pressures holding it, the controller (possibly with a mis-estimated payload) runs inside
``simulate``, and its log is added to the Run. (A top-level module: it uses both the controller
and the plant, which do not know each other; it lives beside the erector, in the demo that sits
on top of both.)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from maniplab.control.cascade import CascadeController
from maniplab.control.ik import inverse_kinematics
from maniplab.control.metrics import TrackingMetrics, tracking_metrics
from maniplab.control.trajectory import MinJerkMove, Path, Pose, segment_placement
from maniplab.model import AnalyticModel
from maniplab.sim.run import Run
from maniplab.sim.simulate import simulate
from maniplab.spec import ManipulatorSpec

#: The acceptance move: from this pose of the erector (rad, m) ...
MOVE_Q0 = np.array([-0.18, 1.27, 0.0, 0.0, 0.0, 0.0])
#: ... 1 m along this direction (base axes; in the plane of the lifting joints) in 4 s.
MOVE_DIRECTION = np.array([-0.892, 0.453, 0.0]) / np.linalg.norm([-0.892, 0.453, 0.0])
MOVE_LENGTH, MOVE_TIME = 1.0, 4.0
#: Segment placement: the segment on the feeder, arm pose (rad, m).
PICK_Q0 = np.array([-0.9, 1.3, -0.4, -0.1, 0.0, 0.0])
START = 0.5  # s at rest before the reference starts to move


def acceptance_move(model: AnalyticModel, *, short: bool = False) -> MinJerkMove:
    """The 1 m Cartesian move in 4 s (short: 0.25 m in 1.5 s), starting at t = START."""
    start = Pose.from_matrix(model.fk(MOVE_Q0))
    length, time = (0.25, 1.5) if short else (MOVE_LENGTH, MOVE_TIME)
    return MinJerkMove(start, start.translated(length * MOVE_DIRECTION), time, t0=START)


def placement_path(model: AnalyticModel, *, short: bool = False) -> Path:
    """The segment placement manoeuvre: lift 0.3 m, turn 0.25 rad about the tunnel axis, push
    0.2 m home (short: 0.1 m, 0.08 rad, 0.08 m, quicker), starting at t = START."""
    pick = Pose.from_matrix(model.fk(PICK_Q0))
    if short:
        return segment_placement(pick, lift=0.1, ring_angle=0.08, push=0.08,
                                    durations=(1.0, 1.5, 1.0), dwell=0.2, t0=START)
    return segment_placement(pick, lift=0.3, ring_angle=0.25, push=0.2,
                                durations=(3.0, 5.0, 2.5), dwell=0.5, t0=START)


def run_case(spec: ManipulatorSpec, trajectory: Any, q_seed: np.ndarray, *, label: str,
             mode: str = "cascade", payload_factor: float = 1.0, settle: float = 1.0,
             model: AnalyticModel | None = None, **settings: Any) -> tuple[Run, TrackingMetrics]:
    """Simulate ``spec`` under the controller following ``trajectory``; returns the run and metrics.

    The plant starts at rest on the reference's first pose (inverse kinematics from q_seed),
    its pressures holding it against gravity. The controller's model has the payload mass
    times ``payload_factor`` (its estimate); the plant has the spec's.
    """
    model = model or AnalyticModel(spec)
    task = settings.get("task") or (spec.control.task if spec.control else None) or (
        "pose" if spec.n >= 6 else "position")
    q0 = inverse_kinematics(model, trajectory.start, q_seed, task=task)
    believed = spec
    if payload_factor != 1.0:
        believed = spec.with_overrides({"end_effector.mass": spec.end_effector.mass * payload_factor})
    controller = CascadeController(believed, trajectory, mode=mode, **settings)
    duration = trajectory.t0 + trajectory.duration + settle
    run = simulate(spec, controller=controller, duration=duration,
                      initial={"q": q0, "dP": "gravity"}, label=label)
    return run, tracking_metrics(run, trajectory, label=label, model=model)
