"""Planning a point-to-point Cartesian move: target parsing, reachability and joint-limit checks."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from maniplab.control.errors import ControlError
from maniplab.control.kinematics import inverse_kinematics, pose_error
from maniplab.control.trajectory import MinJerkMove, Pose
from maniplab.model import AnalyticModel
from maniplab.spec import ManipulatorSpec


def parse_numbers(text: str, what: str, counts: Sequence[int]) -> list[float]:
    """Comma-separated numbers, e.g. "2.5,-1,0"; raises ControlError naming ``what``."""
    parts = [p.strip() for p in str(text).split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise ControlError(f"{what} {text!r}: expected comma-separated numbers such as "
                           f"'2.5,-1.0,0.0'") from None
    if len(values) not in counts or not all(np.isfinite(values)):
        expected = " or ".join(str(c) for c in counts)
        raise ControlError(f"{what} {text!r}: expected {expected} finite numbers, got "
                           f"{len(values)}")
    return values


def plan_move(spec: ManipulatorSpec, target: Sequence[float], *, start: Sequence[float] | None,
              duration: float, t0: float = 0.5, model: AnalyticModel | None = None,
              tol: float = 1e-4) -> tuple[MinJerkMove, str, np.ndarray]:
    """A minimum-jerk move from the arm's pose at ``start`` to ``target``, checked.

    Args:
        spec: the arm.
        target: [x, y, z] (a position task) or [x, y, z, roll, pitch, yaw] (a pose task), m and
            rad, base axes (R = Rz(yaw) Ry(pitch) Rx(roll)).
        start: initial joint positions (n,), or None for q = 0 (clipped into the limits).
        duration: the move's duration, s.
        t0: when the move starts, s.
        model: the arm's analytic model.
        tol: largest acceptable inverse-kinematics residual at the target, m or rad.

    Returns:
        (move, task, q_goal): the move, "position" or "pose", and the joint positions at the
        target found by inverse kinematics from ``start``.

    Raises:
        ControlError: wrong number of values, a task the arm has too few joints for, a target
            out of reach or beyond a joint limit.
    """
    model = model or AnalyticModel(spec)
    if not duration > 0.0:
        raise ControlError(f"duration must be > 0 s, got {duration!r}")
    lower = np.array([j.limits[0] if j.limits else -np.inf for j in spec.joints])
    upper = np.array([j.limits[1] if j.limits else np.inf for j in spec.joints])
    if start is None:
        q0 = np.clip(np.zeros(spec.n), lower, upper)
    else:
        q0 = np.asarray(start, dtype=float)
        if q0.shape != (spec.n,):
            raise ControlError(f"start: expected {spec.n} joint positions "
                               f"({', '.join(spec.joint_names)}), got {q0.size}")
        outside = [n for n, v, lo, hi in zip(spec.joint_names, q0, lower, upper)
                   if not lo <= v <= hi]
        if outside:
            raise ControlError(f"start: joint {outside[0]} is outside its limits")
    task = "pose" if len(target) == 6 else "position"
    if task == "pose" and spec.n < 6:
        raise ControlError(f"a target orientation needs 6 joints; {spec.name} has {spec.n} "
                           "(give x,y,z only)")
    start_pose = Pose.from_matrix(model.fk(q0))
    goal = Pose.from_xyzrpy(target) if task == "pose" else Pose(np.asarray(target[:3], float),
                                                                start_pose.rotation)
    q_goal = inverse_kinematics(model, goal, q0, task=task, max_iter=500)
    H = model.fk(q_goal)
    rows = slice(0, 6 if task == "pose" else 3)
    miss = float(np.linalg.norm(pose_error(goal.position, goal.rotation, H[:3, 3],
                                           H[:3, :3])[rows]))
    if miss > tol:
        unit = "m" if task == "position" else "(m and rad)"
        raise ControlError(f"target {list(target)} is out of reach of {spec.name} from the start "
                           f"pose (the closest pose found misses it by {miss:.3g} {unit})")
    beyond = [(n, v, lo, hi) for n, v, lo, hi in zip(spec.joint_names, q_goal, lower, upper)
              if not lo - 1e-9 <= v <= hi + 1e-9]
    if beyond:
        n, v, lo, hi = beyond[0]
        raise ControlError(f"target {list(target)} needs joint {n} at {v:.4g}, beyond its limits "
                           f"[{lo:g}, {hi:g}]")
    return MinJerkMove(start_pose, goal, duration, t0=t0), task, q0
