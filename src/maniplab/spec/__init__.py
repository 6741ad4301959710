"""The manipulator spec: one file describes one serial arm, base to end-effector.

The spec is a tree of validated frozen dataclasses (:mod:`~maniplab.spec.arm`) that composes the
parameter sections of the parts it names: each joint's actuator (validated by its type's
``Params``, :mod:`~maniplab.spec.actuator`), its friction (:class:`~maniplab.friction.Friction`)
and the controller's settings (:mod:`~maniplab.spec.control`). Those dataclasses are the one
schema: validation, the one-line error translation (:mod:`maniplab.schema`) and the dotted-path
overrides (:mod:`~maniplab.spec.overrides`) are derived from them. Files are read by
:mod:`~maniplab.spec.files` in the YAML dialect of :mod:`~maniplab.spec.yaml_io`.
"""

from maniplab.actuators.hydraulic.params import HydraulicActuator
from maniplab.actuators.torque import TorqueActuator
from maniplab.friction.params import Friction, FrictionModel
from maniplab.schema import NonNegative, Positive, Real, Vec3
from maniplab.spec.actuator import PluginActuator, model_of, models_of, params_of
from maniplab.spec.arm import (
    Axis,
    Body,
    EndEffector,
    Joint,
    JointType,
    ManipulatorSpec,
    Supply,
    inertia_matrix,
)
from maniplab.spec.control import CartesianGains, ControlSpec, JointPIDGains, PressureGains
from maniplab.spec.files import load_spec

__all__ = [
    "Axis",
    "Body",
    "CartesianGains",
    "ControlSpec",
    "EndEffector",
    "Friction",
    "FrictionModel",
    "HydraulicActuator",
    "Joint",
    "JointPIDGains",
    "JointType",
    "ManipulatorSpec",
    "NonNegative",
    "PluginActuator",
    "Positive",
    "PressureGains",
    "Real",
    "Supply",
    "TorqueActuator",
    "Vec3",
    "inertia_matrix",
    "load_spec",
    "model_of",
    "models_of",
    "params_of",
]
