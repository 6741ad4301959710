"""Control: the paper's feedback-linearised cascade (Fig. 8) and its blocks, trajectories, analysis.

Blocks, each usable on its own:

- :class:`PID` (``pid``): filtered derivative, output limits, back-calculation anti-windup;
- G3 and the outer loop's kinematics (``kinematics``): pose from joint sensors, pose errors,
  J̇q̇, damped least squares;
- G1 (``inverse_dynamics``): M q̈ + C q̇ + G + Fv q̇;
- the actuators' drives (:mod:`maniplab.actuators.drive`): for a hydraulic joint the inner
  pressure loop, ΔP_d -> oil-flow command Φ, and G2, the valve inversion Φ -> i_v
  (:mod:`maniplab.actuators.hydraulic.drive`);
- trajectories (``trajectory``): minimum-jerk moves, arcs, via points, segment placement;
- :class:`CascadeController` (``cascade``) composing them; ``mode="pid"`` is the PID-only baseline.

For a controller of your own: the :class:`Controller` interface (``interface``), python-control
systems (:func:`from_python_control`), the actuators' maps (:class:`ActuatorMaps`: valve
inversion, command limits, top speeds, torque ↔ pressure, r(q)), planning and running a move
(:func:`plan_move`, :func:`run_move`), and the metrics (:func:`tracking_metrics`).
"""

from __future__ import annotations

from maniplab.control import metrics, point_to_point
from maniplab.control.cascade import LOG_SIGNALS, CascadeController
from maniplab.control.ik import IKSolution, inverse_kinematics
from maniplab.control.interface import TOLERANCES, Controller
from maniplab.control.inverse_dynamics import InverseDynamics
from maniplab.control.kinematics import (
    DampedLeastSquares,
    Kinematics,
    dls_solve,
    matrix_to_rpy,
    pose_error,
    rotation_exp,
    rotation_log,
    rpy_to_matrix,
)
from maniplab.control.lti import LTIController, from_python_control
from maniplab.control.metrics import TrackingMetrics, tracking_metrics
from maniplab.control.move import MoveResult, run_move
from maniplab.control.pid import PID
from maniplab.control.point_to_point import MovePlan, plan_move
from maniplab.control.toolkit import ActuatorMaps
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

__all__ = [
    "LOG_SIGNALS",
    "PID",
    "TOLERANCES",
    "ActuatorMaps",
    "ArcMove",
    "CascadeController",
    "Controller",
    "DampedLeastSquares",
    "Hold",
    "IKSolution",
    "InverseDynamics",
    "Kinematics",
    "LTIController",
    "MinJerkMove",
    "MovePlan",
    "MoveResult",
    "Path",
    "Pose",
    "Reference",
    "TrackingMetrics",
    "dls_solve",
    "from_python_control",
    "inverse_kinematics",
    "matrix_to_rpy",
    "metrics",
    "min_jerk",
    "plan_move",
    "point_to_point",
    "pose_error",
    "rotation_exp",
    "rotation_log",
    "rpy_to_matrix",
    "run_move",
    "segment_placement",
    "tracking_metrics",
]
