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
    result = ml.optimize("study.yaml", out="opt/")  # co-design: the best spec by a study file
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

import importlib
from typing import TYPE_CHECKING, Any

# Nothing heavy is imported here: `maniplab --version` and `import maniplab` stay fast (MuJoCo,
# scipy, sympy and the actuator stack load when a name that needs them is first used). Each
# public name is imported from its home module on first access (PEP 562); the block below is
# the same table written as imports, for type checkers and the API reference.
_HOMES: dict[str, str] = {
    "load_plugins": "maniplab.actuators.registry",
    "builtin_spec": "maniplab.builtin", "builtin_specs": "maniplab.builtin",
    "resolve_spec": "maniplab.builtin",
    "ActuatorMaps": "maniplab.control", "CascadeController": "maniplab.control",
    "Controller": "maniplab.control", "MinJerkMove": "maniplab.control",
    "Path": "maniplab.control", "Pose": "maniplab.control",
    "segment_placement": "maniplab.control",
    "linearize": "maniplab.control.linearize",
    "ManiplabError": "maniplab.errors", "ModelError": "maniplab.errors",
    "SpecError": "maniplab.errors",
    "identify": "maniplab.identification",
    "LoadChart": "maniplab.loadchart", "load_chart": "maniplab.loadchart",
    "build_model": "maniplab.mjcf_gen", "to_mjcf": "maniplab.mjcf_gen",
    "optimize": "maniplab.optimize",
    "AnalyticModel": "maniplab.model",
    "InputError": "maniplab.sim", "InstabilityError": "maniplab.sim", "Plant": "maniplab.sim",
    "PlantState": "maniplab.sim", "PluginError": "maniplab.sim", "Run": "maniplab.sim",
    "SimulationError": "maniplab.sim", "signals": "maniplab.sim", "simulate": "maniplab.sim",
    "crossvalidate": "maniplab.sim.crossval",
    "RunSet": "maniplab.sim.runset",
    "sweep": "maniplab.sim.sweep",
    "Axis": "maniplab.spec", "Body": "maniplab.spec", "ControlSpec": "maniplab.spec",
    "EndEffector": "maniplab.spec", "Friction": "maniplab.spec",
    "FrictionModel": "maniplab.spec", "HydraulicActuator": "maniplab.spec",
    "Joint": "maniplab.spec", "JointType": "maniplab.spec",
    "ManipulatorSpec": "maniplab.spec", "PluginActuator": "maniplab.spec",
    "TorqueActuator": "maniplab.spec", "load_spec": "maniplab.spec",
    "to_urdf": "maniplab.urdf",
    "render": "maniplab.viz", "write_video": "maniplab.viz",
}
"""Public name -> the module it is imported from on first use."""

if TYPE_CHECKING:
    from maniplab import control, viz
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
    from maniplab.optimize import optimize
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

    __version__: str


def __getattr__(name: str) -> Any:
    """A public name, imported from its home module on first use (then cached here); a
    subpackage (``ml.viz``, ``ml.control``) likewise."""
    if name == "__version__":
        value: Any = _version()
    elif name in _HOMES:
        value = getattr(importlib.import_module(_HOMES[name]), name)
    elif not name.startswith("_"):
        try:
            value = importlib.import_module(f"maniplab.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"maniplab.{name}":
                raise
            raise AttributeError(f"module 'maniplab' has no attribute {name!r}") from None
    else:
        raise AttributeError(f"module 'maniplab' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("maniplab")
    except PackageNotFoundError:  # running from a source tree without installation
        return "0+unknown"


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
    "optimize",
    "render",
    "resolve_spec",
    "segment_placement",
    "signals",
    "simulate",
    "sweep",
    "to_mjcf",
    "to_urdf",
    "viz",
    "write_video",
]
