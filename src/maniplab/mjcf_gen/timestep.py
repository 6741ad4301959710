"""The step an arm needs: from its actuators' natural frequencies and rates, over its workspace.

Two kinds of dynamics bound the step of an explicit integrator (MuJoCo's RK4):

- the **springs** of the actuators' states (a cylinder's oil spring A²E/V) against the arm's
  inertia: coupled through the mass matrix M(q), they ring at the square roots of the eigenvalues
  of K^½ M(q)⁻¹ K^½ (K the diagonal of the joints' stiffnesses); the largest over the workspace
  must satisfy ω dt <= :data:`OSCILLATION`;
- the actuators' own **rates** (a valve's lag 1/τ, a cylinder's leakage and relief, the valve and
  the pressure ringing against each other): λ dt <= :data:`RATE` too; and their stiff decays (a
  chamber filling through a wide-open orifice) only as far as RK4 stays stable, λ dt <=
  :data:`STABLE`.

The default step is the largest of 1, 2 or 5 × 10^k s that satisfies both, and at most
:data:`DEFAULT` (1 ms). A plant asked for a coarser step takes as many sub-steps as it needs.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from maniplab.mjcf_gen.workspace import mass_matrices, poses
from maniplab.spec import ManipulatorSpec, model_of

DEFAULT = 1e-3
"""The step when the arm allows it, s."""

OSCILLATION = 0.5
"""Largest ω dt for a spring mode: RK4's phase error is then below 3e-4 rad per step."""

RATE = OSCILLATION
"""Largest λ dt for an actuator's rate (some are frequencies too; RK4 is stable to 2.8)."""

STABLE = 2.5
"""Largest λ dt for a stiff decay (:meth:`~maniplab.actuators.ActuatorPlugin.decays`), which
the step must keep stable but need not resolve: RK4 is stable to λ dt = 2.78 on the real axis."""

POSES = 48
"""Random poses over which the spring modes are searched (besides the home pose)."""


@dataclasses.dataclass(frozen=True)
class StepLimit:
    """The largest step the arm's fastest dynamics allow.

    Attributes:
        dt: that step, s (inf when nothing limits it).
        joint: the joint whose actuator sets it (None when nothing does).
        what: which of its dynamics ("oil spring mode", "valve lag", ...).
        rate: its frequency or rate, rad/s or 1/s.
    """

    dt: float
    joint: str | None = None
    what: str = ""
    rate: float = 0.0

    def describe(self) -> str:
        """E.g. "joint q2's oil spring mode at 414 rad/s needs dt <= 1.21e-3 s"."""
        if self.joint is None:
            return "no actuator dynamics limit the step"
        return (f"joint {self.joint}'s {self.what} at {self.rate:.4g} "
                f"{'rad/s' if 'mode' in self.what else '1/s'} needs dt <= {self.dt:.3g} s")


def step_limit(spec: ManipulatorSpec, model: mujoco.MjModel) -> StepLimit:
    """The largest step ``spec``'s actuators allow on its compiled MuJoCo ``model``.

    An actuator with an engine plugin (:meth:`~maniplab.actuators.ActuatorPlugin.mujoco_plugin`)
    is asked for the rates its plugin does not take exactly (``rates(native=True)``); one that
    MuJoCo integrates through the callbacks for all of them."""
    actuators = [model_of(j) for j in spec.joints]
    best = StepLimit(math.inf)
    for j, actuator in enumerate(actuators):
        exact = actuator.mujoco_plugin() is not None
        for what, rate in actuator.rates(exact).items():
            if rate > 0.0 and RATE / rate < best.dt:
                best = StepLimit(RATE / rate, spec.joints[j].name, what, rate)
        for what, rate in actuator.decays(exact).items():
            if rate > 0.0 and STABLE / rate < best.dt:
                best = StepLimit(STABLE / rate, spec.joints[j].name, what, rate)
    modes = spring_modes(spec, model)
    omega, joint = modes.fastest, modes.joint
    if omega > 0.0 and OSCILLATION / omega < best.dt:
        best = StepLimit(OSCILLATION / omega, spec.joints[joint].name,
                         f"{actuators[joint].spring_name} mode", omega)
    return best


def default_step(limit: StepLimit) -> float:
    """The largest of 1, 2, 5 × 10^k s within ``limit`` and at most DEFAULT, s."""
    return DEFAULT if limit.dt >= DEFAULT else round_down(limit.dt)


def round_down(dt: float) -> float:
    """The largest of 1, 2, 5 × 10^k s at most ``dt``."""
    exponent = math.floor(math.log10(dt))
    for mantissa in (5.0, 2.0, 1.0):
        step = mantissa * 10.0**exponent
        if step <= dt * (1.0 + 1e-12):
            return step
    return 10.0**exponent  # pragma: no cover - 1 × 10^floor(log10 dt) is always within dt


def hydraulic_frequencies(spec: ManipulatorSpec, model: mujoco.MjModel,
                          count: int = POSES) -> np.ndarray:
    """Each joint's spring frequency sqrt(k_j / J_j) at the sampled poses, rad/s, shape
    (count + 1, n), with J_j = M_jj (the other joints held); 0 where a joint has no spring."""
    actuators = [model_of(j) for j in spec.joints]
    qs = poses(spec, count)
    k = np.array([[a.stiffness(float(x)) for a, x in zip(actuators, q)] for q in qs])
    return np.sqrt(k / np.diagonal(mass_matrices(model, qs), axis1=1, axis2=2))


@dataclasses.dataclass(frozen=True)
class SpringModes:
    """The arm's actuator-spring modes over its workspace (all 0 without springs).

    Attributes:
        slowest: the lowest mode frequency at any sampled pose, rad/s.
        fastest: the highest, rad/s.
        joint: the joint that takes most part in the fastest mode (index).
    """

    slowest: float
    fastest: float
    joint: int


def spring_modes(spec: ManipulatorSpec, model: mujoco.MjModel) -> SpringModes:
    """The eigen-frequencies of the actuators' springs K on M(q): sqrt(eig(K^½ M⁻¹ K^½)) over
    the sampled poses, the joints without a spring left out."""
    actuators = [model_of(j) for j in spec.joints]
    qs = poses(spec, POSES)
    masses = mass_matrices(model, qs)
    regular = [i for i, m in enumerate(masses) if np.linalg.matrix_rank(m) == len(m)]
    qs, masses = qs[regular], masses[regular]  # a pose that happens to be singular: left out
    k = np.array([[a.stiffness(float(x)) for a, x in zip(actuators, q)] for q in qs])
    sprung = np.flatnonzero(k.any(axis=0)) if len(qs) else np.zeros(0, dtype=int)
    if not sprung.size:
        return SpringModes(0.0, 0.0, 0)
    inverse = np.linalg.inv(masses)[:, sprung][:, :, sprung]
    root = np.sqrt(k[:, sprung])
    values, vectors = np.linalg.eigh(root[:, :, None] * inverse * root[:, None, :])
    pose = int(np.argmax(values[:, -1]))
    joint = int(sprung[np.argmax(np.abs(vectors[pose, :, -1]))])
    return SpringModes(math.sqrt(max(values[:, 0].min(), 0.0)), math.sqrt(values[pose, -1]),
                       joint)
