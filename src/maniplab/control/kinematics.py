"""G3 and the outer loop's kinematics: pose from joint sensors, pose errors, J̇q̇, damped least squares.

Orientation conventions: a pose is (p, R), position p (3,) in m and rotation matrix R (3, 3) of the
end-effector frame in base axes (R = I at q = 0, the paper's convention). roll, pitch, yaw are
fixed-axis x-y-z angles: R = Rz(yaw) Ry(pitch) Rx(roll). Angular errors and velocities are
rotation vectors (axis times angle, rad) in base axes, matching the Jacobian's angular rows.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import lapack

from maniplab.model import AnalyticModel


# --- rotations ---------------------------------------------------------------------------------
def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation matrix Rz(yaw) Ry(pitch) Rx(roll), shape (3, 3); angles in rad."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def matrix_to_rpy(R: ArrayLike) -> np.ndarray:
    """(roll, pitch, yaw) in rad of a rotation matrix (inverse of :func:`rpy_to_matrix`), (3,).

    At pitch = ±π/2 (gimbal lock) roll is set to 0 and yaw takes the whole rotation about z.
    """
    R = np.asarray(R, dtype=float)
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) < 1e-12:
        return np.array([0.0, pitch, math.atan2(-R[0, 1], R[1, 1])])
    return np.array([math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])])


def rotation_exp(w: ArrayLike) -> np.ndarray:
    """Rotation matrix of the rotation vector w (axis times angle, rad), shape (3, 3) (Rodrigues)."""
    w = np.asarray(w, dtype=float)
    theta = math.sqrt(float(w @ w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if theta < 1e-8:
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + math.sin(theta) / theta * K + (1.0 - math.cos(theta)) / theta**2 * K @ K


def rotation_log(R: ArrayLike) -> np.ndarray:
    """Rotation vector (axis times angle, angle in [0, π]) of a rotation matrix, shape (3,)."""
    R = np.asarray(R, dtype=float)
    cos = max(-1.0, min(1.0, 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)))
    vee = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    theta = math.acos(cos)
    if theta < 1e-6:
        return vee  # sin θ ≈ θ: vee = sin θ · axis ≈ θ · axis
    if theta < math.pi - 1e-4:
        return theta / math.sin(theta) * vee
    # near π the axis a comes from the symmetric part: (R + Rᵀ)/2 = cos θ I + (1 - cos θ) a aᵀ
    B = (0.5 * (R + R.T) - cos * np.eye(3)) / (1.0 - cos)
    k = int(np.argmax(np.diag(B)))
    axis = B[:, k] / math.sqrt(max(B[k, k], 1e-300))
    if axis @ vee < 0.0:  # vee = sin θ · a fixes the sign (either sign at exactly π)
        axis = -axis
    return theta * axis / np.linalg.norm(axis)


def pose_error(p_d: ArrayLike, R_d: ArrayLike, p: ArrayLike, R: ArrayLike) -> np.ndarray:
    """Error from pose (p, R) to the desired (p_d, R_d): [p_d - p; log(R_d Rᵀ)], shape (6,).

    The angular part is the rotation vector, in base axes, that turns R into R_d.
    """
    out = np.empty(6)
    out[:3] = np.asarray(p_d, dtype=float) - np.asarray(p, dtype=float)
    out[3:] = rotation_log(np.asarray(R_d) @ np.asarray(R).T)
    return out


# --- damped least squares ------------------------------------------------------------------------
class DampedLeastSquares:
    """Damped least-squares inverse of a Jacobian, damped only near singularities.

    x = Σ_i σ_i / (σ_i² + λ²) v_i u_iᵀ b over the singular values σ_i of J, with
    λ² = damping² (1 - (σ_min/threshold)²) when σ_min < threshold and 0 otherwise
    (Maciejewski and Klein's singular-region damping): away from singularities this is the
    pseudo-inverse solution; near one the step along the weak direction stays bounded.

    With joint ``weights`` w the solution minimises Σ_j (x_j / w_j)² instead of |x|² (it is
    x = w ⊙ (J diag(w))⁺ b, the singular values then being those of J diag(w)): joints with
    larger weights take more of the motion, e.g. weights proportional to each joint's top speed.

    Args:
        J: shape (m, n), e.g. the task rows of the Jacobian.
        damping: λ_max, in the units of σ (m per rad on a position task).
        threshold: σ below which damping starts (0: never damp).
        weights: joint weights w, shape (n,), > 0, or None for all 1.

    Attributes:
        lam2: the damping λ² used, in σ's units squared.
        sigma: singular values of J, descending, shape (min(m, n),).
    """

    def __init__(self, J: ArrayLike, *, damping: float = 0.05, threshold: float = 0.05,
                 weights: ArrayLike | None = None) -> None:
        self.J = np.asarray(J, dtype=float)
        self.weights = None if weights is None else np.asarray(weights, dtype=float)
        Jw = self.J if self.weights is None else self.J * self.weights
        U, s, Vt, info = lapack.dgesdd(Jw, full_matrices=0)  # numpy's svd, less overhead
        if info != 0:
            U, s, Vt = np.linalg.svd(Jw, full_matrices=False)
        self._U, self.sigma, self._Vt = U, s, Vt
        smin = float(s[-1]) if s.size else 0.0
        self.lam2 = (damping**2 * (1.0 - (smin / threshold) ** 2)
                     if threshold > 0.0 and smin < threshold else 0.0)
        if self.lam2 > 0.0:
            self._gain = s / (s * s + self.lam2)
        else:  # the pseudo-inverse, ignoring numerically zero singular values
            tiny = 1e-12 * (float(s[0]) if s.size else 0.0)
            self._gain = np.divide(1.0, s, out=np.zeros_like(s), where=s > tiny)

    def solve(self, rhs: ArrayLike) -> np.ndarray:
        """x for J x ≈ rhs; rhs shape (m,) or (m, k), x shape (n,) or (n, k)."""
        b = np.asarray(rhs, dtype=float)
        g = self._gain if b.ndim == 1 else self._gain[:, None]
        x = self._Vt.T @ (g * (self._U.T @ b))
        if self.weights is None:
            return x
        return x * (self.weights if b.ndim == 1 else self.weights[:, None])

    def null_space(self) -> np.ndarray:
        """The projector I - J⁺J onto the task's null space, shape (n, n).

        J⁺ is this solver's (weighted, damped) inverse; J (I - J⁺J) = 0 when no damping is
        active. Zero when J has full column rank.
        """
        Vt = self._Vt
        P = Vt.T @ ((self._gain * self.sigma)[:, None] * Vt)  # Jw⁺ Jw
        if self.weights is not None:  # W Jw⁺ J = W (Jw⁺ Jw) W⁻¹
            P = self.weights[:, None] * P / self.weights[None, :]
        P *= -1.0
        P.flat[:: P.shape[0] + 1] += 1.0
        return P


def dls_solve(J: ArrayLike, rhs: ArrayLike, *, damping: float = 0.05, threshold: float = 0.05,
              weights: ArrayLike | None = None) -> np.ndarray:
    """Damped least-squares solution of J x ≈ rhs (see :class:`DampedLeastSquares`)."""
    return DampedLeastSquares(J, damping=damping, threshold=threshold, weights=weights).solve(rhs)


# --- G3 ---------------------------------------------------------------------------------------
class Kinematics:
    """G3: joint sensors to the end-effector's Cartesian pose and velocity, and the task Jacobian.

    Args:
        model: the arm's analytic model (its fk and Jacobian are used).
        fd_step: joint-space step of the J̇q̇ difference quotient, rad or m.
    """

    def __init__(self, model: AnalyticModel, *, fd_step: float = 1e-5) -> None:
        self.model = model
        self.fd_step = fd_step

    def pose(self, q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(p, R): end-effector position (3,) in m and orientation (3, 3) in base axes."""
        H = self.model.fk(q)
        return H[:3, 3].copy(), H[:3, :3].copy()

    def jacobian(self, q: ArrayLike) -> np.ndarray:
        """Geometric Jacobian [linear; angular], base frame, shape (6, n)."""
        return self.model.jacobian(q)

    def velocity(self, q: ArrayLike, qd: ArrayLike) -> np.ndarray:
        """End-effector twist [v (m/s); ω (rad/s)] = J q̇, base frame, shape (6,)."""
        return self.model.jacobian(q) @ np.asarray(qd, dtype=float)

    def bias_acceleration(self, q: ArrayLike, qd: ArrayLike) -> np.ndarray:
        """J̇(q, q̇) q̇, shape (6,): the end-effector's acceleration at q̈ = 0, base frame.

        Computed as the central difference of J along the motion,
        J̇ ≈ (J(q + s q̇) - J(q - s q̇)) / (2 s), with s q̇ of size ``fd_step`` (error O(s²)).
        """
        qd = np.asarray(qd, dtype=float)
        speed = float(np.max(np.abs(qd))) if qd.size else 0.0
        if speed == 0.0:
            return np.zeros(6)
        q = np.asarray(q, dtype=float)
        s = self.fd_step / speed
        dJ = (self.model.jacobian(q + s * qd) - self.model.jacobian(q - s * qd)) / (2.0 * s)
        return dJ @ qd
