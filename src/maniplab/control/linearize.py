"""Linearisation of the plant (rigid body + eq. 4 hydraulics) around an operating point.

State x = [q (n); q̇ (n); ΔP (h); Q (h)] over the n joints and the h hydraulic joints, input
u = [i_v at hydraulic joints | force at torque joints] in joint order, output
y = [q (n); end-effector position (3)]. The nonlinear plant is

    M(q) q̈ = τ(ΔP, u) - C(q, q̇) q̇ - G(q) - F(q̇)         τ = A ΔP (hydraulic) or u (torque)
    dΔP/dt = (E/V)(Q - Le ΔP - A q̇)
    dQ/dt  = (i_v C sqrt(1 - |ΔP|/Ps) - Q) / τ_v

with F the joints' slip friction: viscous Fv q̇ plus, for a joint that moves (q̇ ≠ 0, hybrid or
LuGre model), the Coulomb/Stribeck part sign(q̇)(Fc + Fs exp(-(q̇/vs)²)), whose slope enters the
linear model. At rest the Coulomb part is left out (it is discontinuous there: a real joint at
rest sticks, which no linear model represents). The Jacobian entries of the hydraulics and of
q̇ are exact; ∂q̈/∂q is a central difference of the analytic model's forward dynamics;
∂(C q̇)/∂q̇ = 2 C (Christoffel form).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from maniplab.control.actuation import ActuatorArrays
from maniplab.model import AnalyticModel
from maniplab.spec import ManipulatorSpec

ArrayLike = Any


def operating_point(spec: ManipulatorSpec, q: ArrayLike, qd: ArrayLike | None = None, *,
                    model: AnalyticModel | None = None) -> dict[str, np.ndarray]:
    """A steady operating point at q (and constant q̇): pressures that balance the arm, steady flows.

    ΔP = (G(q) + C(q, q̇) q̇ + F(q̇)) / A at hydraulic joints, Q = A q̇ + Le ΔP, and the input
    that holds it: i_v = Q / (C sqrt(1 - |ΔP|/Ps)), or the force at torque joints. q̈ = 0 there
    only when q̇ = 0 (a moving arm's bias changes with q).

    Returns:
        {"q", "qd", "dP", "Q", "u"}, each shape (n,) (NaN at joints without the element).
    """
    model = model or AnalyticModel(spec)
    act = ActuatorArrays.from_spec(spec)
    q = np.asarray(q, dtype=float)
    qd = np.zeros(spec.n) if qd is None else np.asarray(qd, dtype=float)
    tau = model.bias(q, qd) + _friction(spec, qd)[0]
    h = act.hydraulic
    dP = np.where(h, tau / act.area, np.nan)
    Q = np.where(h, act.area * qd + act.leakage * dP, np.nan)
    root = np.sqrt(np.maximum(1.0 - np.abs(dP) / act.supply_pressure, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(h, Q / (act.valve_gain * root), tau)
    return {"q": q, "qd": qd, "dP": dP, "Q": Q, "u": u}


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
    act = ActuatorArrays.from_spec(spec)
    joints = spec.joint_names
    hyd = [j for j, h in zip(joints, act.hydraulic) if h]
    return {
        "states": [f"{j}" for j in joints] + [f"{j}_dot" for j in joints]
        + [f"{j}_dP" for j in hyd] + [f"{j}_Q" for j in hyd],
        "inputs": [f"{j}_iv" if h else f"{j}_tau" for j, h in zip(joints, act.hydraulic)],
        "outputs": list(joints) + ["ee_x", "ee_y", "ee_z"],
    }


def jacobians(spec: ManipulatorSpec, point: Mapping[str, ArrayLike], *,
              model: AnalyticModel | None = None, fd_step: float = 1e-6
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(A, B, C, D) of the plant linearised at ``point`` (see :func:`linearize`)."""
    model = model or AnalyticModel(spec)
    act = ActuatorArrays.from_spec(spec)
    n, hi = spec.n, np.flatnonzero(act.hydraulic)
    h = len(hi)
    q = np.asarray(point["q"], dtype=float)
    qd = np.asarray(point.get("qd", np.zeros(n)), dtype=float)
    dP = np.asarray(point["dP"], dtype=float)
    u = np.asarray(point["u"], dtype=float)
    tau = np.where(act.hydraulic, act.area * np.nan_to_num(dP), u)
    fric, slope = _friction(spec, qd)

    def qdd(qq: np.ndarray) -> np.ndarray:
        return model.forward_dynamics(qq, qd, tau - fric)

    nx = 2 * n + 2 * h
    A = np.zeros((nx, nx))
    B = np.zeros((nx, n))
    iq, iv, ip, iQ = slice(0, n), slice(n, 2 * n), slice(2 * n, 2 * n + h), slice(2 * n + h, nx)
    A[iq, iv] = np.eye(n)
    for k in range(n):  # ∂q̈/∂q by central differences of the model's forward dynamics
        e = np.zeros(n)
        e[k] = fd_step
        A[iv, k] = (qdd(q + e) - qdd(q - e)) / (2.0 * fd_step)
    Minv = np.linalg.inv(model.M(q))
    A[iv, iv] = -Minv @ (2.0 * model.C(q, qd) + np.diag(slope))
    A[iv, ip] = Minv[:, hi] * act.area[hi]
    torque = np.flatnonzero(~act.hydraulic)
    B[iv, torque] = Minv[:, torque]
    cap = act.bulk_modulus[hi] / act.volume[hi]
    hrows = np.arange(h)
    A[2 * n + hrows, n + hi] = -cap * act.area[hi]
    A[2 * n + hrows, 2 * n + hrows] = -cap * act.leakage[hi]
    A[2 * n + hrows, 2 * n + h + hrows] = cap
    Ps, tau_v, C = act.supply_pressure[hi], act.valve_tau[hi], act.valve_gain[hi]
    p = dP[hi]
    root = np.sqrt(np.maximum(1.0 - np.abs(p) / Ps, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        droot = np.where(root > 0.0, -np.sign(p) / (2.0 * Ps * root), 0.0)
    A[2 * n + h + hrows, 2 * n + hrows] = u[hi] * C * droot / tau_v
    A[2 * n + h + hrows, 2 * n + h + hrows] = -1.0 / tau_v
    B[2 * n + h + hrows, hi] = C * root / tau_v
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
            ``qd``, ``dP``, ``Q``, ``u`` (missing ones are filled in as by
            :func:`operating_point`).
        model: a ready analytic model of ``spec``.

    Returns:
        ``control.StateSpace`` with states ``q1, …, q1_dot, …, q1_dP, …, q1_Q, …`` (ΔP and Q of
        the hydraulic joints only), inputs ``q1_iv`` (valve current, A) or ``q1_tau`` (force),
        outputs ``q1, …`` and ``ee_x, ee_y, ee_z`` (end-effector position, m). SI units.
    """
    import control  # python-control

    model = model or AnalyticModel(spec)
    if isinstance(operating_point_, Mapping):
        given = {k: np.asarray(v, dtype=float) for k, v in operating_point_.items()}
        unknown = set(given) - {"q", "qd", "dP", "Q", "u"}
        if unknown or "q" not in given:
            raise ValueError(f"operating point keys must include 'q' and be among q, qd, dP, Q, u; "
                             f"got {sorted(given)}")
        point = {**operating_point(spec, given["q"], given.get("qd"), model=model), **given}
    else:
        point = operating_point(spec, operating_point_, model=model)
    A, B, C, D = jacobians(spec, point, model=model)
    labels = names(spec)
    return control.ss(A, B, C, D, states=labels["states"], inputs=labels["inputs"],
                      outputs=labels["outputs"], name=f"{spec.name}_linear")
