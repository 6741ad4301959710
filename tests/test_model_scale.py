"""Large arms: the 12- and 20-joint models against MuJoCo, and the recording tape on its own.

The references are MuJoCo's (``mj_fullM``, ``qfrc_bias``, ``mj_inverse``, poses, ``mj_jac``),
finite differences of M for Ṁ, and the two identities that fix the Christoffel form of C
uniquely: Ṁ = C + Cᵀ and C(q, v) w = C(q, w) v.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_model import MjRef, assert_close, check_against_mujoco, random_states

import maniplab as ml
from maniplab.model import AnalyticModel
from maniplab.model.build import generate
from maniplab.model.tape import Tape, c_function, kernel, python_function
from maniplab.sample import sample_arm


@pytest.fixture(scope="module", params=[12, 20])
def large(request: pytest.FixtureRequest) -> tuple[AnalyticModel, MjRef]:
    spec = sample_arm(request.param, seed=request.param)
    return AnalyticModel(spec, backend="c"), MjRef(spec)


def test_large_arms_match_mujoco(large: tuple[AnalyticModel, MjRef]) -> None:
    am, ref = large
    check_against_mujoco(am, ref, random_states(am.n, 4, seed=am.n))


def test_large_arms_c_is_the_christoffel_form(large: tuple[AnalyticModel, MjRef]) -> None:
    am, _ = large
    rng = np.random.default_rng(3)
    q, v, w = rng.uniform(-2, 2, size=(3, am.n))
    C = am.C(q, v)
    assert_close(am.C(q, v) @ w, am.C(q, w) @ v, "C(v) w = C(w) v")
    h = 1e-6  # central difference of M along v: error O(h²) ~ 1e-12 relative
    Mdot = (am.M(q + h * v) - am.M(q - h * v)) / (2 * h)
    assert_close(C + C.T, Mdot, "C + Cᵀ = Ṁ", rel=1e-7)


def test_large_arm_python_backend_agrees_with_c() -> None:
    spec = sample_arm(12, seed=12)
    c, py = AnalyticModel(spec, backend="c"), AnalyticModel(spec, backend="python")
    q, qd, qdd = np.random.default_rng(5).uniform(-2, 2, size=(3, 12))
    for name, args in (("M", (q,)), ("C", (q, qd)), ("bias", (q, qd)),
                       ("inverse_dynamics", (q, qd, qdd)), ("jacobian", (q,))):
        assert_close(getattr(py, name)(*args), getattr(c, name)(*args), name, rel=1e-13)


def test_code_grows_about_linearly_with_the_arm() -> None:
    """The recorded inverse dynamics costs a bounded number of operations per joint, and M and C a
    bounded number per entry: the structure of the algorithms, not of expanded closed forms."""
    ops = {n: {k.name: k.ops for k in generate(sample_arm(n, seed=n)).kernels} for n in (8, 32)}
    for n in (8, 32):  # a general link costs about 130 to 160 operations in the RNEA
        assert ops[n]["inverse_dynamics"] <= 200 * n
        assert ops[n]["M"] <= 200 * n + 12 * n * n  # 11 per entry: one 6-vector dot product
    assert ops[32]["inverse_dynamics"] / ops[8]["inverse_dynamics"] < 4.0 * 1.25
    assert ops[32]["C"] / ops[8]["C"] < 16.0


# --- the tape ------------------------------------------------------------------------------------

def test_the_tape_folds_constants_and_numbers_values() -> None:
    tape = Tape()
    x, y = tape.input("q", 0), tape.input("q", 1)
    assert 0.0 * x == 0.0 and x + 0.0 is x and 1.0 * x is x and x - x == 0.0
    assert x * y is y * x  # one statement for a product, whichever order
    assert tape.call("sin", x) is tape.call("sin", x)
    assert (-x) * y is -(x * y) and x - (-y) is x + y
    # x*y, sin x, -x, -(x*y), -y, x+y: nothing else was recorded
    assert [s.op for s in tape.stmts if s.op != "in"] == ["*", "sin", "neg", "neg", "neg", "+"]


def test_printed_c_and_python_compute_what_the_recording_did() -> None:
    """A recorded function printed as Python gives the value of the same formula in numpy."""
    tape = Tape()
    q = tape.inputs("q", 2)
    p = tape.inputs("p", 1)
    value = tape.call("cos", q[0]) * p[0] - q[1] / (p[0] + 2.0) + (-q[0]) * q[1]
    k = kernel(tape, "f", 1, (2,), "a test", [value, 3.5])
    namespace: dict = {"sin": math.sin, "cos": math.cos, "sqrt": math.sqrt}
    exec(python_function(k), namespace)  # noqa: S102 (source printed by the code under test)
    got = namespace["f"]([0.7], [0.3, -1.2], None, None)
    assert got == pytest.approx((math.cos(0.3) * 0.7 + 1.2 / 2.7 + 0.3 * 1.2, 3.5), rel=1e-15)
    source = c_function(k)
    assert "void ml_f(" in source and "cos(q0)" in source and "out[1] = 3.5;" in source


def test_a_massless_arm_has_no_dynamics_terms_but_keeps_its_kinematics() -> None:
    spec = ml.ManipulatorSpec.from_dict({
        "name": "bare", "gravity": [0, 0, -9.81],
        "joints": [{"type": "R", "axis": "z", "body": {"length": 1.0, "mass": 0.0}},
                   {"type": "R", "axis": "y", "body": {"length": 0.5, "mass": 0.0}}]})
    am = AnalyticModel(spec, backend="python")
    q = np.array([0.3, -0.4])
    np.testing.assert_array_equal(am.M(q), np.zeros((2, 2)))
    np.testing.assert_array_equal(am.G(q), np.zeros(2))
    x = math.cos(0.3) * (1.0 + 0.5 * math.cos(-0.4))  # planar reach of the two links
    assert am.fk(q)[0, 3] == pytest.approx(x, rel=1e-14)
