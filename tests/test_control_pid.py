"""The PID block against hand-computed discrete sequences (filter, integral, anti-windup, limits)."""

from __future__ import annotations

import numpy as np
import pytest

from maniplab.control.errors import ControlError
from maniplab.control.pid import PID


def run(pid: PID, errors: list[float], rates: list[float] | None = None) -> list[float]:
    out = []
    for k, e in enumerate(errors):
        rate = None if rates is None else np.array([rates[k]])
        out.append(float(pid.update(np.array([e]), rate)[0]))
    return out


def test_proportional_only_is_kp_times_error() -> None:
    pid = PID(2.5, dt=0.01)
    assert run(pid, [0.0, 1.0, -0.4]) == pytest.approx([0.0, 2.5, -1.0])


def test_filtered_derivative_sequence() -> None:
    # Kd s/(1 + Tf s), backward Euler, h = Tf = 0.1: a = Tf/(Tf+h) = 0.5, Kd/(Tf+h) = 5
    # e = 0, 1, 1, 1, 0 -> D = 0, 5, 2.5, 1.25, 0.625 - 5 = -4.375
    pid = PID(0.0, 0.0, 1.0, dt=0.1, filter_time=0.1)
    assert run(pid, [0.0, 1.0, 1.0, 1.0, 0.0]) == pytest.approx([0.0, 5.0, 2.5, 1.25, -4.375])


def test_unfiltered_derivative_is_the_difference_quotient_without_first_kick() -> None:
    pid = PID(0.0, 0.0, 0.5, dt=0.1)
    # first sample has no kick; then Kd (e_k - e_{k-1}) / h
    assert run(pid, [3.0, 3.2, 3.1]) == pytest.approx([0.0, 1.0, -0.5])


def test_measured_rate_is_low_pass_filtered_from_its_first_value() -> None:
    pid = PID(0.0, 0.0, 2.0, dt=0.1, filter_time=0.3)
    # d_0 = r_0 = 1; d_k = 0.75 d_{k-1} + 0.25 r_k with r = 1, 0, 0 -> 1, 0.75, 0.5625
    assert run(pid, [0.0, 0.0, 0.0], rates=[1.0, 0.0, 0.0]) == pytest.approx([2.0, 1.5, 1.125])


def test_integral_is_forward_euler_of_ki_e() -> None:
    pid = PID(1.0, 2.0, dt=0.1)
    # I_0 = 0, I_{k+1} = I_k + h Ki e_k: u = e + I = 1, 1.2, 1.4, 1.6
    assert run(pid, [1.0] * 4) == pytest.approx([1.0, 1.2, 1.4, 1.6])


def test_output_limits_clip_and_flag() -> None:
    pid = PID(10.0, dt=0.1, limits=(-1.0, 2.0))
    assert run(pid, [0.05, 0.5, -0.5]) == pytest.approx([0.5, 2.0, -1.0])
    assert pid.saturated.tolist() == [True]
    assert pid.unclipped[0] == pytest.approx(-5.0)


def test_back_calculation_anti_windup_sequence() -> None:
    # Kp = 0, Ki = 10, h = 0.1, Tt = 0.1, limits ±1, e = 1:
    # k0: v = 0, u = 0, I1 = 0 + 0.1 (10 + 0) = 1
    # k1: v = 1, u = 1, I2 = 1 + 0.1 (10 + 0) = 2
    # k2: v = 2, u = 1, I3 = 2 + 0.1 (10 + (1 - 2)/0.1) = 2   (held: the windup stops)
    # then e = -1: k3: v = 2, u = 1, I4 = 2 + 0.1 (-10 - 10) = 0;  k4: v = 0, u = 0, I5 = -1
    pid = PID(0.0, 10.0, dt=0.1, limits=(-1.0, 1.0), tracking_time=0.1)
    assert run(pid, [1.0, 1.0, 1.0, -1.0, -1.0]) == pytest.approx([0.0, 1.0, 1.0, 1.0, 0.0])
    assert pid.integral[0] == pytest.approx(-1.0)


