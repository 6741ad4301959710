"""The manipulator spec: frozen, validated dataclasses describing one serial arm, base to tip.

A spec is usually read from YAML (:func:`load_spec`, see ``specfile``) or taken from the built-in
library (:func:`builtin_spec`). All frames coincide in orientation with the base frame at q = 0, so
axes, directions, centres of gravity and inertias are written in base axes. Units are SI.

Defaults of the optional fields (documented here and in the README):

=========================  ===================================================================
field                      default
=========================  ===================================================================
name                       the file's stem, or "manipulator" (any one line of printable text)
gravity                    [0, 0, -9.81] m/s²
joints[].name              q1 .. qn
joints[].type              (required) R or P; also accepted, in any case: Tr, revolute,
                           rotational, hinge (-> R); prismatic, translational, slide (-> P)
joints[].axis              (required) x, y or z (X, Y, Z accepted)
joints[].limits            none (the joint is unlimited)
joints[].body              none: no connecting body (the paper's l_b = 0, m_b = 0)
body.length                0 m
body.direction             [1, 0, 0] (normalised; must be unit length within 1e-3)
body.mass                  0 kg (the paper's m_b = 0: a massless body)
body.com                   length/2 * direction (the middle of the body)
body.inertia               slender rod about the COG: m L²/12 (1 - e eᵀ); zero when massless
joints[].actuator          {type: torque} (an ideal force or torque source, no limit)
joints[].friction          {model: none}
hydraulic.bulk_modulus     1.4e9 Pa (mineral oil); .leakage 0; .valve_tau 0.01 s;
                           .current_limit 1.0 (valve_gain is then the flow at full command)
friction.*                 0 (stribeck_velocity 0.01 m/s or rad/s, stick_velocity 1e-3,
                           sigma0 1e5, sigma1 316.2)
end_effector               mass 0 kg, offset [0, 0, 0] m, size derived from the mass (visual only)
control                    none: the controller's defaults (see ControlSpec)
=========================  ===================================================================

Numbers may be written as integers or floats (``1e-11`` is a float); booleans, text, NaN and
infinities are rejected where a number is expected. Vectors are lists of exactly 3 numbers
(``limits`` 2, ``inertia`` 6). Any bad input raises :class:`~maniplab.errors.SpecError`, also
when a dataclass is constructed directly in Python.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import math
from collections.abc import Mapping
from typing import Annotated, Any, Literal, Union

import numpy as np
from pydantic import (
    AfterValidator,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Strict,
    Tag,
    ValidationError,
    field_validator,
)
from pydantic.dataclasses import dataclass as _pydantic_dataclass
from pydantic_core import PydanticCustomError

from maniplab.errors import SpecError

_CONFIG = ConfigDict(extra="forbid", allow_inf_nan=False)
_NAME_PATTERN = r"^[A-Za-z_][A-Za-z0-9_\-]*$"



def _number(value: Any) -> Any:
    """Accept numpy scalars as floats; reject integers too large for a float."""
    if isinstance(value, (bool, np.bool_)):
        return value  # rejected by the strict float schema: True is not a number
    if isinstance(value, (np.integer, np.floating)):
        return float(value)
    if isinstance(value, int):
        try:
            return float(value)
        except OverflowError:
            raise PydanticCustomError(
                "finite_number", "Input should be a finite number"
            ) from None
    return value


def _sequence(value: Any) -> Any:
    """Accept lists, tuples and numpy arrays as vectors; reject sets, mappings, text, generators."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return value
    raise PydanticCustomError("tuple_type", "Input should be a valid list")


Real = Annotated[float, Strict(), BeforeValidator(_number)]
NonNegative = Annotated[float, Strict(), Field(ge=0.0), BeforeValidator(_number)]
Positive = Annotated[float, Strict(), Field(gt=0.0), BeforeValidator(_number)]
Vec3 = Annotated[tuple[Real, Real, Real], BeforeValidator(_sequence)]


