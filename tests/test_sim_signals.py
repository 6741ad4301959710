"""Input signals: values, arithmetic, readable reprs."""

from __future__ import annotations

import math

import numpy as np
import pytest

import maniplab as ml

s = ml.signals


def test_values() -> None:
    assert s.step(2.0, t0=0.5)(0.4999) == 0.0 and s.step(2.0, t0=0.5)(0.5) == 2.0
    assert s.step(1.0, t0=0.1)(0.1 - 1e-12) == 1.0  # sample times off by rounding still switch
    assert s.constant(3.5)(123.0) == 3.5
    assert s.ramp(2.0, t0=1.0)(3.0) == 4.0 and s.ramp(2.0, t0=1.0)(0.5) == 0.0
    assert s.ramp(2.0, t0=1.0, t1=2.0)(5.0) == 2.0
    assert s.sine(2.0, frequency=0.25)(1.0) == pytest.approx(2.0)
    assert s.sine(1.0, 1.0, phase=math.pi / 2, t0=1.0)(1.0) == pytest.approx(1.0)
    assert s.sine(1.0, 1.0, t0=1.0)(0.5) == 0.0


def test_impulse_has_its_area() -> None:
    pulse = s.impulse(0.3, t0=0.2, width=0.01)
    t = np.arange(0.0, 1.0, 1e-3)
    assert pulse.sample(t).sum() * 1e-3 == pytest.approx(0.3)
    with pytest.raises(ValueError):
        s.impulse(1.0, width=0.0)


def test_arithmetic_and_repr() -> None:
    u = s.step(0.5, t0=0.1) + s.sine(0.1, frequency=2.0) - s.constant(0.2)
    assert repr(u) == "step(0.5, t0=0.1) + sine(0.1, frequency=2.0) - constant(0.2)"
    assert u(0.25) == pytest.approx(0.5 + 0.1 * math.sin(2 * math.pi * 2.0 * 0.25) - 0.2)
    assert repr(2 * s.step(1.0)) == "2.0 * step(1.0, t0=0.0)"
    assert (1.0 + s.ramp(1.0))(2.0) == 3.0 and (1.0 - s.ramp(1.0))(2.0) == -1.0
    assert s.as_signal(4)(0.0) == 4.0
    assert repr(s.as_signal(math.cos)) == "cos" and s.as_signal(math.cos)(0.0) == 1.0
    with pytest.raises(TypeError):
        s.as_signal("fast")
    assert s.step(1.0) == s.step(1.0) and hash(s.step(1.0)) == hash(s.step(1.0))  # frozen values
