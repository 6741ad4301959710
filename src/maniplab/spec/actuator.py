"""A joint's ``actuator:`` section: any registered actuator type, validated by its own ``Params``.

A built-in type's parameters carry their ``type`` (``HydraulicActuator(type="hydraulic", ...)``);
any other plugin's parameters are wrapped with theirs in a :class:`PluginActuator`. Either way the
value has ``.type`` and the parameters as attributes, :func:`params_of` gives the parameters
alone, and :func:`model_of` makes the joint's actuator model.

Data that needs no plugin (a run file's stored spec) is validated with the context
``{DEFER_PLUGINS: True}``: an actuator whose plugin is not available is then kept as an
:class:`UnresolvedActuator`, and only making its model fails.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping
from typing import TYPE_CHECKING, Annotated, Any

from pydantic import PlainValidator, TypeAdapter, ValidationError, ValidationInfo
from pydantic_core import PydanticCustomError

from maniplab.actuators.base import ActuatorPlugin, JointFrame, ParameterProblem
from maniplab.actuators.registry import BUILTIN, PluginLookupError, resolve
from maniplab.schema import describe, plain, translate_errors
from maniplab.schema.translate import choices, did_you_mean

if TYPE_CHECKING:
    from maniplab.spec.arm import Joint, ManipulatorSpec


@dataclasses.dataclass(frozen=True)
class PluginActuator:
    """An actuator implemented by a plugin whose ``Params`` has no ``type`` field.

    Written in a spec as ``actuator: {type: "mypkg.motors:GearedDCMotor", <parameters>}`` or with a
    registered name (``type: dcmotor``). Its parameters read as attributes, like a built-in's
    (``joint.actuator.resistance``).

    Attributes:
        type: the plugin's name as written in the spec.
        params: the plugin's validated parameters (an instance of its ``Params``).
    """

    type: str
    params: Any

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__") or name == "params":
            raise AttributeError(name)
        return getattr(self.params, name)


DEFER_PLUGINS = "defer_plugins"
"""Key of the validation context: true keeps an actuator of an unavailable plugin unresolved."""


@dataclasses.dataclass(frozen=True)
class UnresolvedActuator:
    """An actuator of a plugin that was not available when stored data (a run file) was read.

    Its parameters are kept as stored, unvalidated; the spec lists, compares and writes as
    before, and :func:`model_of` fails naming the plugin to load.

    Attributes:
        type: the plugin's name as written in the spec.
        params: the parameters as stored (plain data).
        problem: why the plugin was not available.
    """

    type: str
    params: Mapping[str, Any] = dataclasses.field(hash=False)
    problem: str = dataclasses.field(compare=False, hash=False)


def params_of(actuator: Any) -> Any:
    """The parameters of an actuator value (the plugin's ``Params`` instance; stored data for an
    :class:`UnresolvedActuator`)."""
    return actuator.params if isinstance(actuator, (PluginActuator, UnresolvedActuator)) else actuator


def model_of(joint: Joint) -> ActuatorPlugin:
    """The actuator model of ``joint``, made from its spec (built-in or plugin).

    Raises:
        PluginLookupError: the actuator is an :class:`UnresolvedActuator`.
    """
    actuator = joint.actuator
    if isinstance(actuator, UnresolvedActuator):
        raise PluginLookupError(f"joint {joint.name}, actuator: {actuator.problem}")
    params = params_of(actuator)
    return resolve(actuator.type).variant(params=params)(params, joint)


def models_of(spec: ManipulatorSpec) -> list[ActuatorPlugin]:
    """Every joint's actuator model (:func:`model_of`), each told of the spec's shared pump where
    its model takes one (``on_pump``: a pinned cylinder's valve as a load-sensing pump feeds
    it), as a controller or a linear model sees them."""
    models = [model_of(joint) for joint in spec.joints]
    for model in models:
        getattr(model, "on_pump", lambda supply: None)(spec.supply)
    return models


def actuator_dict(actuator: Any) -> dict[str, Any]:
    """``{"type": ..., <parameters>}`` as written in a spec file."""
    params = params_of(actuator)
    fields = plain(dict(params) if isinstance(actuator, UnresolvedActuator)
                   else dataclasses.asdict(params))
    return {"type": actuator.type, **{k: v for k, v in fields.items() if k != "type"}}


def _problem(problem: str, field: str | None = None) -> PydanticCustomError:
    return PydanticCustomError("spec_problem", "{problem}",
                               {"problem": problem, "field": field or ""})


@functools.cache
def _adapter(params: type) -> TypeAdapter[Any]:
    return TypeAdapter(params)


def _has_type_field(params: type) -> bool:
    return any(f.name == "type" for f in dataclasses.fields(params))


def _validated(value: Any) -> bool:
    if isinstance(value, (PluginActuator, UnresolvedActuator)):
        return True
    kind = getattr(value, "type", None)
    return (dataclasses.is_dataclass(value) and isinstance(kind, str)
            and getattr(resolve(kind).variant(params=value), "Params", None) is type(value))


def validate_actuator(value: Any, info: ValidationInfo) -> Any:
    """Validate a joint's ``actuator`` section (a mapping with ``type``) into its value.

    Args:
        value: the section.
        info: pydantic's validation info; its context may set :data:`DEFER_PLUGINS`.

    Raises:
        PydanticCustomError: of kind ``spec_problem``, worded for the spec file, with the field
            below ``actuator`` that is wrong.
    """
    if _validated(value):
        return value
    example = "{type: torque}"
    if not isinstance(value, Mapping):
        raise _problem(f"expected a mapping such as {example}, got {describe(value)}")
    if "type" not in value:
        types = " or ".join(f"'type: {t}'" for t in BUILTIN)
        raise _problem(f"missing key 'type'; expected {types}, or a plugin's name", "type")
    name = value["type"]
    if not isinstance(name, str):
        raise _problem(f"expected text (an actuator type), got {describe(name)}", "type")
    try:
        plugin = resolve(name)
    except PluginLookupError as exc:
        problem = _lookup_problem(name, exc)
        if (info.context or {}).get(DEFER_PLUGINS):
            stored = {k: v for k, v in value.items() if k != "type"}
            return UnresolvedActuator(type=name, params=stored, problem=problem)
        raise _problem(problem, "type") from None
    plugin = plugin.variant(value)
    params = plugin.Params
    typed = _has_type_field(params)
    values = dict(value) if typed else {k: v for k, v in value.items() if k != "type"}
    try:
        validated = _adapter(params).validate_python(values)
    except ValidationError as exc:
        error = translate_errors(exc.errors(), root=params)
        raise _problem(error.problem, error.field) from None
    _check_joint(plugin, validated, info)
    return validated if typed else PluginActuator(type=name, params=validated)


def _check_joint(plugin: type[ActuatorPlugin], params: Any, info: ValidationInfo) -> None:
    """The plugin's :meth:`~ActuatorPlugin.check_joint` against the joint's fields validated so
    far (none when one of them failed: that error is reported)."""
    data = info.data if isinstance(info.data, Mapping) else {}
    if "type" not in data or "axis" not in data:
        return
    joint = JointFrame(prismatic=data["type"] == "P", axis=data["axis"].vector,
                       limits=data.get("limits"))
    try:
        plugin.check_joint(params, joint)
    except ParameterProblem as exc:
        raise _problem(str(exc), exc.field) from None


def _lookup_problem(name: str, exc: PluginLookupError) -> str:
    if ":" in name or "no actuator plugin named" not in str(exc):
        return str(exc)
    return (f"unknown actuator type {name!r}; expected {choices(list(BUILTIN))}, or a plugin as "
            f"'module:Class' or a registered name{did_you_mean(name, list(BUILTIN))}")


Actuator = Annotated[Any, PlainValidator(validate_actuator)]
"""The type of ``Joint.actuator``: any registered actuator's validated parameters."""
