"""The arm's dynamics by recursive algorithms, written once over scalars and recorded on a tape.

- Inverse dynamics, bias and gravity forces: the recursive Newton-Euler algorithm (RNEA) in the
  bodies' own frames, where a joint's rotation is about a base axis and costs a few products.
- Inertia matrix: the composite-rigid-body algorithm (CRBA) with spatial vectors in base
  coordinates, M_kj = S_kᵀ I^C_j S_j (k <= j).
- Coriolis matrix in Christoffel form: Echeandia and Wensing's algorithm (2021) in base
  coordinates, C = Σ_i J_iᵀ (I_i J̇_i + B_i J_i) with B(I, v) = ½((v×*) I + (I v)×̄* - I (v×)),
  which gives Ṁ = C + Cᵀ and C(q, v) w = C(q, w) v: the unique Christoffel form.
- End-effector pose and geometric Jacobian from the same base-frame kinematics.

Spatial vectors are [angular; linear] with the linear part taken at the base origin. The cost of
each kernel grows like the number of joints (RNEA) or its square (M, C: one short dot product per
entry), and the code printed from the tape grows the same way.
"""

from __future__ import annotations

from collections.abc import Sequence

from maniplab.model.inertial import InertialParameters, Slot
from maniplab.model.kinematics import add, cross, scale, sub
from maniplab.model.tape import Num, Tape, TapeKernel, kernel

V3 = list  # three Nums
M3 = list  # three rows of three Nums
V6 = list  # six Nums: [angular; linear]

_ZERO = 0.0


class Link:
    """One joint and its body as the algorithms read them (scalars: floats or tape Vars).

    Attributes:
        axis: 0, 1, 2 for x, y, z.  prismatic: a sliding joint.
        mass, h (3), inertia (3x3 about the joint), offset (3): see :mod:`.inertial`.
    """

    def __init__(self, axis: int, prismatic: bool, mass: Num, h: V3, inertia: M3,
                 offset: V3) -> None:
        self.axis, self.prismatic = axis, prismatic
        self.mass, self.h, self.inertia, self.offset = mass, h, inertia, offset

    @property
    def unit(self) -> V3:
        return [1.0 if r == self.axis else _ZERO for r in range(3)]


class Arm:
    """The links, gravity and end-effector point, read from the parameter vector ``p``."""

    def __init__(self, tape: Tape, params: InertialParameters, axes: Sequence[int],
                 prismatic: Sequence[bool]) -> None:
        slots = iter(range(len(params.values)))

        def read(slot: Slot) -> Num:
            return tape.input("p", next(slots)) if slot.structural else _ZERO

        self.links = []
        for body, axis, slide in zip(params.bodies, axes, prismatic):
            mass = read(body.mass)
            h = [read(s) for s in body.first_moment]
            xx, yy, zz, xy, xz, yz = (read(s) for s in body.inertia)
            offset = [read(s) for s in body.offset]
            self.links.append(Link(axis, slide, mass, h, [[xx, xy, xz], [xy, yy, yz],
                                                           [xz, yz, zz]], offset))
        self.gravity = [read(s) for s in params.gravity]
        self.end_effector = [read(s) for s in params.end_effector]

    @property
    def n(self) -> int:
        return len(self.links)

    def joint_offset(self, i: int, q: Sequence[Num]) -> V3:
        """Joint i's origin relative to joint i-1's, in body i-1's frame (the base for i = 0)."""
        p = list(self.links[i - 1].offset) if i > 0 else [_ZERO] * 3
        link = self.links[i]
        if link.prismatic:
            p[link.axis] = p[link.axis] + q[i]
        return p


# --- vectors (add, sub, scale and cross work on any scalars: kinematics' serve) ---------------------

def dot(a: Sequence[Num], b: Sequence[Num]) -> Num:
    acc: Num = _ZERO
    for x, y in zip(a, b):
        acc = acc + x * y
    return acc


def matvec(m: M3, v: V3) -> V3:
    return [dot(row, v) for row in m]


def rotate(axis: int, c: Num, s: Num, v: V3, transpose: bool = False) -> V3:
    """Rot(axis, θ) v (or Rotᵀ v) with c = cos θ, s = sin θ: only two components change."""
    i, j = (axis + 1) % 3, (axis + 2) % 3
    out = list(v)
    if transpose:
        out[i] = c * v[i] + s * v[j]
        out[j] = c * v[j] - s * v[i]
    else:
        out[i] = c * v[i] - s * v[j]
        out[j] = s * v[i] + c * v[j]
    return out


# --- inverse dynamics: RNEA in body frames ---------------------------------------------------------

