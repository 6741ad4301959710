"""Export of the analytic model (the paper's "analytical model representation").

- ``latex`` / ``markdown``: M, C, G and Fv for reading, parameters as symbols. A small arm's
  entries are simplified (expand + trigsimp, affordable below :data:`SIMPLIFY_LIMIT` operations);
  a larger arm is written in common-subexpression form (x_k = ..., then the entries in x_k), since
  ``simplify()`` does not finish for 6 DOF.
- ``python``: a self-contained module (math and numpy only) with M, C, G, bias,
  inverse_dynamics, fk, jacobian and FV, the spec's values built in.
- ``c``: a self-contained C file (math.h only) with the same functions.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterable
from typing import Any

import sympy

from maniplab.actuators.hydraulic.pinned import PinnedCylinder
from maniplab.model.build import Generated, generate
from maniplab.model.dynamics import derive
from maniplab.model.engine import get_engine
from maniplab.model.errors import ModelArgumentError
from maniplab.model.parameters import arm_terms
from maniplab.model.tape import c_function, python_function
from maniplab.model.version import package_version
from maniplab.progress import Progress
from maniplab.spec import ManipulatorSpec, model_of

FORMATS = ("latex", "markdown", "python", "c")
SUFFIXES = {".tex": "latex", ".md": "markdown", ".py": "python", ".c": "c"}
DEFAULT_SYMBOLIC = ("mass", "length", "payload")
SIMPLIFY_LIMIT = 600  # total operations of M, C, G up to which entries are simplified


def export_model(spec: ManipulatorSpec, fmt: str, symbolic: Iterable[str] | None = None) -> str:
    """The analytic model of ``spec`` as text in ``fmt`` (one of :data:`FORMATS`).

    Args:
        symbolic: parameter groups kept as symbols in latex/markdown (default mass, length,
            payload); python and c always use the spec's numbers.

    Raises:
        ModelArgumentError: unknown format or parameter group.
    """
    if fmt not in FORMATS:
        raise ModelArgumentError(f"unknown format {fmt!r}; expected one of {', '.join(FORMATS)}")
    if fmt == "python":
        return python_module(spec)
    if fmt == "c":
        return c_file(spec)
    doc = readable(spec, DEFAULT_SYMBOLIC if symbolic is None else tuple(symbolic))
    return _latex_document(spec, doc) if fmt == "latex" else _markdown_document(spec, doc)


# --- readable forms ------------------------------------------------------------------------------

class Readable:
    """M, C, G, Fv entries (and cse temporaries) as sympy expressions, with LaTeX names."""

    def __init__(self) -> None:
        self.temps: list[tuple[Any, Any]] = []
        self.entries: dict[str, list[tuple[str, Any]]] = {"M": [], "C": [], "G": [], "Fv": []}
        self.names: dict[Any, str] = {}
        self.parameters: list[tuple[str, float, str]] = []  # latex name, value, meaning
        self.simplified = False

    def latex(self, expr: Any) -> str:
        return sympy.latex(expr, symbol_names=self.names)


def readable(spec: ManipulatorSpec, symbolic: tuple[str, ...]) -> Readable:
    """The readable form: simplified entries for a small arm, cse form for a larger one.

    The Lagrangian derivation grows fast with the arm (a minute at 8 joints): its stages show
    progress (a bar on a terminal, lines in a log) and answer Ctrl-C.
    """
    bar = Progress(3, f"maniplab: deriving the readable model of {spec.name}")
    try:
        bar.start(f"deriving M, C, G of {spec.n} joints (Lagrange)")
        engine = get_engine("auto")
        terms = arm_terms(spec, engine, symbolic=symbolic)
        n = spec.n
        q = [engine.symbol(f"q{i + 1}") for i in range(n)]
        qd = [engine.symbol(f"qd{i + 1}") for i in range(n)]
        _, dyn = derive(spec, terms, q, qd, engine)
        keys = ([("M", f"M_{{{i + 1}{j + 1}}}", dyn.M[i][j]) for i in range(n) for j in range(i, n)]
                + [("C", f"C_{{{i + 1}{j + 1}}}", dyn.C[i][j]) for i in range(n) for j in range(n)]
                + [("G", f"G_{{{i + 1}}}", dyn.G[i]) for i in range(n)])
        small = _at_most(engine, [e for _, _, e in keys], SIMPLIFY_LIMIT)
        bar.step("derived")
        bar.start("converting to sympy")
        exprs = [sympy.sympify(e) for _, _, e in keys]
        bar.step("converted")
        doc = Readable()
        if small:
            bar.start("simplifying")
            exprs = [sympy.factor_terms(sympy.trigsimp(sympy.expand(e))) for e in exprs]
            doc.simplified = True
        else:
            bar.start("eliminating common subexpressions")
            temps, reduced = sympy.cse(exprs, symbols=sympy.numbered_symbols("x"),
                                       optimizations=None)
            doc.temps, exprs = temps, reduced
        bar.step("done")
    finally:
        bar.close()
    for (group, label, _), e in zip(keys, exprs):
        doc.entries[group].append((label, e))
    doc.entries["Fv"] = [(f"F_{{v,{i + 1}}}", sympy.sympify(terms.viscous[i])) for i in range(n)]
    doc.names = _names(n, terms.symbols)
    doc.names.update({t: f"x_{{{str(t)[1:]}}}" for t, _ in doc.temps})
    doc.parameters = [(doc.names[sympy.Symbol(str(s))], v, _meaning(str(s), spec))
                      for s, v in terms.symbols.items()]
    return doc


def _at_most(engine: Any, exprs: list[Any], limit: int) -> bool:
    """Whether the expressions have at most ``limit`` operations in all (stops counting early)."""
    total = 0
    for e in exprs:
        total += int(engine.module.count_ops(e))
        if total > limit:
            return False
    return True


def _names(n: int, params: dict[Any, float]) -> dict[Any, str]:
    from maniplab.model.symbolic import _parameter_latex

    names: dict[Any, str] = {}
    for i in range(n):
        names[sympy.Symbol(f"q{i + 1}")] = f"q_{{{i + 1}}}"
        names[sympy.Symbol(f"qd{i + 1}")] = f"\\dot{{q}}_{{{i + 1}}}"
    for s in params:
        names[sympy.Symbol(str(s))] = _parameter_latex(str(s))
    return names


def _meaning(name: str, spec: ManipulatorSpec) -> str:
    joint = lambda k: spec.joints[int(k) - 1].name
    if m := re.fullmatch(r"m(\d+)", name):
        return f"mass of body {joint(m.group(1))}, kg"
    if m := re.fullmatch(r"l(\d+)", name):
        return f"length of body {joint(m.group(1))}, m"
    if m := re.fullmatch(r"c(\d+)([xyz])", name):
        return f"COG {m.group(2)} of body {joint(m.group(1))}, m"
    if m := re.fullmatch(r"I(\d+)(\w\w)", name):
        return f"inertia {m.group(2)} of body {joint(m.group(1))}, kg·m²"
    if m := re.fullmatch(r"fv(\d+)", name):
        return f"viscous friction of joint {joint(m.group(1))}"
    return {"me": "payload mass, kg", "gx": "gravity x, m/s²", "gy": "gravity y, m/s²",
            "gz": "gravity z, m/s²", "ex": "end-effector offset x, m",
            "ey": "end-effector offset y, m", "ez": "end-effector offset z, m"}.get(name, name)


def _intro(spec: ManipulatorSpec, doc: Readable) -> list[str]:
    form = ("entries simplified" if doc.simplified else
            f"common-subexpression form: {len(doc.temps)} temporaries x_k, then the entries")
    return [(f"Analytic model of '{spec.name}' ({spec.n} joints: "
             f"{', '.join(f'{j.name} {j.type.value}{j.axis.value}' for j in spec.joints)}), "
             f"generated by maniplab {package_version()}."),
            ("Equations of motion: M(q) q̈ + C(q, q̇) q̇ + G(q) + Fv q̇ = τ; C in Christoffel form; "
             f"M symmetric (upper triangle shown); {form}.")]


def _latex_document(spec: ManipulatorSpec, doc: Readable) -> str:
    def esc(text: str) -> str:
        return (text.replace("q̈", r"$\ddot q$").replace("q̇", r"$\dot q$").replace("τ", r"$\tau$")
                .replace("_", r"\_").replace("²", "$^2$").replace("·", r"$\cdot$"))

    lines = [r"\documentclass[10pt]{article}", r"\usepackage[margin=1.5cm,landscape]{geometry}",
             r"\usepackage{amsmath}", r"\allowdisplaybreaks", r"\begin{document}",
             r"\section*{" + esc(f"Analytic model: {spec.name}") + "}"]
    lines += [esc(p) + "\n" for p in _intro(spec, doc)]
    if doc.parameters:
        lines += [r"\subsection*{Parameters}", r"\begin{tabular}{lll}", r"symbol & value & meaning \\ \hline"]
        lines += [f"${name}$ & {value!r} & {esc(meaning)} \\\\" for name, value, meaning in doc.parameters]
        lines.append(r"\end{tabular}")
    sections = ([("Common subexpressions", [(doc.latex(t), e) for t, e in doc.temps])] if doc.temps else [])
    sections += [(title, doc.entries[key]) for key, title in
                 (("M", "Inertia matrix M(q)"), ("C", "Coriolis matrix C(q, q̇)"),
                  ("G", "Gravity G(q)"), ("Fv", "Viscous friction Fv (diagonal)"))]
    for title, rows in sections:
        lines += [r"\subsection*{" + esc(title) + "}", r"\begin{align*}"]
        lines += [f"{label} &= {doc.latex(e)} \\\\" for label, e in rows]
        lines.append(r"\end{align*}")
    cylinders = cylinder_terms(spec)
    if cylinders:
        lines += [r"\subsection*{Cylinders}", esc(CYLINDER_INTRO), r"\begin{align*}"]
        lines += [line.replace(" = ", " &= ", 1) + r" \\" for c in cylinders for line in c.latex()]
        lines.append(r"\end{align*}")
    lines.append(r"\end{document}")
    return "\n".join(lines) + "\n"


def _markdown_document(spec: ManipulatorSpec, doc: Readable) -> str:
    lines = [f"# Analytic model: {spec.name}", ""] + [p + "\n" for p in _intro(spec, doc)]
    if doc.parameters:
        lines += ["## Parameters", "", "| symbol | value | meaning |", "|---|---|---|"]
        lines += [f"| ${name}$ | {value!r} | {meaning} |" for name, value, meaning in doc.parameters]
        lines.append("")
    sections = ([("Common subexpressions", [(doc.latex(t), e) for t, e in doc.temps])] if doc.temps else [])
    sections += [(title, doc.entries[key]) for key, title in
                 (("M", "Inertia matrix M(q)"), ("C", "Coriolis matrix C(q, q̇)"),
                  ("G", "Gravity G(q)"), ("Fv", "Viscous friction Fv (diagonal)"))]
    for title, rows in sections:
        lines += [f"## {title}", ""]
        lines += [f"$$ {label} = {doc.latex(e)} $$\n" for label, e in rows]
    cylinders = cylinder_terms(spec)
    if cylinders:
        lines += ["## Cylinders", "", CYLINDER_INTRO, ""]
        lines += [f"$$ {line} $$\n" for c in cylinders for line in c.latex()]
    return "\n".join(lines)


# --- code: Python module and C file --------------------------------------------------------------

def c_identifier(name: str) -> str:
    """An arm's name as a C identifier: characters other than ASCII letters, digits and ``_``
    become ``_``; a name that starts with a digit (or is empty) gets ``arm_`` in front."""
    ident = re.sub(r"\W", "_", name, flags=re.ASCII)
    return ident if ident and not ident[0].isdigit() else f"arm_{ident}"


_PUBLIC = (  # kernel, Python/C signature arguments, output shape description
    ("M", ("q",)), ("C", ("q", "qd")), ("G", ("q",)), ("bias", ("q", "qd")),
    ("inverse_dynamics", ("q", "qd", "qdd")), ("fk", ("q",)), ("jacobian", ("q",)))


def python_module(spec: ManipulatorSpec) -> str:
    """A self-contained Python module (math, numpy) evaluating the arm's model."""
    version = package_version()
    gen = generate(spec)
    kernels = {k.name: k for k in gen.kernels}
    n = spec.n
    params = "\n".join(f"    {v!r},  # p{k}: {label}" for k, (v, label) in
                       enumerate(zip(gen.params.values.tolist(), gen.params.labels)))
    out = [f'"""Analytic model of the arm \'{spec.name}\', generated by maniplab {version}.',
           "",
           "Self-contained (math and numpy only): copy this file into any project.",
           f"Joints (q order): {', '.join(spec.joint_names)}. Units: SI; q in rad or m.",
           "Each function takes arrays of N floats and returns numpy arrays:",
           "M(q) (N, N); C(q, qd) (N, N), Christoffel form; G(q) (N,); bias(q, qd) = C qd + G;",
           "inverse_dynamics(q, qd, qdd) = M qdd + C qd + G (add FV * qd for viscous friction);",
           "fk(q) 4x4 end-effector pose; jacobian(q) (6, N) [linear; angular], base frame.",
           "cylinder_length(q), moment_arm(q) (N,): each pinned cylinder's pin-to-pin length s",
           "and r = ds/dq (NaN at joints without one); the joint force is (pA A_A - pB A_B) r;",
           "rod_friction(q, qd) (N,): a slipping cylinder's rod friction on its joint (0 without).",
           '"""', "", "from math import cos, sin, sqrt  # noqa: F401", "", "import numpy as np", "",
           f"N = {n}", f"JOINTS = {spec.joint_names!r}",
           f"FV = np.array({[j.friction.viscous for j in spec.joints]!r})  # viscous friction",
           f"P = (\n{params}\n)" if params else "P = (0.0,)", ""]
    out += _python_cylinders(spec)
    for name, args in _PUBLIC:
        k = kernels[name]
        kernel_src = python_function(k, name=f"_{name}")
        shape = k.shape
        call = ", ".join([f"list({a})" for a in args] + ["None"] * (3 - len(args)))
        out += ["", kernel_src, "", "",
                f"def {name}({', '.join(args)}):",
                f"    \"\"\"{k.doc}, shape {shape}.\"\"\"",
                f"    return np.array(_{name}(P, {call})).reshape{shape}", ""]
    return "\n".join(out)


