"""Control: the paper's feedback-linearised cascade (Fig. 8) and its blocks, trajectories, analysis.

Blocks, each usable on its own:

- :class:`PID` (``pid``): filtered derivative, output limits, back-calculation anti-windup;
- G3 and the outer loop's kinematics (``kinematics``): pose from joint sensors, pose errors,
  J̇q̇, damped least squares;
- G1 (``inverse_dynamics``): M q̈ + C q̇ + G + Fv q̇ and the domain transformation τ -> ΔP_d;
- the inner pressure loop (``pressure``): ΔP_d -> oil-flow command Φ;
- G2 (``valve``): inversion of eq. (4)'s valve, Φ -> i_v;
- trajectories (``trajectory``): minimum-jerk moves, arcs, via points, segment placement;
- :class:`CascadeController` (``cascade``) composing them; ``mode="pid"`` is the PID-only baseline.
"""

from __future__ import annotations

from maniplab.control.actuation import ActuatorArrays
from maniplab.control.cascade import LOG_SIGNALS, CascadeController
from maniplab.control.inverse_dynamics import InverseDynamics, to_pressure
from maniplab.control.kinematics import (
    DampedLeastSquares,
    Kinematics,
    dls_solve,
    inverse_kinematics,
    matrix_to_rpy,
    pose_error,
    rotation_exp,
    rotation_log,
    rpy_to_matrix,
)
from maniplab.control.pid import PID
from maniplab.control.pressure import PressureLoop
from maniplab.control.trajectory import (
    ArcMove,
    Hold,
    MinJerkMove,
    Path,
    Pose,
    Reference,
    min_jerk,
    segment_placement,
)
from maniplab.control.valve import valve_current, valve_flow

__all__ = [
    "LOG_SIGNALS", "PID", "ActuatorArrays", "ArcMove", "CascadeController", "DampedLeastSquares",
    "Hold", "InverseDynamics", "Kinematics", "MinJerkMove", "Path", "Pose", "PressureLoop",
    "Reference", "dls_solve", "inverse_kinematics", "matrix_to_rpy", "min_jerk", "pose_error",
    "rotation_exp", "rotation_log", "rpy_to_matrix", "segment_placement", "to_pressure",
    "valve_current", "valve_flow",
]