def rnea(tape: Tape, arm: Arm, q: Sequence[Num], qd: Sequence[Num], qdd: Sequence[Num],
         gravity: bool = True) -> list[Num]:
    """Joint forces M q̈ + C q̇ (+ G with ``gravity``), n scalars (N·m or N)."""
    w: V3 = [_ZERO] * 3
    dw: V3 = [_ZERO] * 3
    a: V3 = [-g for g in arm.gravity] if gravity else [_ZERO] * 3  # base "accelerates" up
    wrenches: list[tuple[V3, V3]] = []
    trig: list[tuple[Num, Num] | None] = []
    for i, link in enumerate(arm.links):
        p = arm.joint_offset(i, q)
        a = add(a, add(cross(dw, p), cross(w, cross(w, p))))
        e = link.unit
        if link.prismatic:
            trig.append(None)
            a = add(a, add(scale(cross(w, e), 2.0 * qd[i]), scale(e, qdd[i])))
        else:
            c, s = tape.call("cos", q[i]), tape.call("sin", q[i])
            trig.append((c, s))
            w, dw, a = (rotate(link.axis, c, s, v, transpose=True) for v in (w, dw, a))
            dw = add(dw, add(scale(cross(w, e), qd[i]), scale(e, qdd[i])))
            w = add(w, scale(e, qd[i]))
        h, inertia = link.h, link.inertia
        force = add(scale(a, link.mass), add(cross(dw, h), cross(w, cross(w, h))))
        moment = add(add(matvec(inertia, dw), cross(w, matvec(inertia, w))), cross(h, a))
        wrenches.append((force, moment))
    tau: list[Num] = [_ZERO] * arm.n
    f: V3 = [_ZERO] * 3
    m: V3 = [_ZERO] * 3
    for i in reversed(range(arm.n)):
        if i + 1 < arm.n:  # the outer body's wrench, in this body's frame
            child = arm.links[i + 1]
            turn = trig[i + 1]
            if turn is not None:
                c, s = turn
                f, m = rotate(child.axis, c, s, f), rotate(child.axis, c, s, m)
            m = add(m, cross(arm.joint_offset(i + 1, q), f))
        f, m = add(wrenches[i][0], f), add(wrenches[i][1], m)
        link = arm.links[i]
        tau[i] = f[link.axis] if link.prismatic else m[link.axis]
    return tau


# --- base-frame kinematics and spatial algebra ---------------------------------------------------

class Frames:
    """Each body's rotation R_i and joint origin o_i in base coordinates, and its motion axis S_i.

    Attributes:
        rotations: n 3x3.  origins: n 3-vectors, m.  axes: n unit 3-vectors (z_i).
        motions: n spatial 6-vectors S_i = [z; o × z] (revolute) or [0; z] (prismatic).
    """

    def __init__(self, tape: Tape, arm: Arm, q: Sequence[Num]) -> None:
        R: M3 = [[1.0 if r == c else _ZERO for c in range(3)] for r in range(3)]
        o: V3 = [_ZERO] * 3
        self.rotations, self.origins, self.axes, self.motions = [], [], [], []
        for i, link in enumerate(arm.links):
            o = add(o, matvec(R, arm.joint_offset(i, q)))
            if not link.prismatic:  # R Rot(axis, q): two columns change
                c, s = tape.call("cos", q[i]), tape.call("sin", q[i])
                cols = [[R[r][m] for r in range(3)] for m in range(3)]
                a, b = (link.axis + 1) % 3, (link.axis + 2) % 3
                cols[a], cols[b] = (add(scale(cols[a], c), scale(cols[b], s)),
                                    sub(scale(cols[b], c), scale(cols[a], s)))
                R = [[cols[m][r] for m in range(3)] for r in range(3)]
            z = [R[r][link.axis] for r in range(3)]
            self.rotations.append(R)
            self.origins.append(o)
            self.axes.append(z)
            self.motions.append([_ZERO] * 3 + z if link.prismatic else z + cross(o, z))


