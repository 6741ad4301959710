"""LuGre friction (Canudas de Wit et al., IEEE TAC 40(3), 1995), vectorised over the joints.

With the spec's keys (Fc ``coulomb``, the static level Fc + ``static``, vs ``stribeck_velocity``,
σ0 ``sigma0``, σ1 ``sigma1``, σ2 ``viscous``)::

    g(v)  = Fc + static exp(-(v/vs)²)
    dz/dt = v - σ0 |v| z / g(v)
    F     = σ0 z + σ1 dz/dt + σ2 v          (the joint feels -F)

The bristle state z (m, or rad) lives in MuJoCo's activations (one per LuGre joint), so it is
part of ``mj_getState``. Its relaxation rate σ0|v|/g(v) reaches 1e4 1/s on the 1995 paper's
stick-slip case, which is what makes LuGre stiff (explicit Euler needs dt ≈ 1e-5 s there).

On the plant's native route z is updated with the exact solution for the step's mean velocity
v̄ = Δq/dt, ``z' = z e^(-a dt) + v̄ dt φ1(a dt)``, a = σ0|v̄|/g(v̄), which is stable at any step;
the force σ0 z + σ1 ż is held over the step (σ2 v is MuJoCo's joint damping, integrated inside
the step). The held force keeps the bristle spring's stability bound, ω dt < 2 with
ω = sqrt(σ0/m). On the callback route (:class:`LuGreBristles`) MuJoCo's RK4 integrates z with
the arm, the generic way, bounded by the relaxation rate instead.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from maniplab.friction.params import Friction, FrictionModel
from maniplab.numerics import phi1


def steady_force(friction: Friction, v: np.ndarray) -> np.ndarray:
    """LuGre's steady-state friction g(v) sign(v) + σ2 v (the Stribeck curve), N or N·m."""
    v = np.asarray(v, dtype=float)
    g = friction.coulomb + friction.static * np.exp(-((v / friction.stribeck_velocity) ** 2))
    return g * np.sign(v) + friction.viscous * v


@dataclasses.dataclass(frozen=True)
class LuGreJoint:
    """LuGre parameters of one joint (index ``joint``)."""

    joint: int
    sigma0: float
    sigma1: float
    coulomb: float
    static: float
    stribeck_velocity: float

    @classmethod
    def of(cls, joint: int, f: Friction) -> LuGreJoint:
        return cls(joint, f.sigma0, f.sigma1, f.coulomb, f.static, f.stribeck_velocity)

    def level(self, v: float) -> float:
        """g(v) = Fc + static exp(-(v/vs)²), N or N·m."""
        r = v / self.stribeck_velocity
        return self.coulomb + self.static * math.exp(-r * r)

    def rate(self, z: float, v: float) -> float:
        """dz/dt = v - σ0 |v| z / g(v)."""
        return v - self.sigma0 * abs(v) * z / self.level(v)

    def force(self, z: float, v: float) -> float:
        """The bristles' force on the joint, -(σ0 z + σ1 dz/dt) (σ2 v excluded), N or N·m."""
        return -(self.sigma0 * z + self.sigma1 * self.rate(z, v))

    def advance(self, z: float, mean_velocity: float, dt: float) -> float:
        """z after a step dt at constant velocity ``mean_velocity``, exactly."""
        x = self.sigma0 * abs(mean_velocity) / self.level(mean_velocity) * dt
        return z * math.exp(-x) + mean_velocity * dt * phi1(x)


class LuGreFriction:
    """The LuGre joints of an arm (``joints``: one :class:`LuGreJoint` each)."""

    def __init__(self, frictions: Sequence[Friction]) -> None:
        self.joints = [LuGreJoint.of(i, f) for i, f in enumerate(frictions)
                       if f.model is FrictionModel.lugre]

    def __len__(self) -> int:
        return len(self.joints)


class LuGreBristles:
    """LuGre on one joint as an element MuJoCo integrates (the plant's callback route).

    Same interface as an actuator plugin: state z, ``derivatives`` dz/dt and the force
    -(σ0 z + σ1 dz/dt) (σ2 v is the joint's damping). MuJoCo's RK4 then integrates z together
    with the arm, the generic way of simulating LuGre, which needs steps short enough for the
    bristle relaxation rate σ0|v|/g(v) (RK4 is stable up to about 2.8 / rate).
    """

    states = ("z",)

    def __init__(self, lugre: LuGreJoint) -> None:
        self.lugre = lugre

    def derivatives(self, x: np.ndarray, u: float, q: float, v: float) -> np.ndarray:
        """(dz/dt,)."""
        return np.array([self.lugre.rate(float(x[0]), v)])

    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        """The bristles' force on the joint, N or N·m."""
        return self.lugre.force(float(x[0]), v)
