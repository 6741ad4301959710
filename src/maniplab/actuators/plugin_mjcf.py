"""MuJoCo engine plugins in an arm's model: an actuator modelled by one, and making sure MuJoCo
knows the plugins before a model that uses them is compiled.

maniplab's own plugins (the hydraulic cylinder, LuGre friction) are C code in
:mod:`maniplab_native`, built on first use and registered with MuJoCo by ``import mujoco`` through
the ``mujoco.plugins`` entry point; :func:`activate_plugins` also loads them explicitly, so a
source tree without an installed entry point works too.

In the model an actuator of a plugin refers to a plugin *instance* of the same name (MJCF:
``<extension><plugin plugin=...><instance name=...><config .../>``), which holds its parameters
as text, every number at full precision.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

import mujoco

import maniplab_native
from maniplab.errors import ModelError


class EnginePlugin(NamedTuple):
    """How an actuator is modelled inside MuJoCo by an engine plugin.

    Attributes:
        name: the plugin's registered name, e.g. "maniplab.hydraulic".
        states: its activations for the actuator (``actdim``).
        config: the instance's parameters (numbers or text).
    """

    name: str
    states: int
    config: Mapping[str, float | str]


def set_plugin(s: mujoco.MjSpec, act: mujoco.MjsActuator, plugin: EnginePlugin) -> None:
    """Make ``act`` (of ``s``) driven by a new instance of ``plugin``, named as the actuator."""
    instance = s.add_plugin(name=act.name, plugin_name=plugin.name, active=True)
    instance.config = {key: value if isinstance(value, str) else repr(float(value))
                       for key, value in plugin.config.items()}
    act.dyntype = mujoco.mjtDyn.mjDYN_NONE
    act.actdim = plugin.states
    act.actlimited = mujoco.mjtLimited.mjLIMITED_FALSE
    act.plugin = instance  # the plugin computes the force: MuJoCo's gain and bias do not apply


def plugins_of(s: mujoco.MjSpec) -> list[str]:
    """The engine plugins the actuators of ``s`` use, in order of first use."""
    names: list[str] = []
    for act in s.actuators:
        if act.plugin.active and act.plugin.plugin_name not in names:
            names.append(act.plugin.plugin_name)
    return names


def activate_plugins(s: mujoco.MjSpec) -> None:
    """Declare every plugin the actuators of ``s`` use (MJCF's ``<extension>``), loading
    maniplab's plugin library first when one of them is maniplab's.

    Raises:
        ModelError: maniplab's plugins could not be built (no C compiler, ...), one line.
    """
    names = plugins_of(s)
    if any(name in maniplab_native.PLUGINS for name in names):
        try:
            maniplab_native.load()
        except maniplab_native.NativeBuildError as exc:
            raise ModelError(str(exc)) from None
    for name in names:
        s.activate_plugin(name)
