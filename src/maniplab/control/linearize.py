"""Linearisation of the plant (rigid body + the actuators' models) around an operating point.

State x = [q (n); q̇ (n); the actuator states], the actuator states grouped by name in the order
the arm first has them (a hydraulic arm: ΔP of each cylinder, then Q of each); input u = each
joint's command (valve current, force, a plugin's command); output y = [q (n); end-effector
position (3)]. The nonlinear plant is

    M(q) q̈ = τ(x_a, u, q, q̇) - C(q, q̇) q̇ - G(q) - F(q̇)     τ_j = force_j of joint j's actuator
    ẋ_a = derivatives of each actuator's model (e.g. eq. 4 for a cylinder)

with F the joints' slip friction: viscous Fv q̇ plus, for a joint that moves (q̇ ≠ 0, hybrid or
LuGre model), the Coulomb/Stribeck part sign(q̇)(Fc + Fs exp(-(q̇/vs)²)), whose slope enters the
linear model. At rest the Coulomb part is left out (it is discontinuous there: a real joint at
rest sticks, which no linear model represents). The actuators' partial derivatives are their own
(:meth:`~maniplab.actuators.ActuatorPlugin.jacobians`: exact for the built-ins, central
differences otherwise); ∂q̈/∂q is a central difference of the analytic model's forward dynamics;
∂(C q̇)/∂q̇ = 2 C (Christoffel form).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from maniplab.actuators import ActuatorPlugin
from maniplab.actuators.base import STANDARD_STATES
from maniplab.control.errors import LinearizeError
from maniplab.model import AnalyticModel
from maniplab.spec import ManipulatorSpec, model_of, models_of


def _states(actuators: list[ActuatorPlugin]) -> list[tuple[str, list[int]]]:
    """The actuator states as the linear model orders them: (name, joints that have it)."""
    order: dict[str, list[int]] = {}
    for j, a in enumerate(actuators):
        for name in a.states:
            order.setdefault(name, []).append(j)
    return list(order.items())


def operating_point(spec: ManipulatorSpec, q: ArrayLike, qd: ArrayLike | None = None, *,
                    model: AnalyticModel | None = None) -> dict[str, np.ndarray]:
    """A steady operating point at q (and constant q̇): actuator states that balance the arm.

    Each joint's actuator exerts τ = G(q) + C(q, q̇) q̇ + F(q̇) in its steady state
    (:meth:`~maniplab.actuators.ActuatorPlugin.steady`: a cylinder's ΔP = τ/A, Q = A q̇ + Le ΔP,
    i_v = Q / (C sqrt(1 - |ΔP|/Ps)); a torque joint's command is τ). q̈ = 0 there only when
    q̇ = 0 (a moving arm's bias changes with q).

    Returns:
        {"q", "qd", "u", ``dP``, ``Q`` and each actuator state by name}, each shape (n,)
        (NaN at joints without the state).

    Raises:
        LinearizeError: an actuator with states declares no steady state.
    """
    model = model or AnalyticModel(spec)
    actuators = models_of(spec)
    q = np.asarray(q, dtype=float)
    qd = np.zeros(spec.n) if qd is None else np.asarray(qd, dtype=float)
    tau = model.bias(q, qd) + _friction(spec, qd)[0]
    point = {"q": q, "qd": qd, "u": np.zeros(spec.n)}
    for name in (*STANDARD_STATES, *(name for name, _ in _states(actuators))):
        point[name] = np.full(spec.n, np.nan)
    for j, a in enumerate(actuators):
        if not a.has_steady():
            raise LinearizeError(f"joint {a.joint.name}: {a.label()} declares no steady state "
                                 "(ActuatorPlugin.steady), so no operating point holds it")
        x, point["u"][j] = a.steady(float(tau[j]), float(q[j]), float(qd[j]))
        if not np.isfinite(point["u"][j]):
            raise LinearizeError(_unreachable(a, float(tau[j]), x))
        for name, value in zip(a.states, x):
            point[name][j] = value
    return point


def _unreachable(actuator: ActuatorPlugin, force: float, x: np.ndarray) -> str:
    """Why no command holds ``actuator`` at ``force`` (N or N·m), for the error message."""
    states = ", ".join(f"{name} = {value:.4g}" for name, value in zip(actuator.states, x))
    return (f"{actuator.label()}: no command holds the arm at this operating point: it would "
            f"have to exert {force:.4g} against gravity, Coriolis and friction ({states}), more "
            "than it can give (a cylinder: a load pressure above its supply pressure); lighten "
            "the payload, enlarge the area or raise the supply pressure")


def _friction(spec: ManipulatorSpec, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Slip friction F(q̇) and its slope dF/dq̇, each (n,) (no Coulomb part at q̇ = 0)."""
    force, slope = np.zeros(spec.n), np.zeros(spec.n)
    for i, joint in enumerate(spec.joints):
        f = joint.friction
        v = float(qd[i])
        force[i], slope[i] = f.viscous * v, f.viscous
        if f.model.value != "none" and v != 0.0:
            g = np.exp(-((v / f.stribeck_velocity) ** 2))
            force[i] += np.sign(v) * (f.coulomb + f.static * g)
            slope[i] += -2.0 * abs(v) / f.stribeck_velocity**2 * f.static * g
    return force, slope


def names(spec: ManipulatorSpec) -> dict[str, list[str]]:
    """State, input and output names of :func:`linearize`'s system."""
    actuators = models_of(spec)
    joints = spec.joint_names
    states = [f"{joints[j]}_{name}" for name, which in _states(actuators) for j in which]
    return {
        "states": list(joints) + [f"{j}_dot" for j in joints] + states,
        "inputs": [f"{j}_{a.command}" for j, a in zip(joints, actuators)],
        "outputs": list(joints) + ["ee_x", "ee_y", "ee_z"],
    }


def jacobians(spec: ManipulatorSpec, point: Mapping[str, ArrayLike], *,
              model: AnalyticModel | None = None, fd_step: float = 1e-6
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C, D) of the plant linearised at ``point`` (see :func:`linearize`)."""
    model = model or AnalyticModel(spec)
    actuators = models_of(spec)
    n = spec.n
    q = np.asarray(point["q"], dtype=float)
    qd = np.asarray(point.get("qd", np.zeros(n)), dtype=float)
    u = np.asarray(point["u"], dtype=float)
    index = {}  # (joint, state name) -> row of x
    row = 2 * n
    for name, which in _states(actuators):
        for j in which:
            index[j, name] = row
            row += 1
    nx = row
    xs = [np.array([float(np.asarray(point[s])[j]) for s in a.states])
          for j, a in enumerate(actuators)]
    parts = [a.jacobians(x, float(u[j]), float(q[j]), float(qd[j]))
             for j, (a, x) in enumerate(zip(actuators, xs))]
    tau = np.array([a.force(x, float(u[j]), float(q[j]), float(qd[j]))
                    for j, (a, x) in enumerate(zip(actuators, xs))])
    fric, slope = _friction(spec, qd)

    def qdd(qq: np.ndarray) -> np.ndarray:
        return model.forward_dynamics(qq, qd, tau - fric)

    A = np.zeros((nx, nx))
    B = np.zeros((nx, n))
    iq, iv = slice(0, n), slice(n, 2 * n)
    A[iq, iv] = np.eye(n)
    for k in range(n):  # ∂q̈/∂q by central differences of the model's forward dynamics
        e = np.zeros(n)
        e[k] = fd_step
        A[iv, k] = (qdd(q + e) - qdd(q - e)) / (2.0 * fd_step)
    Minv = np.linalg.inv(model.M(q))
    A[iv, iv] = -Minv @ (2.0 * model.C(q, qd) + np.diag(slope))
    for j, (a, J) in enumerate(zip(actuators, parts)):
        rows = [index[j, s] for s in a.states]
        A[iv, j] += Minv[:, j] * J.df_dq
        A[iv, n + j] += Minv[:, j] * J.df_dv
        B[iv, j] = Minv[:, j] * J.df_du
        for r, dfx in zip(rows, J.df_dx):
            A[iv, r] += Minv[:, j] * dfx
        for i, r in enumerate(rows):
            A[r, j] = J.dxdot_dq[i]
            A[r, n + j] = J.dxdot_dv[i]
            A[r, rows] = J.dxdot_dx[i]
            B[r, j] = J.dxdot_du[i]
    Cmat = np.zeros((n + 3, nx))
    Cmat[:n, :n] = np.eye(n)
    Cmat[n:, :n] = model.jacobian(q)[:3]
    return A, B, Cmat, np.zeros((n + 3, n))


def linearize(spec: ManipulatorSpec, operating_point_: ArrayLike | Mapping[str, ArrayLike], *,
              model: AnalyticModel | None = None) -> Any:
    """The plant linearised around an operating point, as a python-control ``StateSpace``.

    Args:
        spec: the arm.
        operating_point_: joint positions q (n,) (the arm is then at rest, its pressures
            balancing it, see :func:`operating_point`), or a mapping with ``q`` and any of
            ``qd``, ``u`` and the actuator states (``dP``, ``Q``, ...) (missing ones are filled
            in as by :func:`operating_point`).
        model: a ready analytic model of ``spec``.

    Returns:
        ``control.StateSpace`` with states ``q1, …, q1_dot, …`` and the actuator states
        ``<joint>_<state>`` (``q1_dP, …, q1_Q, …`` on a hydraulic arm), inputs
        ``<joint>_<command>`` (``q1_iv``: valve current, A; ``q1_tau``: force), outputs
        ``q1, …`` and ``ee_x, ee_y, ee_z`` (end-effector position, m). SI units.
    """
    import control  # python-control

    model = model or AnalyticModel(spec)
    if isinstance(operating_point_, Mapping):
        given = {k: np.asarray(v, dtype=float) for k, v in operating_point_.items()}
        states = [name for name, _ in _states([model_of(j) for j in spec.joints])]
        unknown = set(given) - {"q", "qd", "u", *states}
        if unknown or "q" not in given:
            raise LinearizeError(f"operating point keys must include 'q' and be among q, qd, u "
                                 f"and the actuator states {', '.join(states)}; got {sorted(given)}")
        point = {**operating_point(spec, given["q"], given.get("qd"), model=model), **given}
    else:
        point = operating_point(spec, operating_point_, model=model)
    A, B, C, D = jacobians(spec, point, model=model)
    labels = names(spec)
    return control.ss(A, B, C, D, states=labels["states"], inputs=labels["inputs"],
                      outputs=labels["outputs"], name=f"{spec.name}_linear")
