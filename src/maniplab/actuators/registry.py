"""The one registry of actuator types: a spec's ``type`` -> the plugin class that implements it.

A name is found, in this order, among

1. the built-in types, declared here once (:data:`BUILTIN`);
2. the names given to :func:`register`;
3. the entry points of the group ``maniplab.actuators`` of the installed packages::

       [project.entry-points."maniplab.actuators"]
       dcmotor = "mypkg.motors:GearedDCMotor"

4. ``"module:Class"`` (``Class`` may be dotted: ``module:Outer.Inner``), when the user named the
   module on purpose: :func:`load_plugins` (the command line's ``--plugin MODULE``), the
   environment variable ``MANIPLAB_PLUGINS`` (modules, comma-separated), or their own code
   imported it already. A spec or a run file never makes maniplab import a module: reading data
   runs no code.

Nothing outside this package asks for a built-in type by name or class: the spec validates an
actuator's parameters with its class's ``Params``, and every other part of maniplab uses the
capabilities the class declares (:mod:`~maniplab.actuators.base`).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import os
import sys
from importlib.metadata import entry_points
from typing import Any

from maniplab.actuators.base import ActuatorPlugin
from maniplab.actuators.hydraulic import HydraulicCylinder
from maniplab.actuators.passive import Passive
from maniplab.actuators.torque import TorqueSource
from maniplab.errors import ManiplabError

ENTRY_POINT_GROUP = "maniplab.actuators"
"""Entry-point group under which installed packages register actuator plugins."""

PLUGINS_VARIABLE = "MANIPLAB_PLUGINS"
"""Environment variable naming plugin modules to load, comma-separated."""

BUILTIN: dict[str, type[ActuatorPlugin]] = {"torque": TorqueSource, "hydraulic": HydraulicCylinder,
                                             "passive": Passive}
"""The built-in actuator types by name."""

IDEAL_SOURCE = "torque"
"""The type of the ideal force/torque source (the command is the force)."""

_REGISTRY: dict[str, type[ActuatorPlugin]] = dict(BUILTIN)
_RESOLVED: dict[str, type[ActuatorPlugin]] = {}
_LOADED: set[str] = set()  # modules named on purpose (load_plugins)


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


def load_plugins(*modules: str) -> None:
    """Import plugin modules on purpose, so that specs may name their classes as
    ``"module:Class"`` (and names they :func:`register` on import become known).

    Args:
        modules: importable module names, e.g. ``"mypkg.motors"``.

    Raises:
        PluginLookupError: a name is not a module name, or the module cannot be imported.
    """
    for module in modules:
        _load(module)


def loaded_plugins() -> tuple[str, ...]:
    """The plugin modules named on purpose so far in this process (:func:`load_plugins`, or
    imported by the user and named by a spec), for worker processes to load in turn."""
    return tuple(sorted(_LOADED))


def _load(module: str) -> None:
    if not all(part.isidentifier() for part in module.split(".")):
        raise PluginLookupError(f"{module!r} is not a module name; expected e.g. mypkg.motors")
    try:
        importlib.import_module(module)
    except Exception as exc:  # noqa: BLE001 - report any import failure as a lookup failure
        raise PluginLookupError(
            f"cannot import plugin module {module!r} ({type(exc).__name__}: {exc})"
        ) from None
    _LOADED.add(module)


def _named_in_environment() -> list[str]:
    return [m.strip() for m in os.environ.get(PLUGINS_VARIABLE, "").split(",") if m.strip()]


def resolve(name: str) -> type[ActuatorPlugin]:
    """The plugin class a spec's ``type`` names (see the module's search order).

    Raises:
        PluginLookupError: nothing of that name, the module was not named on purpose or cannot
            be imported, or the object is not an ActuatorPlugin.
    """
    if name in _REGISTRY:
        return _REGISTRY[name]
    if name not in _RESOLVED:
        _RESOLVED[name] = _from_module(name) if ":" in name else _entry_point(name)
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


def _from_module(name: str) -> type[ActuatorPlugin]:
    """The class ``module:Class`` names, from a module loaded on purpose (never imported here
    because a spec names it)."""
    module_name, _, attr = name.partition(":")
    if not module_name or not attr:
        raise PluginLookupError(f"{name!r} is not of the form 'module:Class'")
    if module_name in _named_in_environment() and module_name not in _LOADED:
        _load(module_name)
    module = sys.modules.get(module_name)
    if module is None:
        raise PluginLookupError(
            f"{name!r} names module {module_name!r}, which was not loaded; name it with "
            f"--plugin {module_name} or {PLUGINS_VARIABLE}={module_name} (in Python: "
            f"ml.load_plugins({module_name!r}))"
        )
    obj: Any = module
    for part in attr.split("."):
        try:  # static: a module's __getattr__ could import more
            obj = inspect.getattr_static(obj, part)
        except AttributeError:
            raise PluginLookupError(
                f"module {module_name!r} has no {attr!r} (actuator plugin {name!r})"
            ) from None
    _check_plugin(obj, name, lookup=True)
    _LOADED.add(module_name)  # imported by the user's own code: named on purpose
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