def dataclass(**kwargs: Any) -> Any:
    """A frozen pydantic dataclass whose constructor raises SpecError instead of ValidationError."""

    def wrap(cls: type) -> type:
        cls = _pydantic_dataclass(**kwargs)(cls)
        init = cls.__init__

        @functools.wraps(init)
        def __init__(self: Any, *args: Any, **kw: Any) -> None:
            try:
                init(self, *args, **kw)
            except ValidationError as exc:
                from maniplab import specfile

                raise specfile.translate_errors(exc.errors(), {}, None, {}) from None

        cls.__init__ = __init__  # type: ignore[method-assign]
        return cls

    return wrap


class JointType(str, enum.Enum):
    """Rotational (R) or prismatic (P) joint; the paper writes a prismatic joint "Tr"."""

    R = "R"
    P = "P"


class Axis(str, enum.Enum):
    """A joint axis, one of the base frame's axes."""

    x = "x"
    y = "y"
    z = "z"

    @property
    def vector(self) -> np.ndarray:
        """Unit vector of the axis in base coordinates, shape (3,)."""
        return np.eye(3)[" xyz".index(self.value) - 1]


class FrictionModel(str, enum.Enum):
    """Joint friction model: none, the hybrid stick/slip automaton, or LuGre."""

    none = "none"
    hybrid = "hybrid"
    lugre = "lugre"


_JOINT_TYPE_ALIASES = {
    "r": "R", "revolute": "R", "rotational": "R", "hinge": "R",
    "p": "P", "tr": "P", "prismatic": "P", "translational": "P", "slide": "P",
}  # fmt: skip


def _joint_type_alias(value: Any) -> Any:
    return _JOINT_TYPE_ALIASES.get(value.lower(), value) if isinstance(value, str) else value


def _axis_alias(value: Any) -> Any:
    return value.lower() if isinstance(value, str) and value.lower() in ("x", "y", "z") else value


def _unit_direction(value: tuple[float, float, float]) -> tuple[float, float, float]:
    norm = math.hypot(*value)  # hypot neither overflows nor underflows
    if norm == 0.0:
        raise ValueError("direction is zero; expected a unit vector such as [1, 0, 0]")
    if abs(norm - 1.0) > 1e-3:
        raise ValueError(
            f"direction {list(value)} has length {norm:.4g}; expected a unit vector "
            f"(e.g. {[round(c / norm, 4) for c in value]})"
        )
    if abs(norm - 1.0) <= 1e-12:  # already unit: keep it bit for bit, so load(dump(s)) == s
        return value
    return tuple(c / norm for c in value)  # type: ignore[return-value]


def inertia_matrix(inertia: tuple[float, ...]) -> np.ndarray:
    """3x3 inertia matrix from [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] (MuJoCo's fullinertia order), kg·m²."""
    ixx, iyy, izz, ixy, ixz, iyz = inertia
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


def _physical_inertia(value: tuple[float, ...]) -> tuple[float, ...]:
    if min(value[:3]) < 0.0:
        raise ValueError(
            f"inertia {list(value)} has a negative moment; expected Ixx, Iyy, Izz >= 0"
        )
    scale = max(abs(v) for v in value)
    if scale == 0.0:
        return value
    # Scaled to 1 so that neither the eigenvalues nor the sums below overflow.
    moments = np.linalg.eigvalsh(inertia_matrix(tuple(v / scale for v in value)))
    tol = 1e-9
    shown = np.array2string(moments * scale, precision=4)
    if moments[0] < -tol:
        raise ValueError(
            f"inertia {list(value)} is not positive semi-definite (principal moments {shown}); "
            "expected a rigid body's inertia, whose principal moments are all >= 0"
        )
    a, b, c = moments
    if a + b < c - tol:
        raise ValueError(
            f"inertia {list(value)} violates the triangle inequality (principal moments {shown}); "
            "expected I1 + I2 >= I3, which holds for any rigid body"
        )
    return value


Inertia = Annotated[
    tuple[Real, Real, Real, Real, Real, Real],
    BeforeValidator(_sequence),
    AfterValidator(_physical_inertia),
]