def c_file(spec: ManipulatorSpec) -> str:
    """A self-contained C file (math.h only) evaluating the arm's model."""
    version = package_version()
    gen: Generated = generate(spec)
    kernels = {k.name: k for k in gen.kernels}
    prefix = c_identifier(spec.name)
    n, values = spec.n, gen.params.values.tolist()
    docs = "\n".join(f" *   void {prefix}_{name}({', '.join(f'const double *{a}' for a in args)}, "
                     f"double *out);  out: {kernels[name].shape}"
                     for name, args in _PUBLIC)
    params = "\n".join(f"    {v!r},  /* p{k}: {label} */" for k, (v, label) in
                       enumerate(zip(values, gen.params.labels or ("unused",))))
    out = [f"/* Analytic model of the arm '{spec.name}', generated by maniplab {version}.",
           " *", " * Self-contained (math.h only): compile with your project (cc -O2 ... -lm).",
           f" * Joints (q order): {', '.join(spec.joint_names)}. Units: SI; q in rad or m.",
           " * Arrays of doubles; outputs row-major (C order):", docs,
           " * M: inertia matrix; C: Christoffel matrix; G: gravity; bias: C qd + G;",
           " * inverse_dynamics: M qdd + C qd + G (add fv[i] * qd[i] for viscous friction);",
           " * fk: 4x4 end-effector pose; jacobian: 6 x N, rows [linear; angular], base frame.",
           f" *   void {prefix}_cylinder_length(const double *q, double *out);  out: (N,)",
           f" *   void {prefix}_moment_arm(const double *q, double *out);  out: (N,)",
           " * each pinned cylinder's pin-to-pin length s and r = ds/dq (NAN at joints without one);",
           " * the joint force is (pA A_A - pB A_B) r.",
           f" *   void {prefix}_rod_friction(const double *q, const double *qd, double *out);  out: (N,)",
           " * a slipping cylinder's rod friction on its joint (0 at joints without).", " */",
           "#include <math.h>", "", f"#define {prefix.upper()}_N {n}", "",
           f"const double {prefix}_fv[{n}] = {{{', '.join(repr(j.friction.viscous) for j in spec.joints)}}};",
           f"static const double P[{len(values)}] = {{\n{params}\n}};", ""]
    for name, args in _PUBLIC:
        out += [c_function(kernels[name], prefix="k_", static=True), ""]
        full = list(args) + ["0"] * (3 - len(args))
        out += [f"void {prefix}_{name}({', '.join(f'const double *{a}' for a in args)}, double *out)",
                f"{{\n    k_{name}(P, {', '.join(full)}, out);\n}}", ""]
    return "\n".join(out + _c_cylinders(spec, prefix))



