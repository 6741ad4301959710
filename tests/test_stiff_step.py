"""The exponential Rosenbrock-Euler step of maniplab_native/stiff.c against independent references:
scipy's matrix exponential, closed-form solutions of linear equations, its second order on a
nonlinear one (Radau), and the chambers' analytic Jacobian against finite differences."""

from __future__ import annotations

import ctypes
from ctypes import c_double, c_int, c_void_p

import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp

import maniplab as ml
from maniplab.actuators.hydraulic.chambers import ChambersLaw, chambers_law
from maniplab.clib import Functions

C = Functions({
    "ml_expm": (c_int, [c_int, c_void_p, c_void_p]),
    "ml_exponential_step": (c_int, [c_int, c_double, c_void_p, c_void_p, c_void_p, c_void_p]),
    "ml_chambers_jacobian": (None, [ctypes.POINTER(ChambersLaw), c_double, c_double, c_double,
                                    c_double, c_double, c_void_p]),
    "ml_chambers_rates": (None, [ctypes.POINTER(ChambersLaw), c_double, c_double, c_double,
                                 c_double, c_double, c_double, c_void_p]),
})


def expm(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=float)
    out = np.empty_like(a)
    assert C().ml_expm(len(a), a.ctypes.data, out.ctypes.data) == 0
    return out


def step(h: float, J: np.ndarray, f0: np.ndarray, df: np.ndarray | None = None) -> np.ndarray:
    J, f0 = np.ascontiguousarray(J, dtype=float), np.ascontiguousarray(f0, dtype=float)
    dfa = None if df is None else np.ascontiguousarray(df, dtype=float)
    out = np.empty(len(f0))
    status = C().ml_exponential_step(len(f0), h, J.ctypes.data, f0.ctypes.data,
                                     None if dfa is None else dfa.ctypes.data, out.ctypes.data)
    assert status == 0
    return out


@pytest.mark.parametrize("norm", [1e-3, 0.4, 3.0, 1e2, 1e5])
def test_the_matrix_exponential_is_scipys(norm: float) -> None:
    rng = np.random.default_rng(3)
    for n in (1, 3, 5, 8):
        a = rng.normal(size=(n, n))
        a *= norm / np.abs(a).sum(axis=0).max()
        a -= norm * np.eye(n)  # a decaying system, as the chambers are (exp of +1e5 overflows)
        ref = scipy.linalg.expm(a)
        np.testing.assert_allclose(expm(a), ref, rtol=1e-11, atol=1e-13 * max(1.0, np.abs(ref).max()))


def test_a_non_finite_matrix_is_refused_with_nan() -> None:
    out = np.empty((2, 2))
    a = np.array([[np.nan, 0.0], [0.0, 1.0]])
    assert C().ml_expm(2, a.ctypes.data, out.ctypes.data) == -1 and np.isnan(out).all()


def test_a_linear_equation_with_a_ramp_is_solved_exactly_at_any_step() -> None:
    """y' = A y + b + c t from y0 over h, for a stiff A (eigenvalues -1 and -1e6): the same as
    scipy's exponential of the augmented matrix (Al-Mohy and Higham's theorem) and as Radau at
    tight tolerances, at steps up to 1e4 times the fast mode's time constant."""
    A = np.array([[-1.0e6, 2.0e3], [0.0, -1.0]])
    b, c = np.array([3.0e5, 2.0]), np.array([1.0e5, -4.0])
    y0 = np.array([0.2, 1.0])
    for h in (1e-4, 1e-3, 1e-2):
        f0 = A @ y0 + b
        df = c * h  # f(t1, y0) - f(t0, y0)
        # the augmented matrix's exponential is exact for this linear, linearly forced system
        M = np.zeros((4, 4))
        M[:2, :2], M[:2, 2], M[:2, 3], M[2, 3] = h * A, h * df, h * f0, 1.0
        exact = scipy.linalg.expm(M)[:2, 3]
        ref = solve_ivp(lambda t, y: A @ y + b + c * t, (0.0, h), y0, method="Radau",
                        rtol=1e-12, atol=1e-14).y[:, -1] - y0
        np.testing.assert_allclose(step(h, A, f0, df), exact, rtol=1e-10)
        np.testing.assert_allclose(step(h, A, f0, df), ref, rtol=1e-7, atol=1e-12)


def test_the_step_is_second_order_on_a_nonlinear_equation() -> None:
    """y' = -k (y^2 - 1) - y^3/10 + sin(t): halving h divides the error at t = 1 by about 4."""
    def f(t, y):
        return np.array([-50.0 * (y[0] ** 2 - 1.0) - 0.1 * y[0] ** 3 + np.sin(t)])

    def jac(y):
        return np.array([[-100.0 * y[0] - 0.3 * y[0] ** 2]])

    ref = solve_ivp(f, (0.0, 1.0), [3.0], method="Radau", rtol=1e-12, atol=1e-14).y[0, -1]
    errors = []
    for n in (40, 80, 160):
        h, y, t = 1.0 / n, np.array([3.0]), 0.0
        for _ in range(n):
            y = y + step(h, jac(y), f(t, y), f(t + h, y) - f(t, y))
            t += h
        errors.append(abs(y[0] - ref))
    assert 3.5 < errors[0] / errors[1] < 4.5 and 3.5 < errors[1] / errors[2] < 4.5, errors


def rates(law: ChambersLaw, y: np.ndarray, u: float, s: float) -> np.ndarray:
    out = np.empty(3)
    C().ml_chambers_rates(ctypes.byref(law), y[0], y[1], y[2], u, s, 0.01, out.ctypes.data)
    return out


@pytest.mark.parametrize("x", [0.6, -0.4, 0.0])
def test_the_chambers_jacobian_is_the_rates_derivative(x: float) -> None:
    """Against central differences of ml_chambers_rates, at pressures within an edge's laminar
    transition and far from it (at x = 0, where the edges switch, the x column is one-sided and
    left out)."""
    law = chambers_law(ml.builtin_spec("patu655").joints[1].actuator)
    s, u = law.min_length + 0.4 * law.stroke, 0.3
    for pa, pb in ((3.1e6, 8.0e5), (law.tank + 50.0, law.supply - 20.0)):
        J = np.empty(9)
        C().ml_chambers_jacobian(ctypes.byref(law), pa, pb, x, u, s, J.ctypes.data)
        numeric = np.zeros((3, 3))
        for k, h in enumerate((1.0, 1.0, 1e-7)):
            dy = np.zeros(3)
            dy[k] = h
            y = np.array([pa, pb, x])
            numeric[:, k] = (rates(law, y + dy, u, s) - rates(law, y - dy, u, s)) / (2.0 * h)
        columns = 2 if x == 0.0 else 3
        scale = float(np.abs(numeric).max())
        np.testing.assert_allclose(J.reshape(3, 3)[:, :columns], numeric[:, :columns],
                                   rtol=1e-5, atol=1e-9 * scale)
