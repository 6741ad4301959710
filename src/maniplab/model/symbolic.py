"""SymbolicModel: the arm's kinematics and equations of motion as sympy matrices.

Parameters can stay symbolic, so a designer reads how each enters (``symbolic=("mass", "length",
"payload")`` turns masses m1.., lengths l1.. and the payload mass me into symbols; see
:data:`maniplab.model.GROUPS`). Nothing is simplified: for a 6-DOF arm ``simplify()`` does not finish,
and the expressions are exact as built. Use :meth:`SymbolicModel.cse` for a compact form.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import sympy

from maniplab.model.dynamics import derive
from maniplab.model.engine import get_engine
from maniplab.model.kinematics import homogeneous, point_jacobian
from maniplab.model.parameters import arm_terms
from maniplab.spec import ManipulatorSpec


class SymbolicModel:
    """Symbolic H, Jacobians, M, C, G and Fv of one arm (sympy).

    Joint symbols are 1-based: q1..qn, velocities qd1.., accelerations qdd1...

    Args:
        spec: the arm.
        symbolic: parameter groups kept as symbols (keys of :data:`maniplab.model.GROUPS`); all
            other parameters are numbers.

    Attributes:
        q, qd, qdd: joint symbols, n x 1 matrices.
        parameters: each parameter symbol with its value in the spec.
        H_joint: pose of each joint's frame after its motion (MuJoCo's body frame), n 4x4 matrices.
        H_cog: pose of each body's COG frame, n 4x4 matrices.
        H_ee: end-effector pose (the payload point), 4x4.
        J_cog: geometric Jacobian of each body's COG, [linear; angular], n matrices 6 x n.
        J_ee: geometric Jacobian of the end-effector point, 6 x n.
        M: inertia matrix, n x n.  C: Christoffel matrix, n x n.  G: gravity, n x 1.
        Fv: viscous friction, n x n diagonal.
    """

    def __init__(self, spec: ManipulatorSpec, symbolic: Iterable[str] = ()) -> None:
        engine = get_engine("sympy")
        self.spec = spec
        self.n = n = spec.n
        self.symbolic = tuple(symbolic)
        terms = arm_terms(spec, engine, symbolic=self.symbolic)
        self.parameters: dict[sympy.Symbol, float] = dict(terms.symbols)
        q = [sympy.Symbol(f"q{i + 1}") for i in range(n)]
        qd = [sympy.Symbol(f"qd{i + 1}") for i in range(n)]
        qdd = [sympy.Symbol(f"qdd{i + 1}") for i in range(n)]
        self.q, self.qd, self.qdd = sympy.Matrix(q), sympy.Matrix(qd), sympy.Matrix(qdd)
        ch, dyn = derive(spec, terms, q, qd, engine)
        self.H_joint = [sympy.Matrix(homogeneous(engine, r, p))
                        for r, p in zip(ch.rotations, ch.positions)]
        self.H_cog = [sympy.Matrix(homogeneous(engine, r, p)) for r, p in zip(ch.rotations, ch.cogs)]
        self.H_ee = sympy.Matrix(homogeneous(engine, ch.ee_rotation, ch.ee_position))
        self.J_cog = [_jacobian_matrix(*point_jacobian(ch, ch.cogs[b], b, engine)) for b in range(n)]
        self.J_ee = _jacobian_matrix(*point_jacobian(ch, ch.ee_position, n - 1, engine))
        self.M = sympy.Matrix(dyn.M)
        self.C = sympy.Matrix(dyn.C)
        self.G = sympy.Matrix(dyn.G)
        self.Fv = sympy.Matrix(dyn.Fv)
        self._h = sympy.Matrix(dyn.h)

    def __repr__(self) -> str:
        return f"SymbolicModel({self.spec.name!r}, n={self.n}, symbolic={self.symbolic})"

    @property
    def bias(self) -> sympy.Matrix:
        """C q̇ + G, n x 1 (MuJoCo's qfrc_bias)."""
        return self._h + self.G

    def inverse_dynamics(self, friction: bool = False) -> sympy.Matrix:
        """M q̈ + C q̇ + G (+ Fv q̇ when ``friction``), n x 1."""
        tau = self.M * self.qdd + self.bias
        return tau + self.Fv * self.qd if friction else tau

    def constrained(self, stuck: Sequence[int | str]) -> dict[str, Any]:
        """The stuck-joint terms for joints held at q̇ = q̈ = 0 (hybrid friction's STICK mode).

        With F the free and S the stuck joints and b = C q̇ + G at q̇_S = 0:
        ``M_FF q̈_F = τ_F - b_F`` and the holding force ``hold_S = M_SF q̈_F + b_S - τ_S``
        (the paper's e·M_D(q)q̈ is M_SF q̈_F).

        Returns:
            dict with "free" and "stuck" (0-based indices), "M_FF", "M_SF", "b_F", "b_S"
            (b with the stuck velocities set to zero).
        """
        S = sorted({self.spec.joint_index(k) for k in stuck})
        F = [i for i in range(self.n) if i not in S]
        b = self.bias.subs({self.qd[i]: 0 for i in S})
        return {"free": F, "stuck": S, "M_FF": self.M.extract(F, F), "M_SF": self.M.extract(S, F),
                "b_F": b.extract(F, [0]), "b_S": b.extract(S, [0])}

    def numeric(self, expr: Any) -> Any:
        """``expr`` with every parameter symbol replaced by its value in the spec."""
        return expr.xreplace({s: sympy.Float(v) for s, v in self.parameters.items()})

    def latex_names(self) -> dict[sympy.Symbol, str]:
        """LaTeX for each symbol (q̇ as \\dot q, ...), for ``sympy.latex(..., symbol_names=...)``."""
        names = {}
        for i in range(self.n):
            names[self.q[i]] = f"q_{{{i + 1}}}"
            names[self.qd[i]] = f"\\dot{{q}}_{{{i + 1}}}"
            names[self.qdd[i]] = f"\\ddot{{q}}_{{{i + 1}}}"
        for sym in self.parameters:
            names[sym] = _parameter_latex(str(sym))
        return names


def _jacobian_matrix(linear: list, angular: list) -> sympy.Matrix:
    n = len(linear)
    return sympy.Matrix([[linear[j][r] for j in range(n)] for r in range(3)]
                        + [[angular[j][r] for j in range(n)] for r in range(3)])


def _parameter_latex(name: str) -> str:
    """m1 -> m_{1}, I2xx -> I_{2,xx}, c1x -> c_{1,x}, me -> m_{e}, gx -> g_{x}, fv3 -> F_{v,3}."""
    import re

    if name == "me":
        return "m_{e}"
    if m := re.fullmatch(r"fv(\d+)", name):
        return f"F_{{v,{m.group(1)}}}"
    if m := re.fullmatch(r"([A-Za-z])(\d+)([a-z]*)", name):
        sub = m.group(2) + ("," + m.group(3) if m.group(3) else "")
        return f"{m.group(1)}_{{{sub}}}"
    if m := re.fullmatch(r"([ge])([xyz])", name):
        return f"{m.group(1)}_{{{m.group(2)}}}"
    return name


__all__ = ["SymbolicModel"]