def test_without_anti_windup_the_integrator_winds_up() -> None:
    wound = PID(0.0, 10.0, dt=0.1, limits=(-1.0, 1.0), tracking_time=1e9)
    guarded = PID(0.0, 10.0, dt=0.1, limits=(-1.0, 1.0))
    for pid in (wound, guarded):
        run(pid, [1.0] * 50)
    assert wound.integral[0] == pytest.approx(50.0, rel=1e-6)
    assert guarded.integral[0] < 3.0
    # after the error reverses, the guarded PID leaves saturation within a few samples
    back_g = run(guarded, [-1.0] * 5)
    back_w = run(wound, [-1.0] * 5)
    assert back_g[-1] < 1.0 and back_w[-1] == 1.0


def test_default_tracking_time_rule() -> None:
    assert PID(2.0, 4.0, 0.0, dt=0.01).tracking_time[0] == pytest.approx(0.5)  # Ti = Kp/Ki
    assert PID(2.0, 4.0, 1.0, dt=0.01).tracking_time[0] == pytest.approx(0.5)  # sqrt(Kd/Ki)
    assert PID(2.0, 1e6, 0.0, dt=0.01).tracking_time[0] == pytest.approx(0.01)  # never below h


def test_zero_ki_has_no_integrator_even_when_saturated() -> None:
    pid = PID(10.0, 0.0, dt=0.1, limits=(-1.0, 1.0))
    run(pid, [1.0] * 10)
    assert pid.integral[0] == 0.0


def test_freeze_holds_the_integrator() -> None:
    pid = PID(0.0, 1.0, dt=0.5, size=2)
    pid.update(np.array([1.0, 1.0]), freeze=np.array([True, False]))
    assert pid.integral.tolist() == [0.0, 0.5]
    pid.update(np.array([1.0, 1.0]), freeze=True)
    assert pid.integral.tolist() == [0.0, 0.5]


def test_vector_gains_broadcast_and_reset() -> None:
    pid = PID([1.0, 2.0, 3.0], 1.0, dt=0.1)
    assert pid.size == 3
    np.testing.assert_allclose(pid.update(np.ones(3)), [1.0, 2.0, 3.0])
    pid.reset()
    assert not pid.integral.any()


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"dt": 0.0}, "dt must be > 0, got 0.0"),
    ({"dt": 0.1, "filter_time": -1.0}, "filter_time must be >= 0, got -1.0"),
    ({"dt": 0.1, "limits": (1.0, -1.0)}, r"limits \(1.0, -1.0\) are not ordered"),
    ({"dt": 0.1, "tracking_time": 0.0}, "tracking_time must be > 0, got 0.0")])
def test_bad_arguments(kwargs: dict, message: str) -> None:
    with pytest.raises(ControlError, match=message):
        PID(1.0, 1.0, **kwargs)


def test_feedforward_is_added_before_the_limits_and_the_anti_windup_sees_it() -> None:
    # kp = 1, ki = 1 (Tt = kp/ki = 1 s), h = 0.1, limits ±1, feed-forward 0.8:
    # k0: e = 0.5 -> v = 0.5 + 0 + 0.8 = 1.3, u = 1, I = 0.1 (0.5 + (1 - 1.3)/1) = 0.02
    # k1: e = 0.1 -> v = 0.1 + 0.02 + 0.8 = 0.92, u = 0.92, I = 0.02 + 0.1 (0.1) = 0.03
    pid = PID(1.0, 1.0, dt=0.1, limits=(-1.0, 1.0))
    out = [float(pid.update(np.array([e]), feedforward=0.8)[0]) for e in (0.5, 0.1)]
    assert out == pytest.approx([1.0, 0.92])
    assert pid.integral[0] == pytest.approx(0.03)
