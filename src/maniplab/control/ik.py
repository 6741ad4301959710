"""Inverse kinematics within the joint limits: the pose that reaches a target, or the closest miss.

A bounded least-squares solve (scipy's trust-region reflective method) of the task error — the
position error, and on a pose task the rotation vector of R_d Rᵀ — over the joint positions,
within each joint's limits. It starts from the given pose, so a target reachable from there is
reached on the start's branch; if that solve misses, it starts again from poses spread over the
workspace, nearest first, and keeps the first that reaches the target (else the smallest miss).
A target is out of reach only when no start reaches it: the miss then reported is the closest
pose's, with the joints that end on a limit.

When the arm has more joints than the task has rows, many poses reach the target and the solver
would end wherever its iterations drift. Following a path (``near=True``), the first solve
therefore also asks for the smallest change from the start (a small weight on q − q0), and a
second solve from there, with a far smaller weight, removes the miss the first weight left: the
path moves the joints as little as it can, sample after sample, whatever the rounding of the
kinematics, and a joint the task does not see at all does not move.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import least_squares

from maniplab.control.kinematics import pose_error
from maniplab.model import AnalyticModel

RESTARTS = 24
"""Starts tried after the given pose when it does not reach the target."""

NEAR_WEIGHT = 1e-3
"""Weight of q − q0 (m/rad) in the first solve of ``near``: small beside a miss of the task."""

NEAR_HOLD = 1e-9
"""Weight of q − q0 in the second solve of ``near``: it removes the first solve's miss (to about
this weight times the step) while a joint the task does not move (a rotator whose axis passes
through the tip, whose Jacobian column is round-off) keeps its position instead of swinging on
that round-off."""

SEED = 20051117
"""Fixed: the same target gives the same answer every time."""


@dataclasses.dataclass(frozen=True)
class IKSolution:
    """The result of :func:`solve`.

    Attributes:
        q: joint positions, within the limits, (n,).
        miss: the task error's norm there, m (and rad on a pose task).
        at_limits: the joints on a limit in ``q``.
        reached: whether ``miss`` is within the solve's tolerance.
    """

    q: np.ndarray
    miss: float
    at_limits: tuple[str, ...]
    reached: bool


def bounds_of(model: AnalyticModel) -> tuple[np.ndarray, np.ndarray]:
    """The joint limits of the model's arm (±inf where a joint has none), each (n,)."""
    joints = model.spec.joints
    return (np.array([j.limits[0] if j.limits else -np.inf for j in joints]),
            np.array([j.limits[1] if j.limits else np.inf for j in joints]))


def solve(model: AnalyticModel, pose: Any, q0: ArrayLike, *, task: str = "pose",
          tol: float = 1e-9, restarts: int = RESTARTS, near: bool = False) -> IKSolution:
    """Joint positions within the limits that put the end-effector at ``pose``.

    Args:
        model: the analytic model (its spec gives the limits).
        pose: target with ``position`` (3,) and ``rotation`` (3, 3) (e.g. a trajectory Pose).
        q0: the start, shape (n,) (clipped into the limits).
        task: "position" (3 rows) or "pose" (6).
        tol: the largest miss that counts as reaching the target, m (and rad).
        restarts: further starts when the first does not reach it.
        near: of the poses that reach the target, find the one nearest the start (module
            docstring): for following a path.

    Returns:
        The first solution that reaches the target, else the one that comes closest.
    """
    lower, upper = bounds_of(model)
    rows = slice(0, 3) if task == "position" else slice(0, 6)

    def residual(q: np.ndarray) -> np.ndarray:
        H = model.fk(q)
        return pose_error(pose.position, pose.rotation, H[:3, 3], H[:3, :3])[rows]

    def jacobian(q: np.ndarray) -> np.ndarray:
        return -model.jacobian(q)[rows]  # exact for the position, to first order the rotation

    def anchored(start: np.ndarray, weight: float) -> np.ndarray:
        """The least squares of the task error and ``weight`` (q - start)."""
        eye = weight * np.eye(len(start))

        def weighted(q: np.ndarray) -> np.ndarray:
            return np.concatenate([residual(q), weight * (q - start)])

        def weighted_jacobian(q: np.ndarray) -> np.ndarray:
            return np.vstack([jacobian(q), eye])

        return least_squares(weighted, start, jac=weighted_jacobian, bounds=(lower, upper),
                             method="trf", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=100).x

    def solve_from(start: np.ndarray) -> np.ndarray:
        if near:  # a joint the task does not see (its column ~1e-17) stays where it was
            return anchored(anchored(start, NEAR_WEIGHT), NEAR_HOLD)
        return least_squares(residual, start, jac=jacobian, bounds=(lower, upper), method="trf",
                             xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=100).x

    best = None
    for start in _starts(np.asarray(q0, dtype=float), lower, upper, restarts):
        q = np.clip(solve_from(start), lower, upper)
        miss = float(np.linalg.norm(residual(q)))
        if best is None or miss < best[1]:
            best = (q, miss)
        if miss <= tol:
            break
    assert best is not None
    q, miss = best
    span = np.where(np.isfinite(upper - lower), upper - lower, 1.0)
    on = (q - lower <= 1e-9 * span) | (upper - q <= 1e-9 * span)
    names = tuple(model.spec.joint_names[i] for i in np.flatnonzero(on))
    return IKSolution(q, miss, names, miss <= tol)


def inverse_kinematics(model: AnalyticModel, pose: Any, q0: ArrayLike, *, task: str = "pose",
                       tol: float = 1e-9) -> np.ndarray:
    """Joint positions within the limits that put the end-effector at ``pose`` (or come closest):
    :func:`solve`'s ``q``, shape (n,)."""
    return solve(model, pose, q0, task=task, tol=tol).q


def _starts(q0: np.ndarray, lower: np.ndarray, upper: np.ndarray, count: int) -> list[np.ndarray]:
    """q0 (inside the limits), then ``count`` poses over the workspace, nearest to q0 first."""
    span = np.where(np.isfinite(upper - lower), upper - lower, 2.0 * np.pi)
    low = np.where(np.isfinite(lower), lower, q0 - np.pi)
    inside = np.clip(q0, low + 1e-9 * span, low + span * (1.0 - 1e-9))
    rng = np.random.default_rng(SEED)
    others = low + span * rng.uniform(size=(count, len(q0)))
    order = np.argsort(np.linalg.norm((others - inside) / span, axis=1))
    return [inside, *others[order]]