class SpatialInertia:
    """A rigid body's inertia about the base origin, base axes: m, h = m c (3), I_O (3x3)."""

    def __init__(self, m: Num, h: V3, inertia: M3) -> None:
        self.m, self.h, self.inertia = m, h, inertia

    @classmethod
    def of_link(cls, link: Link, R: M3, o: V3) -> SpatialInertia:
        """The link's parameters (about its joint, its axes) moved to the base origin and axes."""
        hr = matvec(R, link.h)
        ri = [[dot(R[r], [link.inertia[k][c] for k in range(3)]) for c in range(3)]
              for r in range(3)]
        rir: M3 = [[_ZERO] * 3 for _ in range(3)]
        for r in range(3):
            for c in range(r, 3):
                rir[r][c] = rir[c][r] = dot(ri[r], R[c])
        oo, oh = dot(o, o), dot(o, hr)
        inertia = [[rir[r][c] + link.mass * ((oo if r == c else _ZERO) - o[r] * o[c])
                    + ((2.0 * oh if r == c else _ZERO) - o[r] * hr[c] - hr[r] * o[c])
                    for c in range(3)] for r in range(3)]
        return cls(link.mass, add(hr, scale(o, link.mass)), inertia)

    def __add__(self, other: SpatialInertia) -> SpatialInertia:
        return SpatialInertia(self.m + other.m, add(self.h, other.h),
                              [add(a, b) for a, b in zip(self.inertia, other.inertia)])

    def apply(self, v: V6) -> V6:
        """I v: [I_O ω + h × v_O; m v_O - h × ω]."""
        w, lin = v[:3], v[3:]
        return add(matvec(self.inertia, w), cross(self.h, lin)) + \
            sub(scale(lin, self.m), cross(self.h, w))

    def matrix(self) -> list[V6]:
        """The 6x6 matrix [[I_O, h×], [-h×, m 1]]."""
        hx = _skew(self.h)
        top = [self.inertia[r] + hx[r] for r in range(3)]
        bottom = [[-x for x in hx[r]] + [self.m if c == r else _ZERO for c in range(3)]
                  for r in range(3)]
        return top + bottom


def _skew(v: V3) -> M3:
    return [[_ZERO, -v[2], v[1]], [v[2], _ZERO, -v[0]], [-v[1], v[0], _ZERO]]


def motion_cross(v: V6, m: V6) -> V6:
    """v × m for spatial motion vectors."""
    return cross(v[:3], m[:3]) + add(cross(v[:3], m[3:]), cross(v[3:], m[:3]))


def force_cross(v: V6, f: V6) -> V6:
    """v ×* f for a motion v and a force f."""
    return add(cross(v[:3], f[:3]), cross(v[3:], f[3:])) + cross(v[:3], f[3:])


def _columns(matrix: list[V6]) -> list[V6]:
    return [[row[c] for row in matrix] for c in range(6)]


def _from_columns(columns: list[V6]) -> list[V6]:
    return [[col[r] for col in columns] for r in range(6)]


def _madd(a: list[V6], b: list[V6]) -> list[V6]:
    return [[x + y for x, y in zip(ra, rb)] for ra, rb in zip(a, b)]


def _mvec(matrix: list[V6], v: V6) -> V6:
    return [dot(row, v) for row in matrix]


def _mtvec(matrix: list[V6], v: V6) -> V6:
    return [dot([row[c] for row in matrix], v) for c in range(6)]


def coriolis_factor(inertia: SpatialInertia, v: V6) -> list[V6]:
    """B(I, v) = ½((v×*) I + (I v)×̄* - I (v×)), 6x6, with B v = v ×* I v and B + Bᵀ = İ."""
    matrix = inertia.matrix()
    iv = inertia.apply(v)
    columns = []
    for c in range(6):
        e = [1.0 if r == c else _ZERO for r in range(6)]
        col = add(force_cross(v, [row[c] for row in matrix]), force_cross(e, iv))
        col = sub(col, inertia.apply(motion_cross(v, e)))
        columns.append(scale(col, 0.5))
    return _from_columns(columns)


# --- M, C, kinematics ----------------------------------------------------------------------------

def composite(inertias: list[SpatialInertia]) -> list[SpatialInertia]:
    """I^C_j = Σ_{i >= j} I_i (a serial chain: body j carries every body after it)."""
    out = list(inertias)
    for j in reversed(range(len(out) - 1)):
        out[j] = out[j] + out[j + 1]
    return out


def link_inertias(arm: Arm, frames: Frames) -> list[SpatialInertia]:
    return [SpatialInertia.of_link(link, R, o)
            for link, R, o in zip(arm.links, frames.rotations, frames.origins)]


def mass_matrix(arm: Arm, frames: Frames) -> list[list[Num]]:
    """M(q), n x n, by the CRBA in base coordinates."""
    n, S = arm.n, frames.motions
    IC = composite(link_inertias(arm, frames))
    M: list[list[Num]] = [[_ZERO] * n for _ in range(n)]
    for j in range(n):
        force = IC[j].apply(S[j])
        for k in range(j + 1):
            M[k][j] = M[j][k] = dot(S[k], force)
    return M


