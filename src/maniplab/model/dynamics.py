"""Equations of motion from the kinematics: M(q), Christoffel C(q, q̇), G(q), viscous Fv.

The paper's eqs. (2)-(3) (Lagrange): M(q) = Σ_b m_b Jv_bᵀ Jv_b + Jω_bᵀ R_b I_b R_bᵀ Jω_b over the
bodies and the payload (its mass at its centre of gravity, its inertia); C from the Christoffel symbols of M; G = ∂V/∂q with
V = -Σ m g·p. Nothing here simplifies: expressions stay as built and are shrunk later by
common-subexpression elimination.
"""

from __future__ import annotations

import dataclasses

from maniplab.model.engine import Engine, Expr, Vec
from maniplab.model.kinematics import Chain, chain, dot, matvec, point_jacobian, rotation, transpose
from maniplab.model.parameters import ArmTerms
from maniplab.spec import ManipulatorSpec

Matrix = list  # n rows of n expressions


@dataclasses.dataclass
class Dynamics:
    """Symbolic equations of motion, nested lists of expressions (n = number of joints).

    Attributes:
        M: inertia matrix, n x n (kg, kg·m, kg·m²).
        C: Coriolis/centrifugal matrix in Christoffel form, n x n; Ṁ - 2C is skew-symmetric.
        h: C q̇, n (N or N·m).
        G: gravity forces, n (N or N·m).
        Fv: viscous friction matrix (diagonal), n x n.
    """

    M: Matrix
    C: Matrix
    h: list
    G: list
    Fv: Matrix


def inertia_matrix(spec: ManipulatorSpec, terms: ArmTerms, ch: Chain, q: list, engine: Engine) -> Matrix:
    """M(q) (symmetric, n x n) from body and payload Jacobians."""
    n = spec.n
    M = [[engine.zero] * n for _ in range(n)]
    for b, body in enumerate(terms.bodies):
        if body.mass != 0:
            lin, _ = point_jacobian(ch, ch.cogs[b], b, engine)
            _add_gram(M, lin, body.mass, b)
        if any(body.inertia[r][c] != 0 for r in range(3) for c in range(3)):
            ang = _body_frame_axes(spec, q, b, engine)
            for i in range(b + 1):
                Iw = matvec(body.inertia, ang[i])
                for j in range(i, b + 1):
                    M[i][j] = M[i][j] + dot(ang[j], Iw)
    if terms.ee_mass != 0:
        lin, _ = point_jacobian(ch, ch.payload_cog, n - 1, engine)
        _add_gram(M, lin, terms.ee_mass, n - 1)
    if any(terms.ee_inertia[r][c] != 0 for r in range(3) for c in range(3)):
        ang = _body_frame_axes(spec, q, n - 1, engine)  # the payload turns with the last body
        for i in range(n):
            Iw = matvec(terms.ee_inertia, ang[i])
            for j in range(i, n):
                M[i][j] = M[i][j] + dot(ang[j], Iw)
    for i in range(n):
        for j in range(i):
            M[i][j] = M[j][i]
    return M


def _add_gram(M: Matrix, columns: list[Vec], mass: Expr, upto: int) -> None:
    for i in range(upto + 1):
        for j in range(i, upto + 1):
            M[i][j] = M[i][j] + mass * dot(columns[i], columns[j])


def _body_frame_axes(spec: ManipulatorSpec, q: list, b: int, engine: Engine) -> list[Vec]:
    """Angular Jacobian columns of body b in body b's own frame, R_bᵀ z_i (zero for P joints).

    R_bᵀ z_i = Rot_bᵀ ⋯ Rot_{i+1}ᵀ a_i: built from the relative rotations only, which keeps the
    expressions far smaller than the product R_bᵀ R_i of absolute rotations.
    """
    z = engine.zero
    out = []
    for i in range(b + 1):
        if spec.joints[i].prismatic:
            out.append([z, z, z])
            continue
        k = "xyz".index(spec.joints[i].axis.value)
        w = [engine.one if r == k else z for r in range(3)]
        for m in range(i + 1, b + 1):
            if not spec.joints[m].prismatic:
                w = matvec(transpose(rotation(engine, spec.joints[m].axis.value, q[m])), w)
        out.append(w)
    return out


def gravity_vector(spec: ManipulatorSpec, terms: ArmTerms, ch: Chain, engine: Engine) -> list:
    """G(q) = -Σ m Jvᵀ g over bodies and payload, n expressions."""
    n = spec.n
    G = [engine.zero] * n
    points = [(body.mass, ch.cogs[b], b) for b, body in enumerate(terms.bodies)]
    points.append((terms.ee_mass, ch.payload_cog, n - 1))
    for mass, point, upto in points:
        if mass == 0:
            continue
        lin, _ = point_jacobian(ch, point, upto, engine)
        for i in range(upto + 1):
            G[i] = G[i] - mass * dot(lin[i], terms.gravity)
    return G


def inertia_derivatives(M: Matrix, q: list, engine: Engine) -> list[Matrix]:
    """dM[k][i][j] = ∂M_ij/∂q_k.

    ∂M_ij/∂q_k is exactly zero for k <= min(i, j): the block of M for joints k.. is the inertia of
    the sub-arm from joint k on, which moves rigidly with q_k. Writing that zero (instead of
    differentiating into terms that cancel only numerically) saves operations and rounding.
    """
    n = len(q)
    dM = []
    for k in range(n):
        d = [[engine.zero] * n for _ in range(n)]
        for i in range(n):
            for j in range(i, n):
                if k > i:
                    d[i][j] = d[j][i] = M[i][j].diff(q[k])
        dM.append(d)
    return dM


def christoffel(dM: list[Matrix], qd: list, engine: Engine) -> tuple[Matrix, list]:
    """C (Christoffel form) and h = C q̇ from the derivatives of M.

    C_kj = Σ_i Γ_kij q̇_i with Γ_kij = ½(∂M_kj/∂q_i + ∂M_ki/∂q_j - ∂M_ij/∂q_k);
    h_k = Σ_ij (∂M_kj/∂q_i - ½ ∂M_ij/∂q_k) q̇_i q̇_j (the same sum, fewer terms).
    """
    n = len(qd)
    half = engine.rational(1, 2)
    C = [[engine.zero] * n for _ in range(n)]
    h = [engine.zero] * n
    for k in range(n):
        for j in range(n):
            acc = engine.zero
            for i in range(n):
                gamma = dM[i][k][j] + dM[j][k][i] - dM[k][i][j]
                if gamma != 0:
                    acc = acc + gamma * qd[i]
            C[k][j] = acc * half
        acc = engine.zero
        for i in range(n):
            for j in range(n):
                term = dM[i][k][j] - half * dM[k][i][j]
                if term != 0:
                    acc = acc + term * qd[i] * qd[j]
        h[k] = acc
    return C, h


def derive(spec: ManipulatorSpec, terms: ArmTerms, q: list, qd: list, engine: Engine
           ) -> tuple[Chain, Dynamics]:
    """Kinematics and equations of motion of the arm for symbols q, q̇ (n each)."""
    ch = chain(spec, terms, q, engine)
    M = inertia_matrix(spec, terms, ch, q, engine)
    G = gravity_vector(spec, terms, ch, engine)
    C, h = christoffel(inertia_derivatives(M, q, engine), qd, engine)
    n = spec.n
    Fv = [[terms.viscous[i] if i == j else engine.zero for j in range(n)] for i in range(n)]
    return ch, Dynamics(M=M, C=C, h=h, G=G, Fv=Fv)
