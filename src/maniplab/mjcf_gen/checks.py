"""Compiling an MjSpec with one-line errors, and checking the compiled arm can be simulated.

MuJoCo accepts a joint that moves nothing once ``boundmass``/``boundinertia`` lift every body to
1e-12 (see :mod:`~maniplab.mjcf_gen.builder`), and would then integrate accelerations of 1e12 times
the torque. :func:`check_drives_mass` refuses such arms, and arms in which two or more joints move the
arm the same way (M(q) singular at every pose), with a ModelError naming the file and the joints.

Both are one criterion: some joint motion ``v`` (a unit vector, prismatic components counted per
reach R so that metres and radians compare) has kinetic-energy metric vᵀ M(q) v below
``NO_MASS * max(1, R)²`` at every pose tried. The bounds contribute at most ~1e-12 (1 + R²) per
body, and arms that move real mass give values many orders of magnitude above the threshold.
"""

from __future__ import annotations

import threading
import warnings

import mujoco
import numpy as np

from maniplab.errors import ModelError
from maniplab.mjcf_gen.reach import reach
from maniplab.mjcf_gen.workspace import mass_matrices, poses
from maniplab.spec import ManipulatorSpec

NO_MASS = 1e-9
"""Threshold per squared reach: kg for a prismatic joint, kg·m² per m² for a rotational one."""

_POSES = 4  # random poses tried besides the home pose


def compile_checked(s: mujoco.MjSpec, spec: ManipulatorSpec) -> mujoco.MjModel:
    """``s.compile()`` with MuJoCo's errors turned into one-line ModelErrors naming the spec file."""
    try:
        return s.compile()
    except ValueError as exc:
        detail = "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())
        detail = detail.removeprefix("Error: ")
        raise ModelError(f"{_where(spec)}MuJoCo cannot compile the model: {detail}") from None


def compile_arm(s: mujoco.MjSpec, spec: ManipulatorSpec) -> mujoco.MjModel:
    """:func:`compile_checked`, then :func:`check_drives_mass`.

    MuJoCo warns while compiling an arm whose M(q) is singular at its home pose; for an arm the
    check refuses, its message says more, so MuJoCo's warnings are shown only for an arm that
    passes.
    """
    model, caught = compile_quietly(s, spec)
    check_drives_mass(model, spec)
    for warning in caught:
        warnings.warn_explicit(warning.message, warning.category, warning.filename,
                               warning.lineno)
    return model


def compile_quietly(s: mujoco.MjSpec,
                    spec: ManipulatorSpec) -> tuple[mujoco.MjModel, list[warnings.WarningMessage]]:
    """:func:`compile_checked`, and the warnings it gave instead of showing them (caught in the
    main thread only: Python's warning filters are process-global, other threads leave them)."""
    if threading.current_thread() is not threading.main_thread():
        return compile_checked(s, spec), []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = compile_checked(s, spec)
    return model, caught


def check_drives_mass(model: mujoco.MjModel, spec: ManipulatorSpec) -> None:
    """Raise ModelError unless every joint, and every combination of joints, moves mass.

    M(q) is evaluated at the home pose (q = 0 clipped to the limits) and at a few random poses
    within the limits (±π for unlimited joints). A motion fails only when it moves no mass at all of
    them, so a pose that happens to be singular (a boom along the slew axis) does not count.

    Args:
        model: the compiled model of ``spec``.
        spec: the spec, for the names in messages.

    Raises:
        ModelError: naming the spec file and the joint(s).
    """
    length = max(1.0, reach(spec))
    weight = np.array([length if j.prismatic else 1.0 for j in spec.joints])
    metrics = list(mass_matrices(model, poses(spec, _POSES)) * np.outer(weight, weight))
    floor = NO_MASS * length**2
    for i, joint in enumerate(spec.joints):
        if max(float(m[i, i]) for m in metrics) < floor:
            largest = max(float(m[i, i]) for m in metrics) / weight[i] ** 2  # kg or kg·m²
            unit = "kg" if joint.prismatic else "kg·m²"
            off_axis = "" if joint.prismatic else "off the joint axis "
            raise ModelError(
                f"{_where(spec)}joint {joint.name} drives no mass or inertia (M[{i}, {i}] <= "
                f"{largest:.3g} {unit} at the home pose and {_POSES} random poses); give its "
                f"body, a body after it or the end effector (end_effector.com, "
                f"end_effector.inertia) a mass {off_axis}or an inertia about the axis"
            )
    _check_independent(metrics, floor, spec)


def _check_independent(metrics: list[np.ndarray], floor: float, spec: ManipulatorSpec) -> None:
    """Raise when one combination of joint motions moves no mass at any pose."""
    best, motion = -np.inf, np.zeros(0)
    for metric in metrics:
        values, vectors = np.linalg.eigh(metric)
        if values[0] > best:
            best, motion = float(values[0]), vectors[:, 0]
    if best < floor:
        involved = [spec.joints[i].name for i in np.flatnonzero(np.abs(motion) > 0.1)]
        raise ModelError(
            f"{_where(spec)}joints {' and '.join(involved)} move the arm the same way (M(q) is "
            f"singular at the home pose and {_POSES} random poses); put a body with mass between "
            f"them or remove one"
        )


def _where(spec: ManipulatorSpec) -> str:
    return f"{spec.source}: " if spec.source else ""
