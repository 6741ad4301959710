"""Random general serial arms of any size, for tests and benchmarks (like Pinocchio's sample models).

Nothing about them is special: every joint has a body with a length along a random direction, a
centre of gravity off that line and a full (rotated) inertia tensor, a fifth of the joints slide,
and the axes are drawn from x, y and z. The same ``(n, seed)`` always gives the same arm.
"""

from __future__ import annotations

import numpy as np

from maniplab.spec import ManipulatorSpec


def sample_arm(n: int, seed: int = 0) -> ManipulatorSpec:
    """A random general arm of ``n`` joints with torque actuators (see the module docstring).

    Args:
        n: number of joints (>= 1).
        seed: the random generator's seed.
    """
    if n < 1:
        raise ValueError(f"sample_arm: n must be at least 1, got {n}")
    rng = np.random.default_rng(seed)
    joints = [_joint(rng, k, n) for k in range(n)]
    return ManipulatorSpec.from_dict({
        "name": f"sample{n}",
        "gravity": [0.0, 0.0, -9.81],
        "joints": joints,
        "end_effector": {"mass": 5.0, "offset": [0.05, 0.0, 0.1]},
    })


def _joint(rng: np.random.Generator, k: int, n: int) -> dict:
    prismatic = rng.random() < 0.2
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    length = float(rng.uniform(0.2, 1.0)) * 6.0 / max(n, 6)  # about 3.6 m of reach in all
    mass = float(rng.uniform(5.0, 60.0)) * 6.0 / max(n, 6)
    com = 0.5 * length * direction + rng.uniform(-0.05, 0.05, size=3)
    return {
        "name": f"j{k + 1}",
        "type": "P" if prismatic else "R",
        "axis": str(rng.choice(list("xyz"))),
        "limits": [-0.3, 0.3] if prismatic else [-3.0, 3.0],
        "body": {"length": length, "direction": direction.tolist(), "mass": mass,
                 "com": com.tolist(), "inertia": _inertia(rng, mass, length)},
        "actuator": {"type": "torque"},
        "friction": {"model": "hybrid", "viscous": float(rng.uniform(0.5, 5.0))},
    }


def _inertia(rng: np.random.Generator, mass: float, length: float) -> list[float]:
    """A physical inertia about the COG: principal moments of a box, rotated at random."""
    sides = np.array([length, 0.2 * length, 0.15 * length]) * rng.uniform(0.8, 1.2, size=3)
    principal = mass / 12.0 * (np.sum(sides**2) - sides**2)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    inertia = q @ np.diag(principal) @ q.T
    return [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2],
            inertia[1, 2]]
