"""Exports of the analytic model and the symbolic model, checked against MuJoCo and closed forms.

The exported Python module is imported from a temporary folder, the exported C file is compiled
with the system's C compiler and called through ctypes; both must reproduce MuJoCo's M and bias.
"""

from __future__ import annotations

import ctypes
import importlib.util
import math
import shutil
import subprocess
from pathlib import Path

import mujoco
import numpy as np
import pytest
import sympy
from test_model import MjRef, _model_cache, assert_close, random_states  # noqa: F401 (fixture)

import maniplab as ml
from maniplab.cli import main
from maniplab.model import SymbolicModel
from maniplab.model.export import readable

CC = shutil.which("cc") or shutil.which("gcc")


@pytest.mark.parametrize("name", ["erector", "crane3"])
def test_exported_python_module_matches_mujoco(name: str, tmp_path: Path) -> None:
    spec = ml.builtin_spec(name)
    path = tmp_path / f"{name}_model.py"
    assert main(["model", name, "-o", str(path)]) == 0
    mod_spec = importlib.util.spec_from_file_location(f"{name}_model", path)
    module = importlib.util.module_from_spec(mod_spec)
    mod_spec.loader.exec_module(module)
    assert "maniplab" not in path.read_text().split('"""', 2)[2]  # self-contained
    ref = MjRef(spec)
    for q, qd, qdd in random_states(spec.n, 4, seed=11):
        assert_close(module.M(q), ref.M(q), "M")
        assert_close(module.bias(q, qd), ref.bias(q, qd), "bias")
        assert_close(module.C(q, qd) @ qd + module.G(q), ref.bias(q, qd), "C qd + G")
        assert_close(module.inverse_dynamics(q, qd, qdd), ref.inverse(q, qd, qdd), "tau")
        assert_close(module.fk(q), ref.pose(q), "fk")
        assert_close(module.jacobian(q), ref.jacobian(q), "jacobian")


@pytest.mark.skipif(CC is None, reason="no C compiler")
@pytest.mark.parametrize("name", ["erector", "planar2"])
def test_exported_c_file_matches_mujoco(name: str, tmp_path: Path) -> None:
    spec = ml.builtin_spec(name)
    source, lib = tmp_path / f"{name}.c", tmp_path / f"lib{name}.so"
    assert main(["model", name, "--format", "c", "-o", str(source)]) == 0
    subprocess.run([CC, "-O1", "-shared", "-fPIC", "-Wall", "-Werror", "-Wno-unused-variable",
                    str(source), "-o", str(lib), "-lm"], check=True)
    so = ctypes.CDLL(str(lib))
    dp = ctypes.POINTER(ctypes.c_double)
    n = spec.n

    def call(fn: str, shape: tuple[int, ...], *args: np.ndarray) -> np.ndarray:
        out = np.zeros(shape)
        ins = [np.ascontiguousarray(a, dtype=float) for a in args]
        getattr(so, f"{name}_{fn}")(*[a.ctypes.data_as(dp) for a in ins], out.ctypes.data_as(dp))
        return out

    ref = MjRef(spec)
    for q, qd, qdd in random_states(n, 4, seed=12):
        assert_close(call("M", (n, n), q), ref.M(q), "M")
        assert_close(call("bias", (n,), q, qd), ref.bias(q, qd), "bias")
        assert_close(call("inverse_dynamics", (n,), q, qd, qdd), ref.inverse(q, qd, qdd), "tau")
        assert_close(call("fk", (4, 4), q), ref.pose(q), "fk")
        assert_close(call("jacobian", (6, n), q), ref.jacobian(q), "jacobian")
    fv = (ctypes.c_double * n).in_dll(so, f"{name}_fv")
    np.testing.assert_array_equal(list(fv), [j.friction.viscous for j in spec.joints])


def _spong(m1, l1, m2, l2, g, q, qd):
    """Two-link arm of uniform rods (Spong): M, C, G in closed form; gravity along -y."""
    c2, s2 = math.cos(q[1]), math.sin(q[1])
    M = np.array([[m1 * l1**2 / 3 + m2 * (l1**2 + l2**2 / 3 + l1 * l2 * c2),
                   m2 * (l2**2 / 3 + l1 * l2 * c2 / 2)],
                  [m2 * (l2**2 / 3 + l1 * l2 * c2 / 2), m2 * l2**2 / 3]])
    h = -m2 * l1 * l2 * s2 / 2
    C = np.array([[h * qd[1], h * (qd[0] + qd[1])], [-h * qd[0], 0.0]])
    G = g * np.array([(m1 / 2 + m2) * l1 * math.cos(q[0]) + m2 * l2 / 2 * math.cos(q[0] + q[1]),
                      m2 * l2 / 2 * math.cos(q[0] + q[1])])
    return M, C, G


