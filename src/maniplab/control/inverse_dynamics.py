"""G1: inverse dynamics from the analytic model.

τ_d = M(q) q̈_d + C(q, q̇) q̇ + G(q) + Fv q̇ (+ optional Coulomb feed-forward, + a hanging
tool's weight); each joint's
actuator drive then turns τ_d into its command (e.g. ΔP_d = τ_d / A on a hydraulic joint, see
:mod:`maniplab.actuators.hydraulic.drive`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from maniplab.model import AnalyticModel


class InverseDynamics:
    """G1: the joint forces that produce q̈_d, from the controller's model of the arm.

    Args:
        model: the analytic model (its masses and payload are the controller's *estimates*).
        coulomb: add the Coulomb friction feed-forward Fc tanh(q̇_ref / v_s) (Fc and v_s, the
            Stribeck velocity, from the spec's hybrid/LuGre friction); default off, as in the
            paper's G1 (the cascade's setting ``coulomb_feedforward`` turns it on).
        weight: the weight of a tool hanging at the end-effector point, N, base axes (3,):
            held, -J_pᵀ weight, without its inertia (it swings free above its pendulum's
            frequency; :mod:`~maniplab.control.suspended`); None: none.
    """

    def __init__(self, model: AnalyticModel, *, coulomb: bool = False,
                 weight: ArrayLike | None = None) -> None:
        self.model = model
        self.weight = None if weight is None else np.asarray(weight, dtype=float).reshape(3)
        joints = model.spec.joints
        self.fv = np.array([j.friction.viscous for j in joints], dtype=float)
        has = np.array([j.friction.model.value != "none" for j in joints])
        self.fc = np.where(has, [j.friction.coulomb for j in joints], 0.0) if coulomb else np.zeros(
            len(joints))
        self.vs = np.array([j.friction.stribeck_velocity for j in joints], dtype=float)

    def torque(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike,
               qd_ref: ArrayLike | None = None) -> np.ndarray:
        """τ_d = M q̈ + C q̇ + G + Fv q̇ (+ Fc tanh(q̇_ref/v_s)), shape (n,), N·m or N.

        Args:
            q: joint positions, (n,). qd: joint velocities, (n,). qdd: desired accelerations, (n,).
            qd_ref: the reference velocity for the Coulomb feed-forward (default ``qd``).
        """
        M, b = self.model.mass_and_bias(q, qd)
        tau = M @ np.asarray(qdd, dtype=float) + b + self.fv * np.asarray(qd, dtype=float)
        if self.fc.any():
            v = np.asarray(qd if qd_ref is None else qd_ref, dtype=float)
            tau += self.fc * np.tanh(v / self.vs)
        if self.weight is not None:
            tau -= np.asarray(self.model.jacobian(q))[:3].T @ self.weight
        return tau