# --- the pinned cylinders' terms -----------------------------------------------------------------

CYLINDER_INTRO = ("Each pinned cylinder's pin-to-pin length s(q) and moment arm r(q) = ds/dq, in "
                  "closed form; its joint force is (p_A A_A - p_B A_B) r(q). A cylinder with rod "
                  "friction (newtons on the rod: Coulomb, static above it, Stribeck at the rod's "
                  "speed r q̇, viscous) puts the friction force τ_f on its joint while it slips "
                  "(the plant adds the joint's own friction and sticks it when it stops).")


@dataclasses.dataclass(frozen=True)
class CylinderTerms:
    """One pinned cylinder's closed form (see :mod:`maniplab.actuators.hydraulic.geometry`).

    Attributes:
        joint: its joint's index.  name: the joint's name.  prismatic: a sliding joint.
        constants: (K, ρ, φ) or (w², b, 0).  areas: (A_A, A_B), m².
        rod: its rod friction (Fc N, Fs N, vs m/s, Fv N·s/m), or None.
    """

    joint: int
    name: str
    prismatic: bool
    constants: tuple[float, float, float]
    areas: tuple[float, float]
    rod: tuple[float, float, float, float] | None = None

    def latex(self) -> list[str]:
        """s², r and the force as LaTeX equations."""
        q, (a, b, c) = f"q_{{{self.joint + 1}}}", self.constants
        s = f"s_{{{self.joint + 1}}}"
        if self.prismatic:
            square = f"{s}^2 = {a!r} + ({q} + {b!r})^2"
            arm = f"r_{{{self.joint + 1}}} = ({q} + {b!r}) / {s}"
        else:
            square = f"{s}^2 = {a!r} - 2 \\cdot {b!r} \\cos({q} - {c!r})"
            arm = f"r_{{{self.joint + 1}}} = {b!r} \\sin({q} - {c!r}) / {s}"
        force = (f"\\tau_{{{self.joint + 1}}} = (p_A \\cdot {self.areas[0]!r} - p_B \\cdot "
                 f"{self.areas[1]!r})\\, r_{{{self.joint + 1}}}")
        if self.rod is None:
            return [square, arm, force]
        fc, fs, vs, fv = self.rod
        r, qd = f"r_{{{self.joint + 1}}}", f"\\dot q_{{{self.joint + 1}}}"
        friction = (f"\\tau_{{f,{self.joint + 1}}} = -\\left({fc!r} + {fs!r}\\, "
                    f"e^{{-({r} {qd} / {vs!r})^2}}\\right) |{r}|\\, \\mathrm{{sign}}({qd}) - "
                    f"{fv!r}\\, {r}^2 {qd}")
        return [square, arm, force, friction]


