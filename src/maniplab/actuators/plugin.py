"""The actuator plugin interface, and finding a plugin by the name a spec gives it.

Every joint actuator is an :class:`ActuatorPlugin`: the built-in torque source
(:mod:`~maniplab.actuators.torque`) and hydraulic cylinder (:mod:`~maniplab.actuators.hydraulic`)
as much as a model a user writes in their own module. A spec names one by its ``type``::

    actuator: {type: torque}                                   # built-in
    actuator: {type: "mypkg.motors:GearedDCMotor", resistance: 1.2, ...}   # module:Class
    actuator: {type: dcmotor, resistance: 1.2, ...}            # registered name (entry point)

A registered name comes from :func:`register` or from the ``maniplab.actuators`` entry-point
group of an installed package::

    [project.entry-points."maniplab.actuators"]
    dcmotor = "mypkg.motors:GearedDCMotor"

The plugin's parameters (the actuator's keys besides ``type``) are validated by its ``Params``
dataclass like the rest of the spec, and a bad value raises SpecError naming the file, the joint
and the field (``joint q1, field 'actuator.resistance': expected a number > 0, got -1.0``).

The plant integrates a plugin's states inside MuJoCo's step (user actuator dynamics with one
activation per state, through MuJoCo's ``mjcb_act_dyn`` and ``mjcb_act_bias`` callbacks, installed
only while the plant steps; see :mod:`maniplab.sim.callbacks`). The built-in actuators implement
the same interface, and the plant also has a faster vectorised route for them (see
:class:`~maniplab.sim.plant.Plant`).
"""

from __future__ import annotations

import abc
import dataclasses
import importlib
import keyword
from collections.abc import Mapping
from importlib.metadata import entry_points
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from maniplab.spec import _CONFIG, PluginActuator
from maniplab.spec import dataclass as _spec_dataclass

if TYPE_CHECKING:
    from maniplab.spec import Joint

ENTRY_POINT_GROUP = "maniplab.actuators"
"""Entry-point group under which installed packages register actuator plugins."""

RESERVED_STATE_NAMES = frozenset(
    {"t", "q", "qd", "qdd", "tau_act", "tau_fric", "tau_limit", "ctrl", "iv", "mode", "ee_pos", "z"}
)
"""Signal names of a Run that a plugin state may not take (``dP`` and ``Q`` are allowed: they
mean pressure and flow, as for the built-in cylinder)."""


def parameters(cls: type) -> type:
    """Decorator for a plugin's ``Params``: a frozen dataclass validated like the spec.

    Unknown keys, wrong types, NaN and infinities are rejected; use the spec's annotated types
    (``maniplab.spec.Positive``, ``NonNegative``, ``Real``) for range checks::

        @parameters
        class MotorParams:
            resistance: Positive        # Ω
            inductance: Positive        # H
    """
    return _spec_dataclass(frozen=True, config=_CONFIG)(cls)