def test_planar2_readable_form_is_the_textbook_model() -> None:
    """The LaTeX/Markdown entries for planar2 keep m, l symbolic and equal Spong's closed form."""
    spec = ml.builtin_spec("planar2")
    doc = readable(spec, ("mass", "length", "payload"))
    assert doc.simplified and not doc.temps
    m1, l1, m2, l2 = sympy.symbols("m1 l1 m2 l2")
    free = set().union(*(e.free_symbols for rows in doc.entries.values() for _, e in rows))
    assert {m1, l1, m2, l2} <= free
    values = {m1: 3.0, l1: 0.7, m2: 2.0, l2: 1.3}
    q, qd = np.array([0.4, -1.1]), np.array([0.9, 0.3])
    sub = {**values, sympy.Symbol("q1"): q[0], sympy.Symbol("q2"): q[1],
           sympy.Symbol("qd1"): qd[0], sympy.Symbol("qd2"): qd[1]}
    M, C, G = _spong(3.0, 0.7, 2.0, 1.3, 9.81, q, qd)
    got = {label: float(e.subs(sub)) for rows in doc.entries.values() for label, e in rows}
    np.testing.assert_allclose([got["M_{11}"], got["M_{12}"], got["M_{22}"]],
                               [M[0, 0], M[0, 1], M[1, 1]], rtol=1e-12)
    np.testing.assert_allclose([got[f"C_{{{i}{j}}}"] for i in (1, 2) for j in (1, 2)], C.ravel(),
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose([got["G_{1}"], got["G_{2}"]], G, rtol=1e-12)


def test_latex_and_markdown_files(tmp_path: Path) -> None:
    tex, md = tmp_path / "planar2.tex", tmp_path / "erector.md"
    assert main(["model", "planar2", "-o", str(tex)]) == 0
    text = tex.read_text()
    assert text.startswith(r"\documentclass") and text.rstrip().endswith(r"\end{document}")
    assert r"l_{1} l_{2} m_{2}" in text and "M_{11}" in text and r"\dot{q}_{2}" in text
    assert main(["model", "erector", "-o", str(md), "--symbolic", "payload"]) == 0
    text = md.read_text()
    assert "Common subexpressions" in text and "x_{0}" in text and "m_{e}" in text
    assert text.count("$$ M_{") == 21 and text.count("$$ C_{") == 36


def test_model_command_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["model", "planar2", "-o", str(tmp_path / "x.txt")]) == 2
    assert "format" in capsys.readouterr().err
    assert main(["model", "planar2", "-o", str(tmp_path / "x.md"), "--symbolic", "mass,mas"]) == 2
    err = capsys.readouterr().err
    assert "'mas'" in err and len(err.strip().splitlines()) == 1
    assert main(["model", "nosuch", "-o", str(tmp_path / "x.md")]) == 2


# --- SymbolicModel -------------------------------------------------------------------------------

def _numeric(sm: SymbolicModel, expr, q, qd=None):
    sub = {**{s: v for s, v in sm.parameters.items()}, **dict(zip(sm.q, q))}
    if qd is not None:
        sub.update(dict(zip(sm.qd, qd)))
    return np.array(expr.xreplace(sub).evalf(), dtype=float)


def test_symbolic_model_with_every_group_matches_mujoco() -> None:
    """All parameters symbolic (default COG and slender-rod inertia written in l and m)."""
    spec = ml.builtin_spec("crane3")
    sm = SymbolicModel(spec, symbolic=("mass", "length", "payload", "offset", "gravity"))
    names = {str(s) for s in sm.parameters}
    assert {"m1", "m2", "m3", "l1", "l2", "l3", "me", "ez", "gz"} <= names
    assert "l2" in str(sm.M[1, 1])  # the luff's rod inertia m l²/12 is written in l2
    ref = MjRef(spec)
    for q, qd, _ in random_states(spec.n, 2, seed=13):
        assert_close(_numeric(sm, sm.M, q), ref.M(q), "M")
        assert_close(_numeric(sm, sm.bias, q, qd).ravel(), ref.bias(q, qd), "bias")
        assert_close(_numeric(sm, sm.H_ee, q), ref.pose(q), "H_ee")