@dataclass(frozen=True, config=_CONFIG)
class Body:
    """The rigid body that connects a joint to the next one (eq. 1 of the paper).

    Attributes:
        length: offset to the next joint along ``direction``, m.
        direction: unit vector e in base axes, shape (3,).
        mass: kg; 0 is the paper's massless body (m_b = 0).
        com: centre of gravity in the joint frame, m, shape (3,).
        inertia: about the COG in joint-frame axes, [Ixx, Iyy, Izz, Ixy, Ixz, Iyz], kg·m².
    """

    length: NonNegative = 0.0
    direction: Annotated[Vec3, AfterValidator(_unit_direction)] = (1.0, 0.0, 0.0)
    mass: NonNegative = 0.0
    com: Vec3 | None = None
    inertia: Inertia | None = None

    def __post_init__(self) -> None:
        e = np.asarray(self.direction)
        if self.com is None:
            object.__setattr__(self, "com", tuple(float(c) for c in 0.5 * self.length * e))
        if self.inertia is None:
            with np.errstate(over="ignore", invalid="ignore"):
                rod = self.mass * np.float64(self.length) ** 2 / 12.0 * (np.eye(3) - np.outer(e, e))
            if not np.all(np.isfinite(rod)):
                raise ValueError(
                    f"the default inertia m L²/12 of a {self.mass:g} kg, {self.length:g} m body "
                    "overflows; expected a smaller mass or length, or an explicit inertia"
                )
            object.__setattr__(self, "inertia", _inertia_tuple(rod))

    @property
    def offset(self) -> np.ndarray:
        """Translation from this joint's frame to the next joint's frame, m, shape (3,)."""
        return self.length * np.asarray(self.direction)


def _inertia_tuple(matrix: np.ndarray) -> tuple[float, ...]:
    return tuple(float(matrix[i, j]) for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)))


@dataclass(frozen=True, config=_CONFIG)
class TorqueActuator:
    """An ideal force (prismatic) or torque (rotational) source: the command is the force.

    Attributes:
        limit: largest |force| in N or N·m, or None for no limit.
    """

    type: Literal["torque"] = "torque"
    limit: Positive | None = None


@dataclass(frozen=True, config=_CONFIG)
class HydraulicActuator:
    """Valve-controlled hydraulic cylinder of the paper's eq. (4); the command is the valve current.

    Attributes:
        area: piston area A, m² (m³/rad on a rotational joint: force = A ΔP).
        volume: oil volume V of the cylinder and lines, m³.
        bulk_modulus: effective bulk modulus E, Pa.
        leakage: leakage coefficient Le, m³/(s·Pa).
        valve_gain: flow gain C, m³/(s·A): flow at current i_v with no load is i_v C.
        valve_tau: valve time constant τ, s.
        supply_pressure: Ps, Pa.
        current_limit: largest |i_v|, A.
    """

    type: Literal["hydraulic"]
    area: Positive
    volume: Positive
    valve_gain: Positive
    supply_pressure: Positive
    bulk_modulus: Positive = 1.4e9
    leakage: NonNegative = 0.0
    valve_tau: Positive = 0.01
    current_limit: Positive = 1.0


ACTUATOR_TYPES = ("torque", "hydraulic")


