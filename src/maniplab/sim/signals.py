"""Input signals of time: small frozen callables that add up and print readably.

Use them as ``inputs`` of :func:`maniplab.simulate` (valve current of a hydraulic joint, force or
torque of a torque joint)::

    import maniplab as ml
    u = ml.signals.step(0.5, t0=0.1) + ml.signals.sine(0.1, frequency=2.0)
    u(0.2)           # value at t = 0.2 s
    repr(u)          # 'step(0.5, t0=0.1) + sine(0.1, frequency=2.0)'  (stored in a run's meta)

Signals support ``+``, ``-``, unary ``-`` and multiplication by a number. Events (a step's ``t0``)
count as reached within 1e-9 s, so a step at 0.1 s switches at the sample t = 0.1 even when the
sample time is 0.09999999999999999.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from maniplab.sim.errors import InputError, SimulationError

EPS = 1e-9
"""Time tolerance of events, s."""

Number = int | float


class SignalTypeError(SimulationError, TypeError):
    """A value given as a signal is none of a signal, a number or a callable of time.

    It is also a TypeError, which :func:`as_signal` raised before.
    """


class Signal:
    """Base of the signals: a scalar function of time t (s) with arithmetic and a readable repr."""

    def __call__(self, t: float) -> float:  # pragma: no cover - abstract
        raise NotImplementedError

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Values at the times ``t``, same shape (the built-in signals evaluate them as arrays,
        to round-off the values of their calls)."""
        t = np.asarray(t, dtype=float)
        return np.array([self(float(x)) for x in t.reshape(-1)]).reshape(t.shape)

    def __add__(self, other: Signal | Number) -> Signal:
        return Sum((*_terms(self), *_terms(as_signal(other))))

    def __radd__(self, other: Signal | Number) -> Signal:
        return Sum((*_terms(as_signal(other)), *_terms(self)))

    def __neg__(self) -> Signal:
        return Scaled(-1.0, self)

    def __sub__(self, other: Signal | Number) -> Signal:
        return self + (-as_signal(other))

    def __rsub__(self, other: Signal | Number) -> Signal:
        return as_signal(other) + (-self)

    def __mul__(self, gain: Number) -> Signal:
        if not isinstance(gain, (int, float)) or isinstance(gain, bool):
            return NotImplemented
        return Scaled(float(gain), self)

    __rmul__ = __mul__


def _terms(signal: Signal) -> tuple[Signal, ...]:
    return signal.terms if isinstance(signal, Sum) else (signal,)


def _fmt(x: float) -> str:
    return repr(float(x))


@dataclasses.dataclass(frozen=True, repr=False)
class Constant(Signal):
    """``value`` at all times."""

    value: float

    def __call__(self, t: float) -> float:
        return self.value

    def sample(self, t: np.ndarray) -> np.ndarray:
        return np.full(np.shape(t), self.value)

    def __repr__(self) -> str:
        return f"constant({_fmt(self.value)})"


@dataclasses.dataclass(frozen=True, repr=False)
class Step(Signal):
    """0 before ``t0`` (s), ``amplitude`` from then on."""

    amplitude: float
    t0: float = 0.0

    def __call__(self, t: float) -> float:
        return self.amplitude if t >= self.t0 - EPS else 0.0

    def sample(self, t: np.ndarray) -> np.ndarray:
        return np.where(np.asarray(t, dtype=float) >= self.t0 - EPS, self.amplitude, 0.0)

    def __repr__(self) -> str:
        return f"step({_fmt(self.amplitude)}, t0={_fmt(self.t0)})"


