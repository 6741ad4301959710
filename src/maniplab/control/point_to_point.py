"""Planning a point-to-point Cartesian move: target parsing, reach within the joint limits, and
a duration the actuators can deliver."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from maniplab.control.errors import ControlError
from maniplab.control.feasibility import MARGIN, Demand, JointPath, fit
from maniplab.control.ik import bounds_of, solve
from maniplab.control.shaping import ShapedMove
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


FITS = ("stretch", "refuse")
"""What :func:`plan_move` does with a move the actuators cannot deliver in its duration."""


@dataclasses.dataclass(frozen=True)
class MovePlan:
    """A checked point-to-point move.

    Attributes:
        move: the minimum-jerk move (its duration possibly stretched; shaped to leave a hanging
            tool without sway, :mod:`~maniplab.control.shaping`).
        task: "position" or "pose".
        q_start: the joint positions at the start, (n,).
        q_goal: the joint positions at the target (inverse kinematics within the limits), (n,).
        asked: the duration asked for, s.
        demand: what the move asks of its most demanded joint (None when no actuator can say).
        path: the joints along the move as the planner checked them (at unit duration).
    """

    move: MinJerkMove | ShapedMove
    task: str
    q_start: np.ndarray
    q_goal: np.ndarray
    asked: float
    demand: Demand | None
    path: JointPath | None = None

    def joint_reference(self, t: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The planned joint path at time t: (q, q̇), each (n,) (rad or m, and per s): the
        joints the planner checked along the move, interpolated; the start before the move and
        the path's end after it. At times t (K,): each (K, n)."""
        if self.path is None:
            raise ValueError("this plan has no joint path")
        move, path = self.move, self.path
        times = np.asarray(t, dtype=float)
        tau = np.clip((times - move.t0) / move.duration, 0.0, 1.0)
        q = np.stack([np.interp(tau, path.tau, column) for column in path.q.T], axis=-1)
        moving = (move.t0 < times) & (times < move.t0 + move.duration)
        qd = np.stack([np.interp(tau, path.tau, column) for column in path.dq.T], axis=-1)
        qd = np.where(moving[..., None], qd / move.duration, 0.0)
        return q, qd

    joint_reference.accepts_arrays = True  # type: ignore[attr-defined]

    @property
    def stretched(self) -> bool:
        """Whether the move was made slower than asked."""
        return self.move.duration > self.asked

    def note(self) -> str | None:
        """One line saying why the move was stretched, or None."""
        if not self.stretched or self.demand is None:
            return None
        d = self.demand
        return (f"move stretched from {self.asked:g} s to {self.move.duration:.3g} s: at "
                f"{self.asked:g} s joint {d.joint} would need more than {MARGIN:.0%} of its "
                f"actuator's command range (--fit refuse to refuse such moves instead)")


MAX_DURATION = 1e9
"""The longest move (and latest start) planned, s: beyond it the path's derivatives underflow
and the run could not be simulated anyway."""


def plan_move(spec: ManipulatorSpec, target: Sequence[float], *, start: Sequence[float] | None,
              duration: float, t0: float = 0.5, model: AnalyticModel | None = None,
              tol: float = 1e-4, fit_mode: str = "stretch") -> MovePlan:
    """A minimum-jerk move from the arm's pose at ``start`` to ``target``, checked.

    Args:
        spec: the arm.
        target: [x, y, z] (a position task) or [x, y, z, roll, pitch, yaw] (a pose task), m and
            rad, base axes (R = Rz(yaw) Ry(pitch) Rx(roll)).
        start: initial joint positions (n,), or None for q = 0 (clipped into the limits).
        duration: the move's duration, s.
        t0: when the move starts, s.
        model: the arm's analytic model.
        tol: largest acceptable miss at the target, m (and rad).
        fit_mode: when the actuators cannot deliver the move in ``duration``: "stretch" it to the
            shortest duration they can (the plan says so), or "refuse" it (saying which
            duration works).

    Returns:
        The plan: the move, the task, the start and goal joint positions, the demand.

    Raises:
        ControlError: wrong number of values, a task the arm has too few joints for, a target
            out of reach within the joint limits (with the closest miss and the joints at their
            limits), a path that leaves the workspace, a move too fast (``fit_mode="refuse"``)
            or a load no actuator holds.
    """
    model = model or AnalyticModel(spec)
    if not 0.0 < duration <= MAX_DURATION:
        raise ControlError(f"duration must be > 0 s and at most {MAX_DURATION:g} s, "
                           f"got {duration!r}")
    if not abs(t0) <= MAX_DURATION:
        raise ControlError(f"t0 must be a finite time within ±{MAX_DURATION:g} s, got {t0!r}")
    if fit_mode not in FITS:
        raise ControlError(f"fit {fit_mode!r}: expected 'stretch' or 'refuse'")
    lower, upper = bounds_of(model)
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
    found = solve(model, goal, q0, task=task, tol=tol, near=True)
    if not found.reached:
        unit = "m" if task == "position" else "(m and rad)"
        at = (f", with joint(s) {', '.join(found.at_limits)} at their limits"
              if found.at_limits else "")
        raise ControlError(f"target {list(target)} is out of reach of {spec.name}: the closest "
                           f"pose within the joint limits misses it by {found.miss:.3g} {unit}{at}")
    path = JointPath.of(model, start_pose, goal, q0, task)
    needed, worst = fit(model, path, duration)
    if needed > duration and fit_mode == "refuse":
        assert worst is not None
        raise ControlError(
            f"the move is too fast for joint {worst.joint}'s actuator: in {duration:g} s it needs "
            f"more than {MARGIN:.0%} of its command range; give --duration {needed:.3g} or more, "
            "or --fit stretch")
    return MovePlan(MinJerkMove(start_pose, goal, needed, t0=t0), task, q0, found.q, duration,
                    worst, path)
