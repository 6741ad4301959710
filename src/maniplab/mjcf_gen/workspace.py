"""Poses over an arm's workspace and its mass matrix there: what depends on the arm's pose.

The checks of a new model, the step size and the controller's default gains all ask how the arm's
inertia varies over its workspace; they sample it here, the same way each time (a fixed seed), at
the home pose (q = 0 clipped to the limits) and random poses within the limits (±π, or ±π m, for
joints without limits).
"""

from __future__ import annotations

import mujoco
import numpy as np

from maniplab.spec import ManipulatorSpec

SEED = 20050704
"""Fixed: a verdict drawn from the samples must be the same every time."""


def poses(spec: ManipulatorSpec, count: int) -> np.ndarray:
    """The home pose and ``count`` random poses within the limits, shape (count + 1, n)."""
    rng = np.random.default_rng(SEED)
    low = np.array([j.limits[0] if j.limits else -np.pi for j in spec.joints])
    high = np.array([j.limits[1] if j.limits else np.pi for j in spec.joints])
    home = np.clip(np.zeros(spec.n), low, high)
    return np.vstack([home, rng.uniform(low, high, size=(count, spec.n))])


def mass_matrices(model: mujoco.MjModel, qs: np.ndarray) -> np.ndarray:
    """M(q) at each pose of ``qs`` (k, n): shape (k, n, n), kg / kg·m², without running actuator
    or sensor callbacks."""
    data = mujoco.MjData(model)
    out = np.zeros((len(qs), model.nv, model.nv))
    for q, dense in zip(qs, out):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_crb(model, data)
        mujoco.mj_fullM(model, data, dense)
    return out
