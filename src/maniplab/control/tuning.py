"""The controller's default gains and rate, derived from the arm and its actuators.

The rule, one loop inside the next, each a safe factor slower than the one it drives:

1. **Force loop** (the pressure loop of each hydraulic joint): its bandwidth ω_F is limited by the
   actuator's lag (a valve's τ: the flow it asks for arrives τ later), ω_F = FORCE_LAG / τ. The
   load's inertia, and with it the hydraulic natural frequency sqrt(A²E / (V J)), does not limit
   it: the loop feeds the piston's flow A q̇ forward, so the pressure follows its command
   whatever the joint moves (capping ω_F at a fraction of the natural frequency was tried on the
   test corpus and made heavy slewing joints, ω_h ≈ 2.5 rad/s, track a hundred times worse).
   One bandwidth serves every hydraulic joint (the slowest joint's); the pressure gain of each
   joint is ω_F V/E.
2. **Outer Cartesian loop**: three poles at ω_o = ω_F / OUTER (with ideal torque sources, ω_o is
   set by the controller's rate instead): kd = 3 ω_o, kp = 3 ω_o², ki = ω_o³.
3. **Rate**: fast enough that every loop is nearly continuous, ω h <= LOOP_STEP, and at least
   RATE_MIN.
4. **PID-only baseline**: each joint is a speed source (a valve: speed = flow / A; any other
   actuator through a velocity loop of gain k_v = VELOCITY × kp). A valve is a speed source only
   well below the resonance of its oil spring with the load, so the position loop's kp is
   limited by the arm's slowest spring mode over the workspace ω_s (the eigen-frequencies of the
   springs on M(q), the textbook limit of a hydraulic position servo, a fraction of ω_s) and by
   the lag: kp = min(PID_SPRING × ω_s, PID_LAG / τ) (Merritt's K_v <= 2 ζ_h ω_h with ζ_h = 0.1);
   the integral puts the loop's natural frequency sqrt(ki) at PID_NATURAL × ω_s. Without
   springs (ideal force sources) kp is half the outer loop's frequency and ki = kp²/4.

:func:`derive` returns the gains with one line of reasoning each (what ``maniplab tune``
prints); :func:`resolve` fills in the gains a ``control:`` section leaves out.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from maniplab.mjcf_gen import build_model
from maniplab.mjcf_gen.timestep import spring_modes
from maniplab.spec import (
    CartesianGains,
    ControlSpec,
    JointPIDGains,
    ManipulatorSpec,
    PressureGains,
    model_of,
)

FORCE_LAG = 0.4
"""ω_F τ: the force loop's bandwidth times the actuator's lag (the valve's phase lag at the
loop's crossover is then atan(0.4) = 22°, a phase margin near 70°)."""

OUTER = 3.0
"""ω_F / ω_o: how much slower the outer loop is than the force loop."""

IDEAL_OUTER_STEP = 0.05
"""ω_o h with ideal torque sources (no force loop): the outer loop's share of the rate."""

LOOP_STEP = 0.2
"""ω h at most for the fastest loop (h the controller's sample time)."""

RATE_MIN = 200.0
"""The controller's rate at least, Hz."""

PID_LAG = 0.2
"""kp τ of the PID-only baseline's position loop at most."""

PID_SPRING = 0.1
"""kp / ω_s of the PID-only baseline at most: Merritt's limit of a valve-controlled position
servo, K_v <= 2 ζ_h ω_h, with the hydraulic damping ratio ζ_h = 0.1."""

PID_NATURAL = 0.5
"""sqrt(ki) / ω_s: the integral puts the position loop's natural frequency at half the slowest
spring mode."""

VELOCITY = 4.0
"""k_v / kp of the baseline's velocity loop on actuators without a speed command."""


@dataclasses.dataclass(frozen=True)
class Tuning:
    """Derived controller settings and why.

    Attributes:
        control: the settings with every gain and the rate filled in.
        reasons: one line per derived value, e.g. {"pressure.bandwidth": "..."}.
    """

    control: ControlSpec
    reasons: dict[str, str]


def _nice_up(x: float) -> float:
    """The smallest of 1, 2, 5 × 10^k at least ``x``."""
    exponent = math.floor(math.log10(x))
    for mantissa in (1.0, 2.0, 5.0, 10.0):
        value = mantissa * 10.0**exponent
        if value >= x * (1.0 - 1e-12):
            return value
    return 10.0 ** (exponent + 1)  # pragma: no cover


def derive(spec: ManipulatorSpec) -> Tuning:
    """The controller's gains and rate for ``spec`` (see the module's rule)."""
    actuators = [model_of(j) for j in spec.joints]
    names = spec.joint_names
    slowest = spring_modes(spec, build_model(spec)).slowest
    lagged = [(a.lag, j) for j, a in enumerate(actuators) if a.lag > 0.0]
    reasons: dict[str, str] = {}
    force = None
    if lagged:
        lag, j = max(lagged)
        force = FORCE_LAG / lag
        reasons["pressure.bandwidth"] = (f"{force:.3g} rad/s: the slowest force loop, joint "
                                         f"{names[j]}'s ({FORCE_LAG:g} / τ, τ = {lag:g} s)")
    rate = RATE_MIN
    if force is not None:
        rate = max(RATE_MIN, _nice_up(force / LOOP_STEP))
        outer = force / OUTER
        outer_why = f"the force loop's {force:.3g} rad/s / {OUTER:g}"
    else:
        outer = IDEAL_OUTER_STEP * rate
        outer_why = f"ideal force sources: {IDEAL_OUTER_STEP:g} × the rate {rate:g} Hz"
    reasons["rate"] = (f"{rate:g} Hz: every loop at most {LOOP_STEP:g} rad per sample, and at "
                       f"least {RATE_MIN:g} Hz")
    cartesian = CartesianGains(kp=3.0 * outer**2, ki=outer**3, kd=3.0 * outer)
    reasons["position"] = (f"kp {cartesian.kp:.4g}, ki {cartesian.ki:.4g}, kd {cartesian.kd:.4g}:"
                           f" three poles at {outer:.3g} rad/s ({outer_why})")
    reasons["orientation"] = "as position"
    pid, pid_why = _pid(actuators, slowest, names, outer)
    reasons["pid_only"] = pid_why
    control = ControlSpec(rate=rate, position=cartesian, orientation=cartesian,
                          pressure=PressureGains(bandwidth=force if force is not None else 40.0),
                          pid_only=pid)
    return Tuning(control, reasons)


def _pid(actuators: list[Any], slowest: float, names: tuple[str, ...],
         outer: float) -> tuple[JointPIDGains, str]:
    candidates = [(PID_LAG / a.lag, f"joint {names[j]}'s {PID_LAG:g} / τ")
                  for j, a in enumerate(actuators) if a.lag > 0.0]
    if slowest > 0.0:
        candidates.append((PID_SPRING * slowest,
                           f"{PID_SPRING:g} × the arm's slowest spring mode, {slowest:.3g} rad/s"))
    if candidates:
        kp, text = min(candidates)
        ki, ki_text = (PID_NATURAL * slowest) ** 2, f"({PID_NATURAL:g} × the slowest mode)²"
        if slowest == 0.0:
            ki, ki_text = kp**2 / 4.0, "kp²/4"
    else:
        kp, text = outer / 2.0, "half the outer loop's poles (ideal force sources)"
        ki, ki_text = kp**2 / 4.0, "kp²/4"
    gains = JointPIDGains(kp=kp, ki=ki, kd=0.0, velocity_gain=VELOCITY * kp)
    return gains, (f"kp {kp:.3g} 1/s ({text}), ki {ki:.3g} 1/s² ({ki_text}), velocity loop "
                   f"{gains.velocity_gain:.3g} 1/s")


def resolve(spec: ManipulatorSpec, given: ControlSpec | None = None) -> ControlSpec:
    """``given`` (default: the spec's ``control:`` section) with what it leaves out derived."""
    given = given or spec.control or ControlSpec()
    if _complete(given):
        return given
    return _merge(given, derive(spec).control)


def _complete(value: Any) -> bool:
    if dataclasses.is_dataclass(value):
        return all(_complete(getattr(value, f.name)) for f in dataclasses.fields(value)
                   if f.name != "task")
    return value is not None


def _merge(given: Any, derived: Any) -> Any:
    """``given`` with its None fields (at any depth) taken from ``derived``."""
    changes = {}
    for f in dataclasses.fields(given):
        mine, theirs = getattr(given, f.name), getattr(derived, f.name)
        if dataclasses.is_dataclass(mine):
            changes[f.name] = _merge(mine, theirs)
        elif mine is None and f.name != "task":
            changes[f.name] = theirs
    return dataclasses.replace(given, **changes)
