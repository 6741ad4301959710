"""maniplab: a design environment for serial (hydraulic) manipulators, built on MuJoCo.

Public API::

    import maniplab as ml
    spec = ml.load_spec("arm.yaml")          # or ml.builtin_spec("erector"); ml.builtin_specs()
    ml.load_plugins("mypkg.motors")          # before a spec names type: "mypkg.motors:Motor"
    spec2 = spec.with_overrides({"end_effector.mass": 800.0})
    xml = ml.to_mjcf(spec)                   # MJCF text at full float precision
    urdf = ml.to_urdf(spec)                  # URDF text (Pinocchio, ROS) at full precision
    model = ml.build_model(spec)             # mujoco.MjModel
    run = ml.simulate(spec, inputs={"q1": ml.signals.step(0.5, t0=0.1)}, duration=2.0)
    runs = ml.sweep(spec, {"end_effector.mass": [3000, 5000]}, out="runs/", duration=2.0)
    chart = ml.load_chart(spec)              # the largest payload held at each pose
"""


from __future__ import annotations

import os
import sys


def _running_as_main() -> bool:
    """Whether Python is locating this package to run it (``python -m maniplab``)."""
    if sys.argv[:1] != ["-m"]:  # what sys.argv[0] is while -m locates its module
        return False
    args = list(getattr(sys, "orig_argv", []))
    module = next((after if arg == "-m" else arg[2:]
                   for arg, after in zip(args, [*args[1:], ""]) if arg.startswith("-m")), "")
    return module.split(".")[0] == "maniplab"


if _running_as_main() and sys.path[:1] in ([""], [os.getcwd()]):
    # Python put the current folder first on sys.path: a yaml.py or plugin module there would be
    # imported in place of the real one. The folder holds data; code comes from installed packages.
    del sys.path[0]

from importlib.metadata import PackageNotFoundError, version

from maniplab import control
from maniplab.actuators.registry import load_plugins
from maniplab.builtin import builtin_spec, builtin_specs, resolve_spec
from maniplab.control import (
    ActuatorMaps,
    CascadeController,
    Controller,
    MinJerkMove,
    Path,
    Pose,
    segment_placement,
)
from maniplab.control.linearize import linearize
from maniplab.errors import ManiplabError, ModelError, SpecError
from maniplab.identification import identify
from maniplab.loadchart import LoadChart, load_chart
from maniplab.mjcf_gen import build_model, to_mjcf
from maniplab.model import AnalyticModel
from maniplab.sim import (
    InputError,
    InstabilityError,
    Plant,
    PlantState,
    PluginError,
    Run,
    SimulationError,
    signals,
    simulate,
)
from maniplab.sim.crossval import crossvalidate
from maniplab.sim.runset import RunSet
from maniplab.sim.sweep import sweep
from maniplab.spec import (
    Axis,
    Body,
    ControlSpec,
    EndEffector,
    Friction,
    FrictionModel,
    HydraulicActuator,
    Joint,
    JointType,
    ManipulatorSpec,
    PluginActuator,
    TorqueActuator,
    load_spec,
)
from maniplab.urdf import to_urdf
from maniplab.viz import render, write_video

try:
    __version__ = version("maniplab")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"

__all__ = [
    "ActuatorMaps",
    "AnalyticModel",
    "Axis",
    "Body",
    "CascadeController",
    "ControlSpec",
    "Controller",
    "EndEffector",
    "Friction",
    "FrictionModel",
    "HydraulicActuator",
    "InputError",
    "InstabilityError",
    "Joint",
    "JointType",
    "LoadChart",
    "ManiplabError",
    "ManipulatorSpec",
    "MinJerkMove",
    "ModelError",
    "Path",
    "Plant",
    "PlantState",
    "PluginActuator",
    "PluginError",
    "Pose",
    "Run",
    "RunSet",
    "SimulationError",
    "SpecError",
    "TorqueActuator",
    "__version__",
    "build_model",
    "builtin_spec",
    "builtin_specs",
    "control",
    "crossvalidate",
    "identify",
    "linearize",
    "load_chart",
    "load_plugins",
    "load_spec",
    "render",
    "resolve_spec",
    "segment_placement",
    "signals",
    "simulate",
    "sweep",
    "to_mjcf",
    "to_urdf",
    "write_video",
]
