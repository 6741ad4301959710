"""LuGre friction (Canudas de Wit et al., IEEE TAC 40(3), 1995).

With the spec's keys (Fc ``coulomb``, the static level Fc + ``static``, vs ``stribeck_velocity``,
σ0 ``sigma0``, σ1 ``sigma1``, σ2 ``viscous``)::

    g(v)  = Fc + static exp(-(v/vs)²)
    dz/dt = v - σ0 |v| z / g(v)
    F     = σ0 z + σ1 dz/dt + σ2 v          (the joint feels -F)

The law is the MuJoCo engine plugin ``maniplab.lugre`` (C, ``maniplab_native/lugre.c``), an
actuator ``<joint>/lugre`` in the arm's model and in the exported MJCF, whose one activation is
the bristle state z (m, or rad), so it is part of ``mj_getState``. σ2 v is MuJoCo's joint damping.

The bristles relax at the rate σ0|v|/g(v), which reaches 1e4 1/s on the 1995 paper's stick-slip
case: that is what makes LuGre stiff (explicit Euler on z needs dt ≈ 1e-5 s there). The plugin
therefore advances z after each step with the exact solution for the step's mean velocity
v̄ = Δq/dt, ``z' = z e^(-a dt) + v̄ dt φ1(a dt)``, a = σ0|v̄|/g(v̄), stable at any step; within the
step each RK4 stage's force takes the same solution to the stage's own time, for the mean velocity
since the step's start (not z held at its start value, a first-order hold), which makes the joint's
motion second-order accurate (issue 36: 1.6e-5 m over the 30 s stick-slip at 1 ms, was 9e-4 m).
The bristle spring keeps its stability bound, ω dt < 2 with ω = sqrt(σ0/m).
"""

from __future__ import annotations

import numpy as np

from maniplab.friction.params import Friction


def steady_force(friction: Friction, v: np.ndarray) -> np.ndarray:
    """LuGre's steady-state friction g(v) sign(v) + σ2 v (the Stribeck curve), N or N·m."""
    v = np.asarray(v, dtype=float)
    g = friction.coulomb + friction.static * np.exp(-((v / friction.stribeck_velocity) ** 2))
    return g * np.sign(v) + friction.viscous * v
