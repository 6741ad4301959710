"""Moves the actuators can deliver: a minimum-jerk move checked against each joint's capacity.

Along the move's path (sampled, the joints found by inverse kinematics within the limits from
one sample to the next) each joint needs the force of the arm's inverse dynamics plus its
friction, at the speed and acceleration the move's duration gives. Each actuator says what
command holds that force at that speed (:meth:`~maniplab.actuators.ActuatorPlugin.steady`: a
valve's current for the flow the piston needs at that load, a torque source's force). The move is
feasible when every command stays within :data:`MARGIN` of its limit, which leaves the
controller room to correct. Speeds scale as 1/T and accelerations as 1/T², so a slower move
needs less: :func:`fit` finds the shortest feasible duration.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from maniplab.control.errors import ControlError
from maniplab.control.ik import solve
from maniplab.control.trajectory import MinJerkMove, Pose
from maniplab.model import AnalyticModel
from maniplab.spec import model_of

MARGIN = 0.8
"""A feasible move needs at most this share of each actuator's command range."""

SAMPLES = 61
"""Samples along the path (time, at unit duration)."""

LONGEST = 100.0
"""A move that is not feasible at this many times its duration is not feasible at any speed."""


@dataclasses.dataclass(frozen=True)
class Demand:
    """What a move asks of one joint at its worst sample.

    Attributes:
        joint: the joint's name.
        share: |command| / limit at the worst sample (inf: no command holds it).
        speed: the joint's speed there, rad/s or m/s.
        force: the force it needs there, N·m or N.
        t: the time into the move, s.
    """

    joint: str
    share: float
    speed: float
    force: float
    t: float


@dataclasses.dataclass(frozen=True)
class JointPath:
    """A move's path in joint space: q at SAMPLES times of the move at unit duration.

    Attributes:
        tau: the samples' times at unit duration, (k,).
        q, dq, ddq: positions and their first and second derivatives in tau, (k, n).
    """

    tau: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray

    @classmethod
    def of(cls, model: AnalyticModel, start: Pose, goal: Pose, q0: np.ndarray,
           task: str) -> JointPath:
        """Follow the straight path from ``start`` to ``goal`` (inverse kinematics from q0, each
        sample from the last).

        Raises:
            ControlError: the path leaves the workspace (a sample is out of reach).
        """
        move = MinJerkMove(start, goal, 1.0)
        tau = np.linspace(0.0, 1.0, SAMPLES)
        q, current = [], np.asarray(q0, dtype=float)
        for t in tau:
            found = solve(model, move.sample(float(t)), current, task=task, tol=1e-6, restarts=0,
                          near=True)
            if not found.reached:
                raise ControlError(
                    f"the straight path leaves the workspace {t:.0%} of the way (the closest "
                    f"pose misses it by {found.miss:.3g} m{_limits(found.at_limits)}); choose a "
                    "target or start from which the straight line stays in reach")
            current = found.q
            q.append(current)
        qs = np.array(q)
        dq = np.gradient(qs, tau, axis=0)
        return cls(tau, qs, dq, np.gradient(dq, tau, axis=0))


def _limits(joints: tuple[str, ...]) -> str:
    return f", joint(s) {', '.join(joints)} at their limits" if joints else ""


def demand(model: AnalyticModel, path: JointPath, duration: float) -> Demand | None:
    """The most demanded joint when the move takes ``duration`` s, or None when no actuator can
    say (none declares a steady state)."""
    spec = model.spec
    actuators = [model_of(j) for j in spec.joints]
    checked = [j for j, a in enumerate(actuators) if a.has_steady()]
    if not checked:
        return None
    qd, qdd = path.dq / duration, path.ddq / duration**2
    worst = None
    for k in range(len(path.tau)):
        force = model.inverse_dynamics(path.q[k], qd[k], qdd[k]) + _friction(spec, qd[k])
        for j in checked:
            a = actuators[j]
            limit = a.command_limit
            u = a.steady(float(force[j]), float(path.q[k, j]), float(qd[k, j])).u
            share = abs(u) / limit if limit is not None else 0.0
            share = share if math.isfinite(share) else math.inf
            if worst is None or share > worst.share:
                worst = Demand(spec.joints[j].name, share, float(qd[k, j]), float(force[j]),
                               float(path.tau[k]) * duration)
    return worst


def _friction(spec: object, qd: np.ndarray) -> np.ndarray:
    """Each joint's slip friction at speed q̇ (viscous and Coulomb), N·m or N, (n,)."""
    joints = spec.joints  # type: ignore[attr-defined]
    return np.array([f.damping * v + (f.coulomb * np.sign(v) if f.model.value != "none" else 0.0)
                     for f, v in zip((j.friction for j in joints), qd)])


def fit(model: AnalyticModel, path: JointPath, duration: float) -> tuple[float, Demand | None]:
    """The shortest duration >= ``duration`` at which the move is feasible, and its demand there.

    Raises:
        ControlError: not feasible at LONGEST times the duration: some pose needs more than the
            actuator holds at rest (naming the joint).
    """
    worst = demand(model, path, duration)
    if worst is None or worst.share <= MARGIN:
        return duration, worst
    slow = demand(model, path, LONGEST * duration)
    if slow is not None and slow.share > MARGIN:
        need = (f"{slow.share:.0%} of its actuator's command range" if math.isfinite(slow.share)
                else "more than its actuator can exert")
        raise ControlError(
            f"joint {slow.joint} cannot hold the arm on this path: it needs {need} at rest "
            f"({slow.force:.4g} N·m or N); a stronger actuator (area, supply pressure, limit, a "
            "cylinder's bore or pins) or another path")
    low, high = duration, LONGEST * duration
    while high - low > 0.01 * high:
        mid = math.sqrt(low * high)
        share = demand(model, path, mid)
        if share is not None and share.share > MARGIN:
            low = mid
        else:
            high = mid
    return high, demand(model, path, high)
