"""Kernels: the equations as flat expression lists, shrunk by common-subexpression elimination and
printed as C or Python source.

A kernel maps ``(p, q, qd, qdd)`` (parameters and one state; unused inputs are ignored) to a flat
output array. Every kernel has the same C signature, which lets one wrapper serve them all::

    void ml_<name>(const double *p, const double *q, const double *qd, const double *qdd,
                   double *out);
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable, Sequence
from typing import Any

from maniplab.model.dynamics import Dynamics
from maniplab.model.engine import Engine, Expr
from maniplab.model.kinematics import Chain, point_jacobian
from maniplab.workers import interruptible

#: Bump when the generated code changes in any way: it is part of every cache key.
GENERATOR_VERSION = "2"

INPUTS = ("q", "qd", "qdd")


@dataclasses.dataclass(frozen=True)
class Kernel:
    """One generated function.

    Attributes:
        name: C and Python name suffix ("M", "bias", ...).
        nin: how many of q, qd, qdd it reads (1 to 3).
        shape: shape of the output for one state.
        second: shape of a second output, written after the first (empty: one output).
        exprs: the output expressions, flattened in C order.
        doc: one line on what it computes.
    """

    name: str
    nin: int
    shape: tuple[int, ...]
    exprs: tuple[Expr, ...]
    doc: str
    second: tuple[int, ...] = ()

    @property
    def outputs(self) -> tuple[tuple[int, ...], ...]:
        """Shapes of the outputs for one state (the flat expressions fill them in order)."""
        return (self.shape, self.second) if self.second else (self.shape,)


@dataclasses.dataclass(frozen=True)
class CseKernel:
    """A kernel after common-subexpression elimination: temporaries, then outputs."""

    kernel: Kernel
    temps: tuple[tuple[Expr, Expr], ...]
    outputs: tuple[Expr, ...]

    @property
    def ops(self) -> int:
        """Operation count of the eliminated form (what one evaluation computes)."""
        return sum(_count_ops(e) for _, e in self.temps) + sum(_count_ops(e) for e in self.outputs)


def _count_ops(expr: Expr) -> int:
    import importlib

    module = importlib.import_module(type(expr).__module__.split(".")[0])
    return int(module.count_ops(expr))


def _flat(rows: Sequence[Any]) -> tuple[Expr, ...]:
    out: list[Expr] = []
    for r in rows:
        out.extend(_flat(r) if isinstance(r, (list, tuple)) else [r])
    return tuple(out)


def model_kernels(ch: Chain, dyn: Dynamics, qdd: list, engine: Engine) -> list[Kernel]:
    """The kernels of :class:`~maniplab.model.analytic.AnalyticModel` for one arm."""
    n = len(dyn.G)
    bias = [h + g for h, g in zip(dyn.h, dyn.G)]
    tau = [sum((dyn.M[i][j] * qdd[j] for j in range(n)), bias[i]) for i in range(n)]
    pose = ch.ee_rotation[0] + [ch.ee_position[0]], ch.ee_rotation[1] + [ch.ee_position[1]], \
        ch.ee_rotation[2] + [ch.ee_position[2]], [engine.zero] * 3 + [engine.one]
    lin, ang = point_jacobian(ch, ch.ee_position, n - 1, engine)
    jac = [[lin[j][r] for j in range(n)] for r in range(3)] + \
          [[ang[j][r] for j in range(n)] for r in range(3)]
    return [
        Kernel("M", 1, (n, n), _flat(dyn.M), "inertia matrix M(q)"),
        Kernel("C", 2, (n, n), _flat(dyn.C), "Christoffel matrix C(q, qd)"),
        Kernel("G", 1, (n,), _flat(dyn.G), "gravity forces G(q)"),
        Kernel("bias", 2, (n,), _flat(bias), "bias forces C(q, qd) qd + G(q)"),
        Kernel("mass_bias", 2, (n, n), _flat(dyn.M) + _flat(bias), "M(q) and C(q, qd) qd + G(q)",
               second=(n,)),
        Kernel("inverse_dynamics", 3, (n,), _flat(tau), "M(q) qdd + C(q, qd) qd + G(q)"),
        Kernel("fk", 1, (4, 4), _flat(pose), "end-effector pose, 4x4"),
        Kernel("jacobian", 1, (6, n), _flat(jac), "end-effector Jacobian [linear; angular]"),
    ]


def eliminate(kernel: Kernel, engine: Engine) -> CseKernel:
    """Common-subexpression elimination of one kernel (the engine's own cse, which for a large
    arm spends seconds in C: :func:`~maniplab.workers.interruptible` keeps Ctrl-C answered)."""
    temps, outputs = interruptible(engine.module.cse, list(kernel.exprs))
    return CseKernel(kernel, _live(list(temps), outputs), tuple(outputs))


def _live(temps: list[tuple[Expr, Expr]], outputs: Sequence[Expr]) -> tuple[tuple[Expr, Expr], ...]:
    """The temporaries the outputs need (symengine's cse can leave dead ones behind)."""
    needed: set[Any] = set()
    for e in outputs:
        needed |= e.free_symbols
    kept = []
    for sym, e in reversed(temps):
        if sym in needed:
            needed |= e.free_symbols
            kept.append((sym, e))
    return tuple(reversed(kept))


# --- printing ------------------------------------------------------------------------------------

_SYMBOL = re.compile(r"^(q|qd|qdd|p)(\d+)$")


def _input_symbols(ck: CseKernel) -> list[tuple[str, str, int]]:
    """(symbol name, array, index) for every input symbol the kernel reads, in a stable order."""
    names: set[str] = set()
    for _, e in ck.temps:
        names |= {str(s) for s in e.free_symbols}
    for e in ck.outputs:
        names |= {str(s) for s in e.free_symbols}
    found = []
    for name in names:
        m = _SYMBOL.match(name)
        if m:
            found.append((name, m.group(1), int(m.group(2))))
    order = {"p": 0, "q": 1, "qd": 2, "qdd": 3}
    return sorted(found, key=lambda t: (order[t[1]], t[2]))


def c_function(ck: CseKernel, printer: Callable[[Expr], str], prefix: str = "ml_") -> str:
    """C definition of one kernel (the uniform signature in the module docstring)."""
    k = ck.kernel
    size = sum(_size(s) for s in k.outputs)
    lines = [f"/* {k.doc}: out has {size} entries (shapes {k.outputs}, C order) */",
             f"void {prefix}{k.name}(const double *restrict p, const double *restrict q,",
             "        const double *restrict qd, const double *restrict qdd, double *restrict out)",
             "{",
             "    (void)p; (void)q; (void)qd; (void)qdd;"]
    lines += [f"    const double {s} = {arr}[{i}];" for s, arr, i in _input_symbols(ck)]
    lines += [f"    const double {t} = {printer(e)};" for t, e in ck.temps]
    lines += [f"    out[{i}] = {printer(e)};" for i, e in enumerate(ck.outputs)]
    lines.append("}")
    return "\n".join(lines)


def python_function(ck: CseKernel, printer: Callable[[Expr], str]) -> str:
    """Python definition ``def <name>(p, q, qd, qdd)`` returning a tuple of the outputs."""
    k = ck.kernel
    lines = [f"def {k.name}(p, q, qd, qdd):",
             (f"    \"\"\"{k.doc}: tuple of {sum(_size(s) for s in k.outputs)} floats "
              f"(shapes {k.outputs}, C order).\"\"\"")]
    lines += [f"    {s} = {arr}[{i}]" for s, arr, i in _input_symbols(ck)]
    lines += [f"    {t} = {printer(e)}" for t, e in ck.temps]
    outputs = ", ".join(printer(e) for e in ck.outputs)
    lines.append(f"    return ({outputs},)")
    return "\n".join(lines)


def _size(shape: tuple[int, ...]) -> int:
    size = 1
    for s in shape:
        size *= s
    return size


def c_printer(engine: Engine) -> Callable[[Expr], str]:
    """Expression -> C (math.h) text for the engine's expressions."""
    if engine.name == "symengine":
        return lambda e: engine.module.ccode(e)
    import sympy

    return lambda e: sympy.ccode(e, standard="c99")


def python_printer(engine: Engine) -> Callable[[Expr], str]:
    """Expression -> Python text using sin, cos, sqrt imported from math."""
    if engine.name == "symengine":
        # symengine writes a Rational p/q as "(p/q)", which Python evaluates as the nearest float
        return str
    import sympy
    from sympy.printing.pycode import PythonCodePrinter

    class _Printer(PythonCodePrinter):
        def _print_known_func(self, expr: Any) -> str:  # sin(x), not math.sin(x)
            return f"{type(expr).__name__}({', '.join(self._print(a) for a in expr.args)})"

    printer = _Printer({"fully_qualified_modules": False})
    return lambda e: printer.doprint(sympy.sympify(e))