def coriolis_matrix(arm: Arm, frames: Frames, qd: Sequence[Num]) -> list[list[Num]]:
    """C(q, q̇) in Christoffel form, n x n (module docstring)."""
    n, S = arm.n, frames.motions
    inertias = link_inertias(arm, frames)
    v: V6 = [_ZERO] * 6
    Sd, B = [], []
    for i in range(n):
        v = add(v, scale(S[i], qd[i]))
        Sd.append(motion_cross(v, S[i]))
        B.append(coriolis_factor(inertias[i], v))
    IC = composite(inertias)
    BC = list(B)
    for j in reversed(range(n - 1)):
        BC[j] = _madd(BC[j], BC[j + 1])
    C: list[list[Num]] = [[_ZERO] * n for _ in range(n)]
    for j in range(n):
        f1 = add(IC[j].apply(Sd[j]), _mvec(BC[j], S[j]))
        f2, f3 = IC[j].apply(S[j]), _mtvec(BC[j], S[j])
        for k in range(j + 1):
            C[k][j] = dot(S[k], f1)
            if k < j:
                C[j][k] = dot(Sd[k], f2) + dot(S[k], f3)
    return C


def end_effector(arm: Arm, frames: Frames) -> tuple[M3, V3]:
    """Rotation and position of the end-effector frame in base coordinates."""
    R = frames.rotations[-1]
    return R, add(frames.origins[-1], matvec(R, arm.end_effector))


def jacobian(arm: Arm, frames: Frames) -> list[list[Num]]:
    """Geometric Jacobian of the end-effector point, 6 x n, rows [linear; angular]."""
    _, point = end_effector(arm, frames)
    columns = []
    for link, z, o in zip(arm.links, frames.axes, frames.origins):
        if link.prismatic:
            columns.append(z + [_ZERO] * 3)
        else:
            columns.append(cross(z, sub(point, o)) + z)
    return [[col[r] for col in columns] for r in range(6)]


# --- the kernels -----------------------------------------------------------------------------------

def model_kernels(params: InertialParameters, axes: Sequence[int],
                  prismatic: Sequence[bool]) -> list[TapeKernel]:
    """The kernels of :class:`~maniplab.model.analytic.AnalyticModel`, each on a tape of its own."""
    n = len(axes)
    zeros = [_ZERO] * n

    def start(nin: int) -> tuple[Tape, Arm, list[Num], list[Num], list[Num]]:
        tape = Tape()
        arm = Arm(tape, params, axes, prismatic)
        state = [tape.inputs(name, n) if k < nin else zeros
                 for k, name in enumerate(("q", "qd", "qdd"))]
        return tape, arm, *state  # type: ignore[return-value]

    def flat(rows: list[list[Num]]) -> list[Num]:
        return [x for row in rows for x in row]

    out = []
    tape, arm, q, _, _ = start(1)
    out.append(kernel(tape, "M", 1, (n, n), "inertia matrix M(q)", flat(mass_matrix(arm, Frames(tape, arm, q)))))
    tape, arm, q, qd, _ = start(2)
    out.append(kernel(tape, "C", 2, (n, n), "Christoffel matrix C(q, qd)",
                      flat(coriolis_matrix(arm, Frames(tape, arm, q), qd))))
    tape, arm, q, _, _ = start(1)
    out.append(kernel(tape, "G", 1, (n,), "gravity forces G(q)", rnea(tape, arm, q, zeros, zeros)))
    tape, arm, q, qd, _ = start(2)
    out.append(kernel(tape, "bias", 2, (n,), "bias forces C(q, qd) qd + G(q)",
                      rnea(tape, arm, q, qd, zeros)))
    tape, arm, q, qd, _ = start(2)
    both = flat(mass_matrix(arm, Frames(tape, arm, q))) + rnea(tape, arm, q, qd, zeros)
    out.append(kernel(tape, "mass_bias", 2, (n, n), "M(q) and C(q, qd) qd + G(q)", both,
                      second=(n,)))
    tape, arm, q, qd, qdd = start(3)
    out.append(kernel(tape, "inverse_dynamics", 3, (n,), "M(q) qdd + C(q, qd) qd + G(q)",
                      rnea(tape, arm, q, qd, qdd)))
    tape, arm, q, _, _ = start(1)
    R, point = end_effector(arm, Frames(tape, arm, q))
    pose = [R[r] + [point[r]] for r in range(3)] + [[_ZERO, _ZERO, _ZERO, 1.0]]
    out.append(kernel(tape, "fk", 1, (4, 4), "end-effector pose, 4x4", flat(pose)))
    tape, arm, q, _, _ = start(1)
    out.append(kernel(tape, "jacobian", 1, (6, n), "end-effector Jacobian [linear; angular]",
                      flat(jacobian(arm, Frames(tape, arm, q)))))
    return out
