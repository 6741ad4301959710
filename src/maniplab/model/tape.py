"""Straight-line code from algorithms run on recording scalars (a "tape").

The recursive algorithms of :mod:`~maniplab.model.recursive` are ordinary Python over numbers.
Run on :class:`Var` scalars, every arithmetic operation they perform is recorded as one statement
of single-assignment code instead of being evaluated, so the algorithm's own structure (one block
per link) becomes the structure of the generated code: its size grows with the work the algorithm
does, never with the size of an expanded closed form.

While recording, the tape

- folds constants (``0 * x``, ``x + 0``, ``1 * x`` and arithmetic on plain floats never emit code:
  a joint axis along z or a zero centre of gravity costs nothing at run time),
- numbers values, so an operation on the same operands is recorded once (local common
  subexpressions, e.g. the sine of a joint angle),
- and, when a kernel is printed, keeps only the statements its outputs need.

Floats are Python floats (IEEE doubles), so folding gives the bits C and Python would compute.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Union

#: A scalar while recording: a plain float (known now) or a Var (known when the code runs).
Num = Union[float, "Var"]

_COMMUTATIVE = frozenset({"+", "*"})


class Var:
    """A value the generated code computes: the target of one statement (or an input)."""

    __slots__ = ("index", "tape")

    def __init__(self, tape: Tape, index: int) -> None:
        self.tape, self.index = tape, index

    def __repr__(self) -> str:
        return f"Var({self.tape.stmts[self.index].name})"

    def __add__(self, other: Num) -> Num:
        return self.tape.add(self, other)

    def __radd__(self, other: Num) -> Num:
        return self.tape.add(other, self)

    def __sub__(self, other: Num) -> Num:
        return self.tape.sub(self, other)

    def __rsub__(self, other: Num) -> Num:
        return self.tape.sub(other, self)

    def __mul__(self, other: Num) -> Num:
        return self.tape.mul(self, other)

    def __rmul__(self, other: Num) -> Num:
        return self.tape.mul(other, self)

    def __truediv__(self, other: Num) -> Num:
        return self.tape.div(self, other)

    def __neg__(self) -> Num:
        return self.tape.neg(self)


@dataclasses.dataclass(frozen=True)
class Stmt:
    """One statement: ``name = op(args)``.

    Attributes:
        name: the variable it defines.
        op: "+", "-", "*", "/", "neg", "sin", "cos", "sqrt", or "in" (read ``array[index]``).
        args: operands (Vars or floats); for "in", (array name, index).
        index: its position on the tape (what a Var of it holds).
    """

    name: str
    op: str
    args: tuple
    index: int


class Tape:
    """The statements recorded so far, with constant folding and value numbering."""

    def __init__(self) -> None:
        self.stmts: list[Stmt] = []
        self._memo: dict[tuple, Var] = {}

    # --- recording ---------------------------------------------------------------------------
    def input(self, array: str, index: int) -> Var:
        """The scalar ``array[index]`` of a kernel argument (recorded once)."""
        return self._emit("in", (array, index))

    def inputs(self, array: str, size: int) -> list[Var]:
        """``array[0..size-1]`` as scalars."""
        return [self.input(array, i) for i in range(size)]

    def add(self, a: Num, b: Num) -> Num:
        if isinstance(a, float) and isinstance(b, float):
            return a + b
        if _is(b, 0.0):
            return a
        if _is(a, 0.0):
            return b
        if isinstance(b, Var) and self._op(b) == "neg":
            return self.sub(a, self._arg(b))
        if isinstance(a, Var) and self._op(a) == "neg":
            return self.sub(b, self._arg(a))
        return self._emit("+", (a, b))

    def sub(self, a: Num, b: Num) -> Num:
        if isinstance(a, float) and isinstance(b, float):
            return a - b
        if _is(b, 0.0):
            return a
        if _is(a, 0.0):
            return self.neg(b)
        if a is b:
            return 0.0
        if isinstance(b, Var) and self._op(b) == "neg":
            return self.add(a, self._arg(b))
        return self._emit("-", (a, b))

    def mul(self, a: Num, b: Num) -> Num:
        if isinstance(a, float) and isinstance(b, float):
            return a * b
        if _is(a, 0.0) or _is(b, 0.0):
            return 0.0
        if _is(a, 1.0):
            return b
        if _is(b, 1.0):
            return a
        if _is(a, -1.0):
            return self.neg(b)
        if _is(b, -1.0):
            return self.neg(a)
        if isinstance(a, Var) and self._op(a) == "neg":  # (-x) y = -(x y): the sign moves out
            return self.neg(self.mul(self._arg(a), b))
        if isinstance(b, Var) and self._op(b) == "neg":
            return self.neg(self.mul(a, self._arg(b)))
        return self._emit("*", (a, b))

    def div(self, a: Num, b: Num) -> Num:
        if isinstance(a, float) and isinstance(b, float):
            return a / b
        if _is(a, 0.0):
            return 0.0
        if _is(b, 1.0):
            return a
        return self._emit("/", (a, b))

    def neg(self, a: Num) -> Num:
        if isinstance(a, float):
            return -a
        if self._op(a) == "neg":
            return self._arg(a)
        return self._emit("neg", (a,))

    def call(self, fn: str, a: Num) -> Num:
        """``fn(a)`` for fn in sin, cos, sqrt."""
        if isinstance(a, float):
            import math

            return float(getattr(math, fn)(a))
        return self._emit(fn, (a,))

    # --- internals -----------------------------------------------------------------------------
    def _op(self, v: Var) -> str:
        return self.stmts[v.index].op

    def _arg(self, v: Var) -> Var:
        arg = self.stmts[v.index].args[0]
        assert isinstance(arg, Var)
        return arg

    def _emit(self, op: str, args: tuple) -> Var:
        keys = tuple(a.index if isinstance(a, Var) else ("c", a) for a in args)
        if op in _COMMUTATIVE:
            keys = tuple(sorted(keys, key=repr))
        key = (op, keys)
        found = self._memo.get(key)
        if found is not None:
            return found
        var = Var(self, len(self.stmts))
        name = f"{args[0]}{args[1]}" if op == "in" else f"t{len(self.stmts)}"
        self.stmts.append(Stmt(name, op, args, var.index))
        self._memo[key] = var
        return var


def _is(x: Num, value: float) -> bool:
    return isinstance(x, float) and x == value


# --- kernels -------------------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class TapeKernel:
    """One generated function: its recorded statements and its flat outputs.

    Attributes:
        name: C and Python name suffix ("M", "bias", ...).
        nin: how many of q, qd, qdd it reads (1 to 3).
        shape: shape of the output for one state.
        second: shape of a second output, written after the first (empty: one output).
        doc: one line on what it computes.
        stmts: the statements the outputs need, in order.
        outputs: the flat outputs (C order), Vars or floats.
    """

    name: str
    nin: int
    shape: tuple[int, ...]
    doc: str
    stmts: tuple[Stmt, ...]
    outputs: tuple[Num, ...]
    second: tuple[int, ...] = ()

    @property
    def output_shapes(self) -> tuple[tuple[int, ...], ...]:
        """Shapes of the outputs for one state (the flat values fill them in order)."""
        return (self.shape, self.second) if self.second else (self.shape,)

    @property
    def ops(self) -> int:
        """Arithmetic operations one evaluation performs (inputs not counted)."""
        return sum(s.op != "in" for s in self.stmts)


def kernel(tape: Tape, name: str, nin: int, shape: tuple[int, ...], doc: str,
           outputs: Sequence[Num], second: tuple[int, ...] = ()) -> TapeKernel:
    """A kernel of ``outputs`` with only the statements they need (dead code removed)."""
    flat = tuple(float(o) if isinstance(o, (int, float)) else o for o in outputs)
    live = [False] * len(tape.stmts)
    stack = [o.index for o in flat if isinstance(o, Var)]
    while stack:
        i = stack.pop()
        if not live[i]:
            live[i] = True
            stack += [a.index for a in tape.stmts[i].args if isinstance(a, Var)]
    stmts = tuple(s for s, keep in zip(tape.stmts, live) if keep)
    return TapeKernel(name, nin, shape, doc, stmts, flat, second)


# --- printing ------------------------------------------------------------------------------------

_INFIX = {"+": " + ", "-": " - ", "*": "*", "/": "/"}


def _literal(x: float) -> str:
    text = repr(float(x))
    return text if any(c in text for c in ".en") else text + ".0"


def c_function(k: TapeKernel, prefix: str = "ml_", static: bool = False) -> str:
    """C definition of one kernel::

        void <prefix><name>(const double *p, const double *q, const double *qd,
                            const double *qdd, double *out)
    """
    def name(x: Num) -> str:
        return x.tape.stmts[x.index].name if isinstance(x, Var) else _literal(x)

    size = sum(_size(s) for s in k.output_shapes)
    lines = [f"/* {k.doc}: out has {size} entries (shapes {k.output_shapes}, C order) */",
             (f"{'static ' if static else ''}void {prefix}{k.name}(const double *restrict p, "
              "const double *restrict q,"),
             "        const double *restrict qd, const double *restrict qdd, double *restrict out)",
             "{", "    (void)p; (void)q; (void)qd; (void)qdd;"]
    for s in k.stmts:
        if s.op == "in":
            lines.append(f"    const double {s.name} = {s.args[0]}[{s.args[1]}];")
        elif s.op in _INFIX:
            lines.append(f"    const double {s.name} = {name(s.args[0])}{_INFIX[s.op]}"
                         f"{name(s.args[1])};")
        elif s.op == "neg":
            lines.append(f"    const double {s.name} = -{name(s.args[0])};")
        else:
            lines.append(f"    const double {s.name} = {s.op}({name(s.args[0])});")
    lines += [f"    out[{i}] = {name(o)};" for i, o in enumerate(k.outputs)]
    lines.append("}")
    return "\n".join(lines)


def python_function(k: TapeKernel, name: str | None = None) -> str:
    """Python definition ``def <name>(p, q, qd, qdd)`` returning the flat outputs as a tuple.

    A temporary used once is written into the expression that uses it (fewer statements: the
    interpreter's cost is per statement as much as per operation), up to a nesting depth.
    """
    uses: dict[int, int] = {}
    for s in k.stmts:
        for a in s.args:
            if isinstance(a, Var):
                uses[a.index] = uses.get(a.index, 0) + 1
    for o in k.outputs:
        if isinstance(o, Var):
            uses[o.index] = uses.get(o.index, 0) + 2  # outputs stay named
    text: dict[int, tuple[str, int]] = {}  # statement index -> (expression, nesting depth)
    lines = [f"def {name or k.name}(p, q, qd, qdd):",
             (f"    \"\"\"{k.doc}: tuple of {sum(_size(s) for s in k.output_shapes)} floats "
              f"(shapes {k.output_shapes}, C order).\"\"\"")]

    def operand(x: Num) -> tuple[str, int]:
        if isinstance(x, Var):
            return text[x.index]
        return (f"({_literal(x)})" if x < 0 else _literal(x)), 0

    lines += _unpack_inputs(k)
    for s in k.stmts:
        index = s.index
        if s.op == "in":
            text[index] = (s.name, 0)
            continue
        else:
            parts = [operand(a) for a in s.args]
            depth = 1 + max(d for _, d in parts)
            if s.op in _INFIX:
                expr = f"({parts[0][0]}{_INFIX[s.op]}{parts[1][0]})"
            elif s.op == "neg":
                expr = f"(-{parts[0][0]})"
            else:
                expr = f"{s.op}({parts[0][0]})"
        if uses.get(index, 0) == 1 and depth < 24:
            text[index] = (expr, depth)
        else:
            lines.append(f"    {s.name} = {expr}")
            text[index] = (s.name, 0)
    outputs = ", ".join(operand(o)[0] for o in k.outputs)
    lines.append(f"    return ({outputs},)")
    return "\n".join(lines)


def matlab_function(k: TapeKernel, name: str | None = None, output: str = "out",
                    header: Sequence[str] = ()) -> str:
    """MATLAB/GNU Octave definition ``function <output> = <name>(q[, qd[, qdd]], p)``.

    One statement per recorded operation (``t5 = q0*t3;``), inputs read 1-based (``q0 = q(1);``,
    so q may be a row or a column), literals at full precision (repr: 17 significant digits, which
    MATLAB reads back to the same double). The output is preallocated with ``zeros`` and filled
    entry by entry in its own shape: an (r, c) output is an r-by-c matrix, an (n,) output an n-by-1
    column. Only scalar ``*`` and ``/`` on scalars are printed, so no ``.*`` is needed.

    Args:
        k: a kernel with one output (not ``mass_bias``).
        name: the function's name (default the kernel's).
        output: the output variable's name.
        header: lines inserted after the signature (help text, argument checks), as given.
    """
    if k.second:
        raise ValueError(f"matlab_function prints kernels with one output, not {k.name!r}")

    def operand(x: Num) -> str:
        if isinstance(x, Var):
            return x.tape.stmts[x.index].name
        return f"({_literal(x)})" if x < 0 else _literal(x)

    args = ["q", "qd", "qdd"][:k.nin] + ["p"]
    lines = [f"function {output} = {name or k.name}({', '.join(args)})", *header]
    for s in k.stmts:
        if s.op == "in":
            lines.append(f"{s.name} = {s.args[0]}({s.args[1] + 1});")
        elif s.op in _INFIX:
            lines.append(f"{s.name} = {operand(s.args[0])}{_INFIX[s.op]}{operand(s.args[1])};")
        elif s.op == "neg":
            lines.append(f"{s.name} = -{operand(s.args[0])};")
        else:
            lines.append(f"{s.name} = {s.op}({operand(s.args[0])});")
    rows, cols = (k.shape[0], 1) if len(k.shape) == 1 else k.shape
    lines.append(f"{output} = zeros({rows}, {cols});")
    for i, o in enumerate(k.outputs):
        if isinstance(o, float) and o == 0.0 and str(o) == "0.0":
            continue  # zeros() has it (a -0.0 is written, to keep its sign)
        where = f"{i + 1}" if len(k.shape) == 1 else f"{i // cols + 1}, {i % cols + 1}"
        lines.append(f"{output}({where}) = {operand(o)};")
    lines.append("end")
    return "\n".join(lines)


def _unpack_inputs(k: TapeKernel) -> list[str]:
    """One statement per input array, ``q0, _, q2 = q[0:3]``: unpacking beats indexing."""
    names: dict[str, dict[int, str]] = {}
    for s in k.stmts:
        if s.op == "in":
            names.setdefault(s.args[0], {})[s.args[1]] = s.name
    lines = []
    for array, used in names.items():
        lo, hi = min(used), max(used)
        targets = [used.get(i, "_") for i in range(lo, hi + 1)]
        lines.append(f"    {', '.join(targets)}, = {array}[{lo}:{hi + 1}]")
    return lines


def _size(shape: tuple[int, ...]) -> int:
    size = 1
    for s in shape:
        size *= s
    return size