def test_symbolic_frames_and_jacobians_match_mujoco_bodies() -> None:
    spec = ml.builtin_spec("erector")
    sm = SymbolicModel(spec, symbolic=("com", "inertia"))
    ref = MjRef(spec)
    q = random_states(spec.n, 1, seed=14)[0][0]
    ref.set(q)
    for j, joint in enumerate(spec.joints):
        body = mujoco.mj_name2id(ref.m, mujoco.mjtObj.mjOBJ_BODY, f"link_{joint.name}")
        H = _numeric(sm, sm.H_joint[j], q)
        assert_close(H[:3, 3], ref.d.xpos[body], "frame position")
        assert_close(H[:3, :3], ref.d.xmat[body].reshape(3, 3), "frame rotation")
        assert_close(_numeric(sm, sm.H_cog[j], q)[:3, 3], ref.d.xipos[body], "COG")
        jacp, jacr = np.zeros((3, spec.n)), np.zeros((3, spec.n))
        mujoco.mj_jac(ref.m, ref.d, jacp, jacr, ref.d.xipos[body], body)
        assert_close(_numeric(sm, sm.J_cog[j], q), np.vstack([jacp, jacr]), "J_cog")


def test_symbolic_constrained_terms_match_analytic_model() -> None:
    spec = ml.builtin_spec("crane3")
    sm, am = SymbolicModel(spec), ml.AnalyticModel(spec)
    terms = sm.constrained(["luff"])
    q, qd, tau = np.array([0.3, -0.5, 0.8]), np.array([0.2, 0.7, -0.4]), np.array([10., 20., 30.])
    qdd_f = np.linalg.solve(_numeric(sm, terms["M_FF"], q),
                            tau[terms["free"]] - _numeric(sm, terms["b_F"], q, qd).ravel())
    hold = _numeric(sm, terms["M_SF"], q) @ qdd_f + _numeric(sm, terms["b_S"], q, qd).ravel() - tau[1]
    qdd, hold_am = am.constrained_dynamics(q, qd, tau, ["luff"])
    np.testing.assert_allclose(qdd[terms["free"]], qdd_f, rtol=1e-10)
    np.testing.assert_allclose(hold_am[1], hold[0], rtol=1e-10)


def _tendon_terms(spec: ml.ManipulatorSpec, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each cylinder's length and moment arm as MuJoCo computes them (NaN without one)."""
    model = ml.build_model(spec)
    data = mujoco.MjData(model)
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    moment = np.zeros((model.nu, model.nv))
    mujoco.mju_sparse2dense(moment, data.actuator_moment, data.moment_rownnz, data.moment_rowadr,
                            data.moment_colind)
    length, arm = np.full(spec.n, np.nan), np.full(spec.n, np.nan)
    for j in range(spec.n):
        if model.actuator_trntype[j] == mujoco.mjtTrn.mjTRN_TENDON:
            length[j], arm[j] = data.actuator_length[j], moment[j, j]
    return length, arm


def test_exported_cylinder_terms_match_mujocos_tendons(tmp_path: Path) -> None:
    """The Python and C exports' cylinder_length and moment_arm equal MuJoCo's tendon length and
    actuator moment at random poses (1e-12), NaN at joints without a pinned cylinder; the
    Markdown lists the closed forms."""
    assert CC is not None, "maniplab's native plugins need a C compiler; so does this test"
    spec = ml.builtin_spec("excavator")
    py, source, lib = tmp_path / "exc.py", tmp_path / "exc.c", tmp_path / "libexc.so"
    assert main(["model", "excavator", "-o", str(py)]) == 0
    assert main(["model", "excavator", "--format", "c", "-o", str(source)]) == 0
    subprocess.run([CC, "-O1", "-shared", "-fPIC", "-Wall", "-Werror", "-Wno-unused-variable",
                    str(source), "-o", str(lib), "-lm"], check=True)
    mod_spec = importlib.util.spec_from_file_location("exc", py)
    module = importlib.util.module_from_spec(mod_spec)
    mod_spec.loader.exec_module(module)
    so = ctypes.CDLL(str(lib))
    dp = ctypes.POINTER(ctypes.c_double)
    rng = np.random.default_rng(4)
    for _ in range(5):
        q = np.array([rng.uniform(*j.limits) for j in spec.joints])
        length, arm = _tendon_terms(spec, q)
        np.testing.assert_allclose(module.cylinder_length(q), length, rtol=1e-12)
        np.testing.assert_allclose(module.moment_arm(q), arm, rtol=1e-12)
        for fn, want in (("cylinder_length", length), ("moment_arm", arm)):
            out = np.zeros(spec.n)
            getattr(so, f"excavator_{fn}")(np.ascontiguousarray(q).ctypes.data_as(dp),
                                           out.ctypes.data_as(dp))
            np.testing.assert_allclose(out, want, rtol=1e-12)
    markdown = tmp_path / "exc.md"
    assert main(["model", "excavator", "--format", "markdown", "-o", str(markdown)]) == 0
    assert markdown.read_text().count("\\tau_{") == 3