def cylinder_terms(spec: ManipulatorSpec) -> list[CylinderTerms]:
    """The closed forms of the spec's pinned cylinders, in joint order."""
    out = []
    for j, joint in enumerate(spec.joints):
        actuator = model_of(joint)
        if isinstance(actuator, PinnedCylinder):
            c = actuator.params.cylinder
            f = c.friction
            rod = None if f is None else (f.coulomb, f.static, f.stribeck_velocity, f.viscous)
            out.append(CylinderTerms(j, joint.name, joint.prismatic, actuator.geometry.constants,
                                     (c.cap_area, c.rod_area), rod))
    return out


def _python_cylinders(spec: ManipulatorSpec) -> list[str]:
    rows = "\n".join(f"    ({c.joint}, {c.prismatic}, {c.constants!r}),  # {c.name}"
                     for c in cylinder_terms(spec))
    return [f"CYLINDERS = (  # joint, prismatic, (K, rho, phi) or (w^2, b, 0)\n{rows}\n)"
            if rows else "CYLINDERS = ()", "", "",
            "def cylinder_length(q):",
            '    """Each pinned cylinder\'s pin-to-pin length s(q), m, (N,) (NaN elsewhere)."""',
            "    out = np.full(N, np.nan)",
            "    for j, prismatic, (a, b, c) in CYLINDERS:",
            "        out[j] = sqrt(a + (q[j] + b) ** 2) if prismatic else sqrt(a - 2 * b * cos(q[j] - c))",
            "    return out", "", "",
            "def moment_arm(q):",
            '    """Each pinned cylinder\'s r(q) = ds/dq, (N,) (NaN elsewhere)."""',
            "    s, out = cylinder_length(q), np.full(N, np.nan)",
            "    for j, prismatic, (a, b, c) in CYLINDERS:",
            "        out[j] = (q[j] + b) / s[j] if prismatic else b * sin(q[j] - c) / s[j]",
            "    return out", "", "",
            "ROD_FRICTION = (  # joint, Fc N, Fs N, vs m/s, Fv N.s/m", *(
                f"    ({c.joint}, {c.rod[0]!r}, {c.rod[1]!r}, {c.rod[2]!r}, {c.rod[3]!r}),  # {c.name}"
                for c in cylinder_terms(spec) if c.rod is not None), ")", "", "",
            "def rod_friction(q, qd):",
            '    """Each pinned cylinder\'s rod friction on its joint while it slips, (N,) (0 elsewhere):',
            "    -(Fc + Fs exp(-(r qd / vs)^2)) |r| sign(qd) - Fv r^2 qd, r = moment_arm(q).\"\"\"",
            "    r, out = moment_arm(q), np.zeros(N)",
            "    for j, fc, fs, vs, fv in ROD_FRICTION:",
            "        v = r[j] * qd[j]",
            "        out[j] = (-(fc + fs * np.exp(-((v / vs) ** 2))) * abs(r[j]) * np.sign(qd[j])",
            "                  - fv * r[j] * v)",
            "    return out", ""]


