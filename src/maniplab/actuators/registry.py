"""The one registry of actuator types: a spec's ``type`` -> the plugin class that implements it.

A name is found, in this order, among

1. the built-in types, declared here once (:data:`BUILTIN`);
2. the names given to :func:`register`;
3. the entry points of the group ``maniplab.actuators`` of the installed packages::

       [project.entry-points."maniplab.actuators"]
       dcmotor = "mypkg.motors:GearedDCMotor"

4. ``"module:Class"`` (``Class`` may be dotted: ``module:Outer.Inner``): the module is imported.

Nothing outside this package asks for a built-in type by name or class: the spec validates an
actuator's parameters with its class's ``Params``, and every other part of maniplab uses the
capabilities the class declares (:mod:`~maniplab.actuators.base`).
"""

from __future__ import annotations

import dataclasses
import importlib
from importlib.metadata import entry_points
from typing import Any

from maniplab.actuators.base import ActuatorPlugin
from maniplab.actuators.hydraulic import HydraulicCylinder
from maniplab.actuators.torque import TorqueSource
from maniplab.errors import ManiplabError

ENTRY_POINT_GROUP = "maniplab.actuators"
"""Entry-point group under which installed packages register actuator plugins."""

BUILTIN: dict[str, type[ActuatorPlugin]] = {"torque": TorqueSource, "hydraulic": HydraulicCylinder}
"""The built-in actuator types by name."""

IDEAL_SOURCE = "torque"
"""The type of the ideal force/torque source (the command is the force)."""

_REGISTRY: dict[str, type[ActuatorPlugin]] = dict(BUILTIN)
_RESOLVED: dict[str, type[ActuatorPlugin]] = {}


class PluginLookupError(ManiplabError, LookupError):
    """No actuator plugin of that name (the message says why and what was expected)."""


class RegistryError(ManiplabError, ValueError):
    """A name cannot be registered (taken, or malformed)."""


def register(name: str, plugin: type[ActuatorPlugin]) -> None:
    """Make ``plugin`` available to specs as ``actuator: {type: <name>}``.

    Raises:
        TypeError: ``plugin`` is not an ActuatorPlugin subclass with a Params dataclass.
        RegistryError: ``name`` is taken by another plugin, or contains ':'.
    """
    _check_plugin(plugin, name)
    if ":" in name:
        raise RegistryError(f"plugin name {name!r} may not contain ':' (that form means "
                            "module:Class)")
    if _REGISTRY.get(name, plugin) is not plugin:
        raise RegistryError(f"actuator plugin name {name!r} is already registered")
    _REGISTRY[name] = plugin


def registered() -> dict[str, type[ActuatorPlugin]]:
    """Names known without importing anything (built-ins and :func:`register`), name -> class."""
    return dict(_REGISTRY)


def resolve(name: str) -> type[ActuatorPlugin]:
    """The plugin class a spec's ``type`` names (see the module's search order).

    Raises:
        PluginLookupError: nothing of that name, the module cannot be imported, or the object is
            not an ActuatorPlugin.
    """
    if name in _REGISTRY:
        return _REGISTRY[name]
    if name not in _RESOLVED:
        _RESOLVED[name] = _import(name) if ":" in name else _entry_point(name)
    return _RESOLVED[name]


def _entry_point(name: str) -> type[ActuatorPlugin]:
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