class ActuatorPlugin(abc.ABC):
    """One actuator model on one joint: states x, command u, force f.

    The model is ``ẋ = derivatives(x, u, q, v)`` and the joint force (N on a prismatic joint, N·m
    on a rotational one) is ``force(x, u, q, v)``, with q and v the joint's position and velocity.
    The command u is clipped to ±``command_limit`` before either is called.

    Subclasses set the class attributes and implement :meth:`force` (and :meth:`derivatives` when
    they have states). An instance is made per joint with the validated parameters.

    Class attributes:
        Params: the parameter dataclass (decorate it with :func:`parameters`).
        states: names of the states in order, e.g. ``("current",)``; each becomes a signal of
            the Run (NaN at joints without it). Empty for a stateless actuator.
        state_units: unit of each state, for plots (same length as ``states``).
        command: name of the command, e.g. "iv" (valve current) or "voltage".
        command_unit: unit of the command.

    Args:
        params: an instance of ``Params``.
        joint: the joint the actuator drives (its name, type and limits are there).
    """

    Params: ClassVar[type]
    states: ClassVar[tuple[str, ...]] = ()
    state_units: ClassVar[tuple[str, ...]] = ()
    command: ClassVar[str] = "u"
    command_unit: ClassVar[str] = ""

    def __init__(self, params: Any, joint: Joint) -> None:
        self.params = params
        self.joint = joint

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        for name in cls.states:
            if not name.isidentifier() or keyword.iskeyword(name) or name in RESERVED_STATE_NAMES:
                raise TypeError(
                    f"{cls.__qualname__}.states: {name!r} is not a valid state name; expected an "
                    f"identifier other than {', '.join(sorted(RESERVED_STATE_NAMES))}"
                )
        if cls.states and cls.derivatives is ActuatorPlugin.derivatives:
            raise TypeError(f"{cls.__qualname__} has states {cls.states} but no derivatives()")

    @property
    def command_limit(self) -> float | None:
        """Largest |u| (in the command's unit), or None for no limit."""
        return None

    def initial_state(self) -> np.ndarray:
        """States after a reset, shape (k,); zeros unless overridden."""
        return np.zeros(len(self.states))

    def derivatives(self, x: np.ndarray, u: float, q: float, v: float) -> np.ndarray:
        """Time derivatives of the states, shape (k,).

        Args:
            x: states, shape (k,).
            u: command (already clipped to the limit).
            q: joint position, rad or m.
            v: joint velocity, rad/s or m/s.
        """
        return np.zeros(0)

    @abc.abstractmethod
    def force(self, x: np.ndarray, u: float, q: float, v: float) -> float:
        """Force (prismatic, N) or torque (rotational, N·m) on the joint, along its axis."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}(joint={self.joint.name!r})"


# --- finding plugins ---------------------------------------------------------------------------

_REGISTRY: dict[str, type[ActuatorPlugin]] = {}


class PluginLookupError(LookupError):
    """No actuator plugin of that name (the message says why and what was expected)."""


def register(name: str, plugin: type[ActuatorPlugin]) -> None:
    """Make ``plugin`` available to specs as ``actuator: {type: <name>}``.

    Raises:
        TypeError: ``plugin`` is not an ActuatorPlugin subclass with a Params dataclass.
        ValueError: ``name`` is taken by another plugin, or contains ':'.
    """
    _check_plugin(plugin, name)
    if ":" in name:
        raise ValueError(f"plugin name {name!r} may not contain ':' (that form means module:Class)")
    if _REGISTRY.get(name, plugin) is not plugin:
        raise ValueError(f"actuator plugin name {name!r} is already registered")
    _REGISTRY[name] = plugin


def registered() -> dict[str, type[ActuatorPlugin]]:
    """Names registered with :func:`register` (the built-ins included), name -> class."""
    _ensure_builtins()
    return dict(_REGISTRY)


def resolve(name: str) -> type[ActuatorPlugin]:
    """The plugin class a spec's ``type`` names.

    Args:
        name: a registered name, an entry point of group ``maniplab.actuators``, or
            ``"module:Class"`` (``Class`` may be dotted: ``module:Outer.Inner``).

    Raises:
        PluginLookupError: nothing of that name, the module cannot be imported, or the object is
            not an ActuatorPlugin.
    """
    _ensure_builtins()
    if name in _REGISTRY:
        return _REGISTRY[name]
    if ":" in name:
        return _import(name)
    for point in entry_points(group=ENTRY_POINT_GROUP):
        if point.name == name:
            try:
                plugin = point.load()
            except Exception as exc:  # noqa: BLE001 - any import failure is the plugin's
                raise PluginLookupError(
                    f"entry point {name!r} ({point.value}) cannot be loaded "
                    f"({type(exc).__name__}: {exc})"
                ) from None
            _check_plugin(plugin, name, lookup=True)
            return plugin
    raise PluginLookupError(f"no actuator plugin named {name!r}")


def _import(name: str) -> type[ActuatorPlugin]:
    module_name, _, attr = name.partition(":")
    if not module_name or not attr:
        raise PluginLookupError(f"{name!r} is not of the form 'module:Class'")
    try:
        obj: Any = importlib.import_module(module_name)
    except Exception as exc:  # noqa: BLE001 - report any import failure as a lookup failure
        raise PluginLookupError(
            f"cannot import module {module_name!r} for actuator plugin {name!r} "
            f"({type(exc).__name__}: {exc})"
        ) from None
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise PluginLookupError(
                f"module {module_name!r} has no {attr!r} (actuator plugin {name!r})"
            ) from None
    _check_plugin(obj, name, lookup=True)
    return obj


def _check_plugin(plugin: Any, name: str, *, lookup: bool = False) -> None:
    error = PluginLookupError if lookup else TypeError
    if not (isinstance(plugin, type) and issubclass(plugin, ActuatorPlugin)):
        raise error(
            f"{name!r} is {plugin!r}, not a subclass of maniplab.actuators.ActuatorPlugin"
        )
    params = getattr(plugin, "Params", None)
    if not (isinstance(params, type) and dataclasses.is_dataclass(params)):
        raise error(f"actuator plugin {name!r} has no Params dataclass")


def _ensure_builtins() -> None:
    if "torque" not in _REGISTRY:
        from maniplab.actuators.hydraulic import HydraulicCylinder
        from maniplab.actuators.torque import TorqueSource

        _REGISTRY.setdefault("torque", TorqueSource)
        _REGISTRY.setdefault("hydraulic", HydraulicCylinder)


def plugin_of(joint: Joint) -> ActuatorPlugin:
    """The actuator model of ``joint``, made from its spec (built-in or plugin)."""
    spec = joint.actuator
    if isinstance(spec, PluginActuator):
        return spec.plugin(spec.params, joint)
    return resolve(spec.type)(spec, joint)


# --- validation (called by the spec layer) -----------------------------------------------------


def validate(data: Mapping[str, Any]) -> PluginActuator:
    """Validate a plugin actuator's mapping (``type`` plus parameters) into a PluginActuator.

    Raises:
        PluginLookupError: the type names no plugin.
        pydantic.ValidationError: a parameter is invalid (locations relative to the actuator).
    """
    from pydantic import TypeAdapter

    name = data["type"]
    plugin = resolve(name)
    values = {k: v for k, v in data.items() if k != "type"}
    params = TypeAdapter(plugin.Params).validate_python(values)
    return PluginActuator(type=name, params=params, plugin=plugin)