def _c_cylinders(spec: ManipulatorSpec, prefix: str) -> list[str]:
    cylinders = cylinder_terms(spec)
    length, arm = [], []
    for c in cylinders:
        j, (a, b, k) = c.joint, c.constants
        s = (f"sqrt({a!r} + (q[{j}] + {b!r}) * (q[{j}] + {b!r}))" if c.prismatic
             else f"sqrt({a!r} - 2.0 * {b!r} * cos(q[{j}] - {k!r}))")
        length.append(f"    out[{j}] = {s};")
        arm.append(f"    out[{j}] = " + (f"(q[{j}] + {b!r}) / {s};" if c.prismatic
                                        else f"{b!r} * sin(q[{j}] - {k!r}) / {s};"))
    friction = []
    for c in cylinders:
        if c.rod is not None:
            j, (fc, fs, vs, fv) = c.joint, c.rod
            friction += [f"    v = r[{j}] * qd[{j}];",
                         (f"    out[{j}] = -({fc!r} + {fs!r} * exp(-(v / {vs!r}) * (v / {vs!r}))) * "
                          f"fabs(r[{j}]) * ((qd[{j}] > 0.0) - (qd[{j}] < 0.0)) - {fv!r} * r[{j}] * v;")]
    n = spec.n
    blank = f"    for (int i = 0; i < {n}; i++) out[i] = NAN;"
    return [f"void {prefix}_cylinder_length(const double *q, double *out)", "{", blank, *length,
            "}", "", f"void {prefix}_moment_arm(const double *q, double *out)", "{", blank, *arm,
            "}", "", f"void {prefix}_rod_friction(const double *q, const double *qd, double *out)",
            "{", f"    double r[{n}], v = 0.0;", f"    {prefix}_moment_arm(q, r);",
            f"    for (int i = 0; i < {n}; i++) out[i] = 0.0;", *friction, "    (void)v;", "}", ""]


__all__ = ["DEFAULT_SYMBOLIC", "FORMATS", "SUFFIXES", "c_file", "cylinder_terms", "export_model",
           "python_module", "readable"]
