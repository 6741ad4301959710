"""G3, pose errors, J̇q̇ and damped least squares, against MuJoCo and first-order expansions."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import maniplab as ml
from maniplab.control.ik import inverse_kinematics
from maniplab.control.kinematics import (
    DampedLeastSquares,
    Kinematics,
    dls_solve,
    matrix_to_rpy,
    pose_error,
    rotation_exp,
    rotation_log,
    rpy_to_matrix,
)


@pytest.fixture(scope="module")
def erector() -> tuple[ml.ManipulatorSpec, ml.AnalyticModel]:
    spec = ml.builtin_spec("erector")
    return spec, ml.AnalyticModel(spec)


def random_q(spec: ml.ManipulatorSpec, rng: np.random.Generator) -> np.ndarray:
    return np.array([rng.uniform(*(j.limits or (-2.0, 2.0))) for j in spec.joints])


def axis_rotation(axis: int, angle: float) -> np.ndarray:
    return rotation_exp(angle * np.eye(3)[axis])


def test_rpy_is_fixed_axis_xyz() -> None:
    roll, pitch, yaw = 0.3, -0.4, 1.1
    expected = axis_rotation(2, yaw) @ axis_rotation(1, pitch) @ axis_rotation(0, roll)
    np.testing.assert_allclose(rpy_to_matrix(roll, pitch, yaw), expected, atol=1e-15)
    np.testing.assert_allclose(matrix_to_rpy(expected), [roll, pitch, yaw], atol=1e-14)
    # gimbal lock: the rotation is still reproduced
    R = rpy_to_matrix(0.2, math.pi / 2, 0.5)
    np.testing.assert_allclose(rpy_to_matrix(*matrix_to_rpy(R)), R, atol=1e-12)


def test_rotation_exp_is_rodrigues_and_log_inverts_it() -> None:
    np.testing.assert_allclose(rotation_exp([0, 0, math.pi / 2]),
                               [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    rng = np.random.default_rng(1)
    for angle in (0.0, 1e-9, 1e-4, 0.5, 2.0, math.pi - 1e-3, math.pi - 1e-6, math.pi):
        axis = rng.normal(size=3)
        w = angle * axis / np.linalg.norm(axis)
        R = rotation_exp(w)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-14)
        w2 = rotation_log(R)
        np.testing.assert_allclose(rotation_exp(w2), R, atol=1e-12)
        if angle < math.pi - 1e-5:  # at π, ±axis are both right
            np.testing.assert_allclose(w2, w, atol=1e-9)


def test_pose_error_turns_R_into_R_d() -> None:
    R = rpy_to_matrix(0.1, 0.2, 0.3)
    R_d = rpy_to_matrix(-0.2, 0.4, 1.0)
    e = pose_error([1, 2, 3], R_d, [0.5, 2, 4], R)
    np.testing.assert_allclose(e[:3], [0.5, 0, -1])
    np.testing.assert_allclose(rotation_exp(e[3:]) @ R, R_d, atol=1e-14)


def test_g3_pose_equals_mujoco_site(erector: tuple) -> None:
    spec, am = erector
    m = ml.build_model(spec)
    d = mujoco.MjData(m)
    kin = Kinematics(am)
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "end_effector")
    rng = np.random.default_rng(2)
    for _ in range(5):
        q = random_q(spec, rng)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        p, R = kin.pose(q)
        np.testing.assert_allclose(p, d.site_xpos[site], atol=1e-12)
        np.testing.assert_allclose(R, d.site_xmat[site].reshape(3, 3), atol=1e-12)


def test_bias_acceleration_equals_mujoco_jac_dot(erector: tuple) -> None:
    spec, am = erector
    m = ml.build_model(spec)
    d = mujoco.MjData(m)
    kin = Kinematics(am)
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "end_effector")
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, qd = random_q(spec, rng), rng.normal(size=spec.n)
        d.qpos[:], d.qvel[:] = q, qd
        mujoco.mj_forward(m, d)
        jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        point = kin.pose(q)[0]
        mujoco.mj_jacDot(m, d, jacp, jacr, point, body)
        expected = np.concatenate([jacp @ qd, jacr @ qd])
        np.testing.assert_allclose(kin.bias_acceleration(q, qd), expected,
                                   atol=1e-7 * max(1.0, np.abs(expected).max()))
    assert not kin.bias_acceleration(q, np.zeros(spec.n)).any()


def test_bias_acceleration_is_the_second_derivative_of_position(erector: tuple) -> None:
    # J̇q̇ (linear part) = d²/ds² p(q + s q̇) at s = 0: a fourth-order central difference of fk
    spec, am = erector
    kin = Kinematics(am)
    q, qd = random_q(spec, np.random.default_rng(4)), np.array([0.3, -0.2, 0.5, 0.1, 0.2, -0.4])
    h = 1e-3
    p = lambda s: am.fk(q + s * qd)[:3, 3]
    d2 = (-p(2 * h) + 16 * p(h) - 30 * p(0) + 16 * p(-h) - p(-2 * h)) / (12 * h * h)
    np.testing.assert_allclose(kin.bias_acceleration(q, qd)[:3], d2, atol=1e-8)


def test_dls_step_reduces_the_error_to_first_order(erector: tuple) -> None:
    _spec, am = erector
    q = np.array([-0.3, 1.0, 0.4, 0.05, 0.1, -0.1])
    H = am.fk(q)
    direction = np.array([0.3, -0.5, 0.2, 0.1, -0.2, 0.15])
    residual = []
    for size in (1e-2, 1e-3, 1e-4):
        target_p = H[:3, 3] + size * direction[:3]
        target_R = rotation_exp(size * direction[3:]) @ H[:3, :3]
        e = pose_error(target_p, target_R, H[:3, 3], H[:3, :3])
        dq = dls_solve(am.jacobian(q), e)
        H2 = am.fk(q + dq)
        residual.append(np.linalg.norm(pose_error(target_p, target_R, H2[:3, 3], H2[:3, :3]))
                        / np.linalg.norm(e))
    # the residual error is O(|e|²): its ratio to |e| falls tenfold per tenfold smaller step
    assert residual[0] < 0.05
    assert residual[1] == pytest.approx(residual[0] / 10, rel=0.2)
    assert residual[2] == pytest.approx(residual[1] / 10, rel=0.2)


def test_dls_equals_the_pseudo_inverse_away_from_singularities() -> None:
    rng = np.random.default_rng(5)
    J, b = rng.normal(size=(3, 6)), rng.normal(size=3)
    np.testing.assert_allclose(dls_solve(J, b), np.linalg.pinv(J) @ b, atol=1e-12)
    w = rng.uniform(0.2, 1.0, size=6)
    W2 = np.diag(w**2)  # weighted minimum norm: x = W² Jᵀ (J W² Jᵀ)⁻¹ b
    np.testing.assert_allclose(dls_solve(J, b, weights=w),
                               W2 @ J.T @ np.linalg.solve(J @ W2 @ J.T, b), atol=1e-12)
    both = DampedLeastSquares(J, weights=w).solve(np.stack([b, 2 * b], axis=1))
    np.testing.assert_allclose(both[:, 1], 2 * both[:, 0])


def test_dls_is_damped_and_bounded_near_a_singularity() -> None:
    J = np.array([[1.0, 0.0], [0.0, 1e-6]])  # nearly singular in the second direction
    b = np.array([0.0, 1.0])
    x = dls_solve(J, b, damping=0.05, threshold=0.05)
    lam2 = 0.05**2 * (1 - (1e-6 / 0.05) ** 2)
    assert x[1] == pytest.approx(1e-6 / (1e-12 + lam2))
    assert abs(x[1]) < 1e-2  # the undamped solution would be 1e6
    # still a descent step: the linear prediction moves toward the target
    assert (J @ x) @ b > 0


def test_null_space_projector(erector: tuple) -> None:
    _spec, am = erector
    J = am.jacobian(np.array([-0.3, 1.0, 0.4, 0.05, 0.1, -0.1]))[:3]
    for w in (None, np.array([1.0, 0.5, 0.3, 0.8, 0.2, 0.1])):
        N = DampedLeastSquares(J, weights=w).null_space()
        np.testing.assert_allclose(J @ N, 0.0, atol=1e-12)
        np.testing.assert_allclose(N @ N, N, atol=1e-12)  # a projector
    assert np.abs(DampedLeastSquares(am.jacobian(np.array(
        [-0.3, 1.0, 0.4, 0.05, 0.1, -0.1]))).null_space()).max() < 1e-12


def test_inverse_kinematics_reaches_a_pose(erector: tuple) -> None:
    _spec, am = erector
    q_true = np.array([-0.4, 0.9, 0.3, 0.1, -0.1, 0.2])
    from maniplab.control.trajectory import Pose

    target = Pose.from_matrix(am.fk(q_true))
    q = inverse_kinematics(am, target, q_true + 0.1)
    H = am.fk(q)
    assert np.linalg.norm(pose_error(target.position, target.rotation, H[:3, 3], H[:3, :3])) < 1e-9
