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
4. **PID-only baseline**, joint by joint: each joint is a speed source (a valve: speed = flow /
   A; any other actuator through a velocity loop of gain k_v = VELOCITY × kp) whose PID tracks
   the planned joint path with its speed fed forward. A valve is a speed source only well below
   the resonance of its oil spring with the load, so each joint's kp is limited by its own
   spring frequency ω_j = sqrt(k_j / M_jj), the lowest over the workspace (the textbook limit
   of a hydraulic position servo, Merritt's K_v <= 2 ζ_h ω_h, taken at ζ_h = 0.1 and a gain
   margin of 2), and by its valve's lag: kp_j = min(PID_SPRING × ω_j, PID_LAG / τ_j). The
   integral removes what a speed source leaves at rest (the leakage under load): ki_j = kp_j²/2,
   the pair s² + kp s + ki at damping ratio 0.71; it integrates only once the planned path has
   stopped, so a joint that lags during the move does not wind it up (with ki = (ω/2)² against
   a kp of ω/10, as before, the loop rang and diverged on the corpus arms). Joints without a
   spring or a lag (ideal force sources) get half the outer loop's frequency. Against Coulomb
   friction the loop may hunt by a few millimetres before it stops (the classic limit cycle
   of an integrating position servo).

:func:`derive` returns the gains with one line of reasoning each (what ``maniplab tune``
prints); :func:`resolve` fills in the gains a ``control:`` section leaves out.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from maniplab.mjcf_gen import build_model
from maniplab.mjcf_gen.timestep import hydraulic_frequencies
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
"""kp / ω_j of the PID-only baseline at most: Merritt's limit of a valve-controlled position
servo, K_v <= 2 ζ_h ω_h, with the hydraulic damping ratio ζ_h = 0.1 and a gain margin of 2."""

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
    model = build_model(spec)
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
    pid, pid_why = _pid(actuators, hydraulic_frequencies(spec, model).min(axis=0), names, outer)
    reasons["pid_only"] = pid_why
    control = ControlSpec(rate=rate, position=cartesian, orientation=cartesian,
                          pressure=PressureGains(bandwidth=force if force is not None else 40.0),
                          pid_only=pid)
    return Tuning(control, reasons)


def _pid(actuators: list[Any], springs: np.ndarray, names: tuple[str, ...],
         outer: float) -> tuple[JointPIDGains, str]:
    """Each joint's kp and ki (see the module's rule 4) from its spring frequency ω_j (rad/s,
    (n,), 0 without a spring), and their reasons."""
    kp, why = [], []
    for name, a, omega in zip(names, actuators, springs):
        candidates = [(PID_LAG / a.lag, f"{PID_LAG:g} / τ")] if a.lag > 0.0 else []
        if omega > 0.0:
            candidates.append((PID_SPRING * omega, f"{PID_SPRING:g} × ω {omega:.3g} rad/s"))
        ideal = (outer / 2.0, "half the outer loop's poles")
        value, text = min(candidates) if candidates else ideal
        kp.append(value)
        why.append(f"{name} {value:.3g} ({text})")
    ki = [k**2 / 2.0 for k in kp]
    gains = JointPIDGains(kp=tuple(kp), ki=tuple(ki), kd=0.0, velocity_gain=VELOCITY * max(kp))
    return gains, (f"kp per joint, 1/s: {'; '.join(why)}; ki = kp²/2 (damping ratio 0.71); "
                   f"velocity loop {gains.velocity_gain:.3g} 1/s")


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