@dataclasses.dataclass(frozen=True, repr=False)
class Impulse(Signal):
    """A rectangular pulse of the given ``area`` (value × s) over [t0, t0 + width)."""

    area: float
    t0: float = 0.0
    width: float = 1e-3

    def __post_init__(self) -> None:
        if not self.width > 0.0:
            raise InputError(f"impulse width must be > 0 s, got {self.width!r}")

    def __call__(self, t: float) -> float:
        inside = self.t0 - EPS <= t < self.t0 + self.width - EPS
        return self.area / self.width if inside else 0.0

    def sample(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        inside = (self.t0 - EPS <= t) & (t < self.t0 + self.width - EPS)
        return np.where(inside, self.area / self.width, 0.0)

    def __repr__(self) -> str:
        return f"impulse({_fmt(self.area)}, t0={_fmt(self.t0)}, width={_fmt(self.width)})"


@dataclasses.dataclass(frozen=True, repr=False)
class Sine(Signal):
    """``amplitude`` sin(2π ``frequency`` (t - t0) + ``phase``) from ``t0`` on, 0 before."""

    amplitude: float
    frequency: float
    phase: float = 0.0
    t0: float = 0.0

    def __call__(self, t: float) -> float:
        if t < self.t0 - EPS:
            return 0.0
        angle = 2.0 * math.pi * self.frequency * (t - self.t0) + self.phase
        return self.amplitude * math.sin(angle)

    def sample(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        angle = 2.0 * math.pi * self.frequency * (t - self.t0) + self.phase
        return np.where(t < self.t0 - EPS, 0.0, self.amplitude * np.sin(angle))

    def __repr__(self) -> str:
        options = (("phase", self.phase), ("t0", self.t0))
        extra = "".join(f", {k}={_fmt(v)}" for k, v in options if v)
        return f"sine({_fmt(self.amplitude)}, frequency={_fmt(self.frequency)}{extra})"


@dataclasses.dataclass(frozen=True, repr=False)
class Ramp(Signal):
    """0 before ``t0``, then ``slope`` (t - t0), held constant after ``t1`` (if given)."""

    slope: float
    t0: float = 0.0
    t1: float | None = None

    def __post_init__(self) -> None:
        if self.t1 is not None and not self.t1 > self.t0:
            raise InputError(f"ramp end t1={self.t1!r} must be after t0={self.t0!r}")

    def __call__(self, t: float) -> float:
        if t <= self.t0:
            return 0.0
        end = t if self.t1 is None else min(t, self.t1)
        return self.slope * (end - self.t0)

    def sample(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        end = t if self.t1 is None else np.minimum(t, self.t1)
        return np.where(t <= self.t0, 0.0, self.slope * (end - self.t0))

    def __repr__(self) -> str:
        extra = f", t1={_fmt(self.t1)}" if self.t1 is not None else ""
        return f"ramp({_fmt(self.slope)}, t0={_fmt(self.t0)}{extra})"


@dataclasses.dataclass(frozen=True, repr=False)
class Sum(Signal):
    """The sum of ``terms``."""

    terms: tuple[Signal, ...]

    def __call__(self, t: float) -> float:
        total = 0.0
        for term in self.terms:
            total += term(t)
        return total

    def sample(self, t: np.ndarray) -> np.ndarray:
        total = np.zeros(np.shape(t))
        for term in self.terms:
            total += term.sample(t)
        return total

    def __repr__(self) -> str:
        text = " + ".join(repr(term) for term in self.terms)
        return text.replace("+ -", "- ")


@dataclasses.dataclass(frozen=True, repr=False)
class Scaled(Signal):
    """``gain`` times ``signal``."""

    gain: float
    signal: Signal

    def __call__(self, t: float) -> float:
        return self.gain * self.signal(t)

    def sample(self, t: np.ndarray) -> np.ndarray:
        return self.gain * self.signal.sample(t)

    def __repr__(self) -> str:
        inner = repr(self.signal)
        inner = f"({inner})" if isinstance(self.signal, Sum) else inner
        return f"-{inner}" if self.gain == -1.0 else f"{_fmt(self.gain)} * {inner}"


@dataclasses.dataclass(frozen=True, repr=False)
class Function(Signal):
    """Any callable of time, under a name for reprs."""

    function: Callable[[float], float]
    name: str

    def __call__(self, t: float) -> float:
        return float(self.function(t))

    def __repr__(self) -> str:
        return self.name


class Held(Signal):
    """Samples held between their times (zero-order hold): ``values[k]`` from ``times[k]`` on,
    ``values[0]`` before the first time. What a digital controller's logged commands were."""

    def __init__(self, times: np.ndarray, values: np.ndarray) -> None:
        self.times = np.asarray(times, dtype=float)
        self.values = np.asarray(values, dtype=float)

    def __call__(self, t: float) -> float:
        return float(self.sample(np.array([t]))[0])

    def sample(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        k = np.searchsorted(self.times, t + EPS, side="right") - 1
        return self.values[np.clip(k, 0, len(self.values) - 1)]

    def __repr__(self) -> str:
        return (f"held({len(self.values)} samples, {_fmt(self.times[0])}..{_fmt(self.times[-1])} s)"
                if len(self.times) else "held(0 samples)")


def held(times: np.ndarray, values: np.ndarray) -> Held:
    """Samples ``values`` at ``times`` (s, increasing), each held until the next."""
    if len(times) != len(values) or len(times) == 0:
        raise InputError(f"held: times and values must be non-empty and of one length, got "
                         f"{len(times)} and {len(values)}")
    return Held(np.asarray(times, dtype=float), np.asarray(values, dtype=float))


def constant(value: float) -> Constant:
    """A constant signal."""
    return Constant(float(value))


def step(amplitude: float, t0: float = 0.0) -> Step:
    """A step of ``amplitude`` at time ``t0`` (s)."""
    return Step(float(amplitude), float(t0))


def impulse(area: float, t0: float = 0.0, width: float = 1e-3) -> Impulse:
    """A pulse of the given area (value × s) lasting ``width`` s from ``t0``.

    Make ``width`` a multiple of the simulation step (default 1 ms, the default step): the plant
    samples its inputs once per step.
    """
    return Impulse(float(area), float(t0), float(width))


def sine(amplitude: float, frequency: float, phase: float = 0.0, t0: float = 0.0) -> Sine:
    """A sine of ``frequency`` Hz and ``phase`` rad, starting at ``t0`` s."""
    return Sine(float(amplitude), float(frequency), float(phase), float(t0))


def ramp(slope: float, t0: float = 0.0, t1: float | None = None) -> Ramp:
    """A ramp of ``slope`` per second from ``t0``, flat after ``t1`` (s) if given."""
    return Ramp(float(slope), float(t0), None if t1 is None else float(t1))


def as_signal(value: Signal | Number | Callable[[float], float]) -> Signal:
    """A Signal from a signal, a number (a constant) or any callable of time."""
    if isinstance(value, Signal):
        return value
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        return constant(float(value))
    if callable(value):
        name = getattr(value, "__qualname__", None) or repr(value)
        return Function(value, name)
    raise SignalTypeError(f"expected a signal, a number or a callable of time, got {value!r}")


__all__ = ["EPS", "Signal", "SignalTypeError", "as_signal", "constant", "held", "impulse", "ramp",
           "sine", "step"]