@dataclasses.dataclass(frozen=True)
class PluginActuator:
    """An actuator implemented by a plugin (:class:`maniplab.actuators.ActuatorPlugin`).

    Written in a spec as ``actuator: {type: "mypkg.motors:GearedDCMotor", <parameters>}`` or with a
    registered name (``type: dcmotor``); the parameters are validated by the plugin's ``Params``.

    Attributes:
        type: the plugin's name as written in the spec.
        params: the plugin's validated parameters (an instance of its ``Params``).
        plugin: the plugin class (not part of the value).
    """

    type: str
    params: Any
    plugin: Any = dataclasses.field(default=None, compare=False, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """``{"type": ..., <parameters>}`` as written in a spec file."""
        return {"type": self.type, **_plain(dataclasses.asdict(self.params))}


def _plugin_actuator(value: Any) -> Any:
    """Validate a mapping whose ``type`` is not a built-in actuator as a plugin actuator."""
    if not isinstance(value, (Mapping, TorqueActuator, HydraulicActuator, PluginActuator)):
        raise PydanticCustomError("dict_type", "Input should be a valid dictionary")
    if not (isinstance(value, Mapping) and isinstance(value.get("type"), str)):
        return value
    name = value["type"]
    if name in ACTUATOR_TYPES:
        return value
    from maniplab.actuators import plugin as _plugin
    from maniplab.specfile import plugin_problem

    try:
        return _plugin.validate(value)
    except _plugin.PluginLookupError as exc:
        if ":" not in name and "no actuator plugin named" in str(exc):
            raise PydanticCustomError(
                "union_tag_invalid", "unknown actuator type {tag}", {"tag": name}
            ) from None
        raise PydanticCustomError(
            "plugin_problem", "{problem}", {"problem": str(exc), "field": "type"}
        ) from None
    except ValidationError as exc:
        field, problem = plugin_problem(exc.errors(), _plugin.resolve(name).Params)
        raise PydanticCustomError(
            "plugin_problem", "{problem}", {"problem": problem, "field": field}
        ) from None


def _actuator_tag(value: Any) -> Any:
    if isinstance(value, PluginActuator):
        return "plugin"
    tag = value.get("type") if isinstance(value, Mapping) else getattr(value, "type", None)
    return "plugin?" if tag == "plugin" else tag  # "plugin" is the tag of validated instances


Actuator = Annotated[
    Union[
        Annotated[TorqueActuator, Tag("torque")],
        Annotated[HydraulicActuator, Tag("hydraulic")],
        Annotated[PluginActuator, Tag("plugin")],
    ],
    Discriminator(_actuator_tag),
    BeforeValidator(_plugin_actuator),
]


@dataclass(frozen=True, config=_CONFIG)
class Friction:
    """Joint friction parameters (units N, N·s/m, m/s on prismatic joints; N·m, rad/s on rotational).

    ``static`` is the stiction above Coulomb: the break-away force is ``coulomb + static``.
    The hybrid model uses coulomb, static, stribeck_velocity, viscous and stick_velocity; LuGre
    uses the same plus sigma0 (bristle stiffness) and sigma1 (bristle damping).
    """

    model: FrictionModel = FrictionModel.none
    coulomb: NonNegative = 0.0
    static: NonNegative = 0.0
    stribeck_velocity: Positive = 0.01
    viscous: NonNegative = 0.0
    stick_velocity: Positive = 1e-3
    sigma0: Positive = 1e5
    sigma1: NonNegative = 316.2


@dataclass(frozen=True, config=_CONFIG)
class Joint:
    """One degree of freedom: the joint, the body after it, its actuator and its friction.

    Attributes:
        name: unique name (letters, digits, '_' and '-').
        type: R (rotational) or P (prismatic).
        axis: x, y or z, in base axes.
        limits: (lower, upper) in rad or m, or None.
        body: the connecting body, or None (l_b = 0, m_b = 0).
    """

    name: Annotated[str, Strict(), Field(pattern=_NAME_PATTERN)]
    type: Annotated[JointType, BeforeValidator(_joint_type_alias)]
    axis: Annotated[Axis, BeforeValidator(_axis_alias)]
    limits: Annotated[tuple[Real, Real], BeforeValidator(_sequence)] | None = None
    body: Body | None = None
    actuator: Actuator = TorqueActuator()
    friction: Friction = Friction()

    @field_validator("limits")
    @classmethod
    def _ordered(cls, value: tuple[float, float] | None) -> tuple[float, float] | None:
        if value is not None and not value[0] < value[1]:
            raise ValueError(f"limits {list(value)} are not increasing; expected [lower, upper]")
        return value

    @property
    def prismatic(self) -> bool:
        """True for a prismatic joint."""
        return self.type is JointType.P

    @property
    def axis_vector(self) -> np.ndarray:
        """Unit joint axis in base coordinates, shape (3,)."""
        return self.axis.vector

    @property
    def offset(self) -> np.ndarray:
        """Translation from this joint's frame to the next one (zero without a body), m, (3,)."""
        return self.body.offset if self.body else np.zeros(3)


@dataclass(frozen=True, config=_CONFIG)
class EndEffector:
    """Point mass (the payload) at the frame after the last body, displaced by ``offset``.

    Attributes:
        mass: kg.
        offset: position of the payload in the last frame, m, shape (3,).
        size: full edge lengths of the payload box drawn in the MJCF (visual only), m, or None
            for a cube of concrete (2400 kg/m³) of the payload's mass.
    """

    mass: NonNegative = 0.0
    offset: Vec3 = (0.0, 0.0, 0.0)
    size: Annotated[tuple[Positive, Positive, Positive], BeforeValidator(_sequence)] | None = None

    @property
    def box_size(self) -> np.ndarray:
        """Edge lengths of the payload box for drawing, m, shape (3,)."""
        if self.size is not None:
            return np.asarray(self.size)
        return np.full(3, max((self.mass / 2400.0) ** (1.0 / 3.0), 0.05))


@dataclass(frozen=True, config=_CONFIG)
class CartesianGains:
    """Gains of the outer Cartesian PID on one group of task rows (position or orientation).

    With feedback linearisation each task coordinate obeys ë + kd ė + kp e + ki ∫e = 0.

    Attributes:
        kp: 1/s².  ki: 1/s³.  kd: 1/s.
    """

    kp: NonNegative
    ki: NonNegative = 0.0
    kd: NonNegative = 0.0


@dataclass(frozen=True, config=_CONFIG)
class PressureGains:
    """Gains of the inner pressure loop (the same on every hydraulic joint, scaled by V/E).

    Attributes:
        bandwidth: ω_P, rad/s: Kp_P = ω_P V/E.
        integral: ω_I, 1/s: Ki_P = ω_I Kp_P (0 for none).
        speed_gain: k_v, dimensionless: flow k_v A (q̇_ref - q̇) from the speed error.
        rate_filter: time constant of the dΔP_d/dt filter, s.
    """

    bandwidth: Positive = 40.0
    integral: NonNegative = 0.0
    speed_gain: NonNegative = 0.0
    rate_filter: NonNegative = 0.01


@dataclass(frozen=True, config=_CONFIG)
class JointPIDGains:
    """Gains of the PID-only baseline (no feedback linearisation), per joint.

    The PID output is a joint speed (rad/s or m/s) turned into valve current through the valve's
    no-load gain, i_v = u A / C; on a torque joint the output is scaled by the diagonal of M(q).
    The defaults are the erector's tuned gains (grid search in examples/pid_baseline.py).

    Attributes:
        kp: 1/s.  ki: 1/s².  kd: dimensionless.
    """

    kp: NonNegative = 3.0
    ki: NonNegative = 96.0
    kd: NonNegative = 0.0


@dataclass(frozen=True, config=_CONFIG)
class ControlSpec:
    """The cascade controller's settings (the spec file's optional ``control:`` section).

    Attributes:
        rate: controller sample rate, Hz.
        task: "position" (3 task rows) or "pose" (6); None: pose for arms with >= 6 joints.
        position: outer-loop gains on the position rows.
        orientation: outer-loop gains on the orientation rows.
        derivative_filter: time constant of the outer loop's derivative filter, s.
        dls_damping: largest damping λ of the damped least squares (units of σ(J)).
        dls_threshold: smallest singular value of J below which the damping starts.
        null_damping: joint damping in the task's null space (redundant arms), 1/s.
        capacity_weighting: share the motion among the joints in proportion to their top speed
            (weighted least squares, weights C i_max / A of each hydraulic joint).
        coulomb_feedforward: add Fc tanh(q̇_ref / v_s) to G1's inverse dynamics (an extension
            of the paper's G1 from the spec's friction parameters; it keeps joints from
            sticking at the start of a move).
        valve_min_root: floor of sqrt(1 - |ΔP|/Ps) in G2's valve inversion.
        pressure: inner-loop gains.
        pid_only: gains of the PID-only baseline.
    """

    rate: Positive = 200.0
    task: Literal["position", "pose"] | None = None
    position: CartesianGains = CartesianGains(kp=400.0, ki=1000.0, kd=40.0)
    orientation: CartesianGains = CartesianGains(kp=400.0, ki=1000.0, kd=40.0)
    derivative_filter: NonNegative = 0.0
    dls_damping: NonNegative = 0.05
    dls_threshold: NonNegative = 0.05
    null_damping: NonNegative = 5.0
    capacity_weighting: Annotated[bool, Strict()] = True
    coulomb_feedforward: Annotated[bool, Strict()] = True
    valve_min_root: Annotated[float, Strict(), Field(gt=0.0, le=1.0),
                              BeforeValidator(_number)] = 0.05
    pressure: PressureGains = PressureGains()
    pid_only: JointPIDGains = JointPIDGains()


@dataclass(frozen=True, config=_CONFIG, kw_only=True)
class ManipulatorSpec:
    """A serial manipulator, base to end-effector, one joint per degree of freedom.

    Attributes:
        name: the arm's name.
        gravity: gravity vector in base axes, m/s², shape (3,).
        joints: the joints in order from the base; MuJoCo's qpos order.
        end_effector: the payload.
        control: the cascade controller's settings, or None for the defaults.
        source: the file the spec was read from (for messages; not part of the spec's value).
    """

    name: Annotated[str, Strict(), Field(min_length=1)]
    gravity: Vec3 = (0.0, 0.0, -9.81)
    joints: Annotated[tuple[Joint, ...], Field(min_length=1), BeforeValidator(_sequence)]
    end_effector: EndEffector = EndEffector()
    control: ControlSpec | None = None
    source: str | None = dataclasses.field(default=None, compare=False, repr=False)

    @field_validator("name")
    @classmethod
    def _printable(cls, name: str) -> str:
        if not name.isprintable():
            raise ValueError(
                f"name {name!r} has a line break or control character; expected one line of text"
            )
        return name

    @field_validator("joints")
    @classmethod
    def _unique_names(cls, joints: tuple[Joint, ...]) -> tuple[Joint, ...]:
        seen: set[str] = set()
        for joint in joints:
            if joint.name in seen:
                raise ValueError(f"duplicate joint name '{joint.name}'; joint names must be unique")
            seen.add(joint.name)
        return joints

    # --- construction ------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Any, *, source: str | None = None) -> ManipulatorSpec:
        """Validate a plain dict (as read from YAML) into a spec; raises SpecError on bad input."""
        from maniplab import specfile

        return specfile.spec_from_dict(data, source=source)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (lists, floats, strings) with every default written out; from_dict inverts it."""
        data = _plain(dataclasses.asdict(self, dict_factory=_drop_source))
        for joint, joint_data in zip(self.joints, data["joints"]):
            if isinstance(joint.actuator, PluginActuator):
                joint_data["actuator"] = joint.actuator.to_dict()
        return data

    def dump(self, path: str) -> None:
        """Write the spec as YAML to ``path`` (atomically); load_spec reads it back equal."""
        from maniplab import specfile

        specfile.dump_spec(self, path)

    def with_overrides(self, overrides: Mapping[str, Any]) -> ManipulatorSpec:
        """A copy with fields replaced, addressed by dotted paths.

        Joints are addressed by name or 0-based index: ``{"end_effector.mass": 800.0,
        "joints.q2.actuator.leakage": 1e-11, "joints.0.friction.viscous": 2e4}``.
        Raises SpecError naming the path when it does not exist or the value is invalid.
        """
        from maniplab import overrides as _overrides

        return _overrides.apply(self, overrides)

    # --- convenience -------------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Number of degrees of freedom."""
        return len(self.joints)

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Joint names in order."""
        return tuple(j.name for j in self.joints)

    def joint(self, key: str | int) -> Joint:
        """A joint by name or 0-based index; raises SpecError listing the names when unknown."""
        return self.joints[self.joint_index(key)]

    def joint_index(self, key: str | int) -> int:
        """0-based index of a joint given by name or index."""
        names = self.joint_names
        if isinstance(key, int) and -len(names) <= key < len(names):
            return key % len(names)
        if isinstance(key, str) and key in names:
            return names.index(key)
        raise SpecError(
            f"no joint {key!r}; expected one of {', '.join(names)} or an index 0..{len(names) - 1}",
            file=self.source,
        )


def _drop_source(items: list[tuple[str, Any]]) -> dict[str, Any]:
    """Leave out ``source`` (not part of the value) and an absent ``control`` section."""
    return {k: v for k, v in items if k != "source" and not (k == "control" and v is None)}


def _plain(value: Any) -> Any:
    """Turn tuples, enums and numpy scalars into YAML-friendly lists, strings and floats."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, (float, np.floating)):
        return float(value)
    return value
