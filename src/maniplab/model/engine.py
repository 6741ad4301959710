"""The symbolic engine behind a derivation: sympy (readable, the user's matrices) or symengine (fast).

The derivation code in ``kinematics`` and ``dynamics`` is written once against this small interface
and never touches either library directly, so the same equations give a sympy model for reading and
a symengine model for code generation.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
from collections.abc import Callable
from typing import Any

from maniplab.model.errors import ModelArgumentError

Expr = Any  # a sympy or symengine expression
Vec = list  # three expressions
Mat = list  # three rows of three expressions


@dataclasses.dataclass(frozen=True)
class Engine:
    """The handful of constructors the derivation needs from a symbolic library.

    Attributes:
        name: "sympy" or "symengine".
        module: the library itself.
    """

    name: str
    module: Any

    def sin(self, x: Expr) -> Expr:
        return self.module.sin(x)

    def cos(self, x: Expr) -> Expr:
        return self.module.cos(x)

    def symbol(self, name: str) -> Expr:
        return self.module.Symbol(name)

    def rational(self, p: int, q: int) -> Expr:
        return self.module.Rational(p, q)

    def number(self, x: float) -> Expr:
        """An exact integer when ``x`` is integral (reads well: 0, 1, -1), else a float."""
        if math.isfinite(x) and x == int(x) and abs(x) < 2**53:
            return self.module.Integer(int(x))
        return self.module.Float(x) if self.name == "sympy" else self.module.RealDouble(x)

    @property
    def zero(self) -> Expr:
        return self.module.Integer(0)

    @property
    def one(self) -> Expr:
        return self.module.Integer(1)


def get_engine(name: str = "auto") -> Engine:
    """The engine called ``name`` ("sympy", "symengine", or "auto": symengine when installed).

    Raises:
        ModelArgumentError: for an unknown name.
        ImportError: when symengine is asked for but not installed.
    """
    if name == "auto":
        try:
            return Engine("symengine", importlib.import_module("symengine"))
        except ImportError:
            name = "sympy"
    if name not in ("sympy", "symengine"):
        raise ModelArgumentError(
            f"unknown symbolic engine {name!r}; expected sympy, symengine or auto")
    return Engine(name, importlib.import_module(name))


def to_sympy(expr: Expr) -> Any:
    """``expr`` as a sympy expression (a no-op for sympy input)."""
    import sympy

    return sympy.sympify(expr)


def apply(fn: Callable[[Expr], Expr], rows: list) -> list:
    """``fn`` applied to every entry of a nested list (vector or matrix)."""
    return [apply(fn, r) if isinstance(r, list) else fn(r) for r in rows]
