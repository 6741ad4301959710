"""The controller's settings: the optional ``control:`` section of a spec.

Every gain left out (None) is derived from the arm and its actuators when a controller is made
(:mod:`maniplab.control.tuning`, ``maniplab tune``); a gain written here wins.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import BeforeValidator, Strict
from pydantic_core import PydanticCustomError

from maniplab.schema import NonNegative, Positive, UnitInterval, validated
from maniplab.schema.fields import number

Flag = Annotated[bool, Strict()]


def _joint_gain(value: Any) -> Any:
    """A gain >= 0 for every joint, or a list of one per joint (checked against the arm's joints
    by the spec): a float, or a tuple of floats."""
    if value is None:
        return None
    many = isinstance(value, (list, tuple, np.ndarray))
    items = [number(v) for v in (value if many else [value])]
    bad = [v for v in items if not (isinstance(v, float) and math.isfinite(v) and v >= 0.0)]
    if bad or not items:
        raise PydanticCustomError("spec_problem", "{problem}", {"problem": (
            f"expected a number >= 0 or a list of one per joint, got {value!r}"), "field": ""})
    return tuple(items) if many else items[0]


JointGain = Annotated[float | tuple[float, ...] | None, BeforeValidator(_joint_gain)]
"""One gain (>= 0) for every joint, or one per joint in the arm's order; None: derived."""


@validated
class CartesianGains:
    """Gains of the outer Cartesian PID on one group of task rows (position or orientation).

    With feedback linearisation each task coordinate obeys ë + kd ė + kp e + ki ∫e = 0.

    Attributes:
        kp: 1/s².  ki: 1/s³.  kd: 1/s.  (None: derived from the arm.)
    """

    EXAMPLE: ClassVar[str] = "kp: 400.0, ki: 1000.0, kd: 40.0"

    kp: NonNegative | None = None
    ki: NonNegative | None = None
    kd: NonNegative | None = None


@validated
class PressureGains:
    """Gains of the inner pressure loop (the same on every hydraulic joint, scaled by V/E).

    Attributes:
        bandwidth: ω_P, rad/s: Kp_P = ω_P V/E (None: derived from the arm).
        integral: ω_I, 1/s: Ki_P = ω_I Kp_P (0 for none).
        speed_gain: k_v, dimensionless: flow k_v A (q̇_ref - q̇) from the speed error.
        rate_filter: time constant of the dΔP_d/dt filter, s.
    """

    EXAMPLE: ClassVar[str] = "bandwidth: 40.0"

    bandwidth: Positive | None = None
    integral: NonNegative = 0.0
    speed_gain: NonNegative = 0.0
    rate_filter: NonNegative = 0.01


@validated
class JointPIDGains:
    """Gains of the PID-only baseline (no feedback linearisation), per joint.

    Each joint's PID tracks the planned joint path (the task error's least-squares image when
    there is none) and adds the path's speed: its output is a joint speed (rad/s or m/s). A
    valve turns it into current through its no-load gain, i_v = u A / C; an actuator without
    such a speed command gets a force from a velocity loop, M_jj k_v (u - q̇) (M_jj the joint's
    inertia at the pose).

    Attributes:
        kp: 1/s.  ki: 1/s².  kd: dimensionless: each one number for every joint or a list of
            one per joint.  velocity_gain: k_v, 1/s.  (None: derived from the arm.)
    """

    EXAMPLE: ClassVar[str] = "kp: 3.0, ki: 2.25"

    kp: JointGain = None
    ki: JointGain = None
    kd: JointGain = None
    velocity_gain: Positive | None = None


@validated
class ControlSpec:
    """The cascade controller's settings (the spec file's optional ``control:`` section).

    Every gain and the rate left at None are derived from the arm (:mod:`maniplab.control.tuning`).

    Attributes:
        rate: controller sample rate, Hz.
        task: "position" (3 task rows) or "pose" (6); None: pose for arms with >= 6 joints.
        position: outer-loop gains on the position rows.
        orientation: outer-loop gains on the orientation rows.
        derivative_filter: time constant of the outer loop's derivative filter, s.
        dls_damping: largest damping λ of the damped least squares (units of σ(J)).
        dls_threshold: smallest singular value of J below which the damping starts.
        null_damping: joint damping in the task's null space (redundant arms), 1/s.
        capacity_weighting: share the motion among the joints in proportion to their top speed
            (weighted least squares, weights C i_max / A of each hydraulic joint).
        coulomb_feedforward: add Fc tanh(q̇_ref / v_s) to G1's inverse dynamics (an extension
            of the paper's G1 from the spec's friction parameters; it keeps joints from
            sticking at the start of a move).
        valve_min_root: floor of sqrt(1 - |ΔP|/Ps) in G2's valve inversion.
        pressure: inner-loop gains.
        pid_only: gains of the PID-only baseline.
    """

    EXAMPLE: ClassVar[str] = "rate: 200.0, position: {kp: 400.0, kd: 40.0}"

    rate: Positive | None = None
    task: Literal["position", "pose"] | None = None
    position: CartesianGains = CartesianGains()
    orientation: CartesianGains = CartesianGains()
    derivative_filter: NonNegative = 0.0
    dls_damping: NonNegative = 0.05
    dls_threshold: NonNegative = 0.05
    null_damping: NonNegative = 5.0
    capacity_weighting: Flag = True
    coulomb_feedforward: Flag = True
    valve_min_root: UnitInterval = 0.05
    pressure: PressureGains = PressureGains()
    pid_only: JointPIDGains = JointPIDGains()
