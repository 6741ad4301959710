"""The manipulator spec: frozen, validated dataclasses describing one serial arm, base to tip.

A spec is usually read from YAML (:func:`~maniplab.spec.files.load_spec`) or taken from the built-in
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
joints[].max_moment        none (no structural limit in the load chart)
hydraulic.bulk_modulus     1.4e9 Pa (mineral oil); .leakage 0; .valve_tau 0.01 s;
                           .current_limit 1.0 (valve_gain is then the flow at full command)
friction.*                 0 (stribeck_velocity 0.01 m/s or rad/s, stick_velocity 1e-3,
                           sigma0 1e5, sigma1 316.2)
actuator.cylinder.friction none (a pinned cylinder's rod friction, N on the rod; its fields 0,
                           stribeck_velocity 0.01 m/s, stick_velocity 1e-3 m/s)
end_effector               mass 0 kg, offset [0, 0, 0] m, size derived from the mass (visual only)
control                    none: the controller's defaults (see ControlSpec)
base                       none (no tipping in the load chart); base.com [0, 0, 0] m,
                           base.ground 0 m
=========================  ===================================================================

Numbers may be written as integers or floats (``1e-11`` is a float); booleans, text, NaN and
infinities are rejected where a number is expected. Vectors are lists of exactly 3 numbers
(``limits`` 2, ``inertia`` 6). Any bad input raises :class:`~maniplab.errors.SpecError`, also
when a dataclass is constructed directly in Python.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import (
    AfterValidator,
    BeforeValidator,
    Field,
    Strict,
    TypeAdapter,
    ValidationError,
    ValidationInfo,
    field_validator,
)

from maniplab.actuators.hydraulic.params import RodFriction, rod_friction
from maniplab.actuators.torque import TorqueActuator
from maniplab.atomic import write_text
from maniplab.errors import SpecError
from maniplab.friction.params import Friction, FrictionModel
from maniplab.schema import (
    NonNegative,
    Positive,
    Real,
    Vec3,
    describe,
    not_vanishing,
    plain,
    sequence,
    translate_errors,
    validated,
)
from maniplab.schema.fields import LARGEST
from maniplab.schema.translate import INTERNAL, line_of, unknown_key_problem
from maniplab.spec import overrides as _overrides
from maniplab.spec.actuator import DEFER_PLUGINS, Actuator, actuator_dict, params_of
from maniplab.spec.control import ControlSpec
from maniplab.spec.yaml_io import Loc, dump_yaml

_NAME_PATTERN = r"^[A-Za-z_][A-Za-z0-9_\-]*$"
NAME_LENGTH = 64
"""The longest joint name, characters (a name is also a MuJoCo element's name and a column
label)."""

Mass = Annotated[NonNegative, AfterValidator(not_vanishing)]
"""A mass, kg: 0 (none), or at least schema.SMALLEST (MuJoCo divides by it)."""


class JointType(str, enum.Enum):
    """Rotational (R) or prismatic (P) joint; the paper writes a prismatic joint "Tr"."""

    R = "R"
    P = "P"

    @classmethod
    def choice_hint(cls) -> str:
        """Said after the choices when a joint type is unknown."""
        return " (the paper's Tr is accepted for P)"


class Axis(str, enum.Enum):
    """A joint axis, one of the base frame's axes."""

    x = "x"
    y = "y"
    z = "z"

    @property
    def vector(self) -> np.ndarray:
        """Unit vector of the axis in base coordinates, shape (3,)."""
        return np.eye(3)[" xyz".index(self.value) - 1]


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
    BeforeValidator(sequence),
    AfterValidator(_physical_inertia),
]


@validated
class Body:
    """The rigid body that connects a joint to the next one (eq. 1 of the paper).

    Attributes:
        length: offset to the next joint along ``direction``, m.
        direction: unit vector e in base axes, shape (3,).
        mass: kg; 0 is the paper's massless body (m_b = 0).
        com: centre of gravity in the joint frame, m, shape (3,).
        inertia: about the COG in joint-frame axes, [Ixx, Iyy, Izz, Ixy, Ixz, Iyz], kg·m².
    """

    EXAMPLE: ClassVar[str] = "length: 1.0, mass: 10.0"

    length: NonNegative = 0.0
    direction: Annotated[Vec3, AfterValidator(_unit_direction)] = (1.0, 0.0, 0.0)
    mass: Mass = 0.0
    com: Vec3 | None = None
    inertia: Inertia | None = None

    def __post_init__(self) -> None:
        e = np.asarray(self.direction)
        if self.com is None:
            object.__setattr__(self, "com", tuple(float(c) for c in 0.5 * self.length * e))
        if self.inertia is None:
            rod = self.mass * self.length**2 / 12.0 * (np.eye(3) - np.outer(e, e))
            largest = float(np.abs(rod).max())
            if largest > LARGEST:  # it is written out with the spec, and must read back
                raise ValueError(
                    f"the inertia of a {self.mass:g} kg rod {self.length:g} m long (m L²/12 = "
                    f"{largest:.4g} kg·m²) is beyond ±{LARGEST:g}, the largest number a spec "
                    "may hold; give a smaller length or mass, or an explicit inertia")
            object.__setattr__(self, "inertia", _inertia_tuple(rod))

    @property
    def offset(self) -> np.ndarray:
        """Translation from this joint's frame to the next joint's frame, m, shape (3,)."""
        return self.length * np.asarray(self.direction)


def _inertia_tuple(matrix: np.ndarray) -> tuple[float, ...]:
    return tuple(float(matrix[i, j]) for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)))


@validated
class Joint:
    """One degree of freedom: the joint, the body after it, its actuator and its friction.

    Attributes:
        name: unique name (letters, digits, '_' and '-').
        type: R (rotational) or P (prismatic).
        axis: x, y or z, in base axes.
        limits: (lower, upper) in rad or m, or None.
        body: the connecting body, or None (l_b = 0, m_b = 0).
        stop_energy: the kinetic energy its end stops may take at an impact, J: a run whose
            joint reaches a limit with more is reported (None: the default, 100 J).
        max_moment: the largest load the joint's structure may carry, N·m on a rotational
            joint, N on a prismatic one (rating data: the load chart's structural limit; None:
            no limit). Not part of the MuJoCo model.
    """

    EXAMPLE: ClassVar[str] = "name: q1, type: R, axis: z"

    name: Annotated[str, Strict(), Field(pattern=_NAME_PATTERN, max_length=NAME_LENGTH)]
    type: Annotated[JointType, BeforeValidator(_joint_type_alias)]
    axis: Annotated[Axis, BeforeValidator(_axis_alias)]
    limits: Annotated[tuple[Real, Real], BeforeValidator(sequence)] | None = None
    body: Body | None = None
    actuator: Actuator = TorqueActuator()
    friction: Friction = Friction()
    stop_energy: Positive | None = None
    max_moment: Positive | None = None

    @field_validator("limits")
    @classmethod
    def _ordered(cls, value: tuple[float, float] | None) -> tuple[float, float] | None:
        if value is not None and not value[0] < value[1]:
            raise ValueError(f"limits {list(value)} are not increasing; expected [lower, upper]")
        return value

    @field_validator("friction")
    @classmethod
    def _not_lugre_with_rod_friction(cls, friction: Friction, info: ValidationInfo) -> Friction:
        rod = rod_friction(info.data.get("actuator"))
        if friction.model is FrictionModel.lugre and rod is not None and rod.sticks:
            raise ValueError("model lugre with rod friction (actuator.cylinder.friction coulomb "
                             "or static): rod friction uses the hybrid stick/slip automaton; "
                             "give the joint model hybrid or none, or the rod viscous friction "
                             "only")
        return friction

    @property
    def rod_friction(self) -> RodFriction | None:
        """Its pinned cylinder's rod friction (``actuator.cylinder.friction``), N on the rod, or
        None."""
        return rod_friction(self.actuator)

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


@validated
class EndEffector:
    """The payload (a tool, a grapple, a load), fixed to the frame after the last body at the
    end-effector point ``offset``: a point mass there, or a rigid body with its own centre of
    gravity and inertia.

    Attributes:
        mass: kg.
        offset: the end-effector point (the tool point the pose and the Jacobian follow) in the
            frame after the last body, m, shape (3,).
        com: the payload's centre of gravity relative to the end-effector point, in the same
            axes as ``offset``, m, shape (3,) (default: at the point).
        inertia: the payload's inertia about its centre of gravity, in those axes,
            [Ixx, Iyy, Izz, Ixy, Ixz, Iyz], kg·m² (default: none, a point mass). A rigid body's:
            positive semi-definite, I1 + I2 >= I3.
        size: full edge lengths of the payload box drawn in the MJCF (visual only), m, or None
            for a cube of concrete (2400 kg/m³) of the payload's mass.
    """

    EXAMPLE: ClassVar[str] = "mass: 500.0"

    mass: Mass = 0.0
    offset: Vec3 = (0.0, 0.0, 0.0)
    com: Vec3 = (0.0, 0.0, 0.0)
    inertia: Inertia = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    size: Annotated[tuple[Positive, Positive, Positive], BeforeValidator(sequence)] | None = None

    @property
    def cog(self) -> np.ndarray:
        """The payload's centre of gravity in the frame after the last body, ``offset + com``,
        m, shape (3,)."""
        return np.asarray(self.offset, dtype=float) + np.asarray(self.com, dtype=float)

    @property
    def inertia_tensor(self) -> np.ndarray:
        """The payload's inertia about its centre of gravity, 3x3, kg·m²."""
        return inertia_matrix(self.inertia)

    @property
    def box_size(self) -> np.ndarray:
        """Edge lengths of the payload box for drawing, m, shape (3,)."""
        if self.size is not None:
            return np.asarray(self.size)
        return np.full(3, max((self.mass / 2400.0) ** (1.0 / 3.0), 0.05))


@validated
class Supply:
    """A pump shared by the pinned cylinders, with a flow limit.

    Attributes:
        pressure: its setting, Pa (each pinned cylinder's ``supply_pressure`` must be it): a
            constant-pressure pump's pressure, a load-sensing pump's cut-off.
        max_flow: the most it delivers (displacement × speed), m³/s; cylinders whose valves
            would draw more together get a lower supply pressure, and slow down.
        ls_margin: a load-sensing variable pump's margin, Pa: its pressure follows the highest
            load-sense pressure (the chamber an open section's meter-in edge feeds) plus this
            margin, at most ``pressure``; with every section closed it stands by at the tank's
            plus the margin. None: a constant-pressure pump.
        response: the time constant of the pump pressure's first-order response to what it
            is asked (the load-sense pressure plus margin, or the setting), s: a swash plate's
            regulator; None: it answers at once. The flow limit always acts at once.
        displacement: "variable" (it delivers what the sections draw, a pressure-compensated
            or load-sensing pump) or "fixed" (a gear pump: it always delivers ``max_flow``, the
            flow the sections do not take goes over its relief valve at ``pressure``). The
            pressures and motions are the same; the energy differs.
    """

    EXAMPLE: ClassVar[str] = "pressure: 8.0e6, max_flow: 1.0e-3"

    pressure: Positive
    max_flow: Positive
    ls_margin: Positive | None = None
    response: Positive | None = None
    displacement: Literal["variable", "fixed"] = "variable"


def _footprint(value: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
    """The corners of a convex polygon, in order (either way round), counter-clockwise."""
    if len(value) < 3:
        raise ValueError(f"footprint {[list(c) for c in value]} has {len(value)} corners; "
                         "expected at least 3 [x, y] corners of a convex polygon")
    corners = np.asarray(value, dtype=float)
    edges = np.roll(corners, -1, axis=0) - corners
    size = float(np.abs(corners - corners.mean(axis=0)).max())
    if size == 0.0 or float(np.linalg.norm(edges, axis=1).min()) <= 1e-9 * size:
        raise ValueError(f"footprint {[list(c) for c in value]} repeats a corner or has no "
                         "extent; expected the corners of a convex polygon, e.g. [[-1, -1], "
                         "[1, -1], [1, 1], [-1, 1]]")
    turns = edges[:, 0] * np.roll(edges, -1, axis=0)[:, 1] - \
        edges[:, 1] * np.roll(edges, -1, axis=0)[:, 0]
    angles = np.arctan2(turns, np.einsum("ij,ij->i", edges, np.roll(edges, -1, axis=0)))
    tol = 1e-9 * size * size
    if not (np.all(turns > tol) or np.all(turns < -tol)) or \
            abs(abs(float(angles.sum())) - 2.0 * math.pi) > 1e-6:
        raise ValueError(f"footprint {[list(c) for c in value]} is not a convex polygon (its "
                         "corners in order, no three on a line); expected e.g. [[-1, -1], "
                         "[1, -1], [1, 1], [-1, 1]]")
    return value if turns[0] > 0.0 else tuple(reversed(value))


@validated
class Base:
    """The machine the arm stands on, for the load chart's tipping (rating data; not part of the
    MuJoCo model): its mass and centre of gravity, and the polygon it stands on.

    Attributes:
        mass: the machine without the arm (carrier, counterweight, slew bearing...), kg.
        com: its centre of gravity in base axes, m, shape (3,).
        footprint: the support polygon's corners [x, y] in base axes (the outriggers' pads,
            the tracks' or wheels' contact), m, at height ``ground``: a convex polygon, its
            corners in order either way round (kept counter-clockwise).
        ground: the height of the support plane in base axes, m (the base frame above the
            ground: negative).
    """

    EXAMPLE: ClassVar[str] = "mass: 8000.0, com: [-0.5, 0, 0.8], footprint: [[-2, -1.5], " \
                             "[2, -1.5], [2, 1.5], [-2, 1.5]]"

    mass: Positive
    footprint: Annotated[tuple[Annotated[tuple[Real, Real], BeforeValidator(sequence)], ...],
                         BeforeValidator(sequence), AfterValidator(_footprint)]
    com: Vec3 = (0.0, 0.0, 0.0)
    ground: Real = 0.0

    def project(self, points: np.ndarray, gravity: np.ndarray) -> np.ndarray:
        """``points`` (m, shape (..., 3)) moved along ``gravity`` onto the support plane: their
        [x, y] there, shape (..., 2)."""
        points = np.asarray(points, dtype=float)
        g = np.asarray(gravity, dtype=float)
        return points[..., :2] - ((points[..., 2] - self.ground) / g[2])[..., None] * g[:2]

    def edges(self) -> tuple[np.ndarray, np.ndarray]:
        """The footprint's edges as outward unit normals n (shape (E, 2)) and offsets d (E,):
        a point x is inside where n·x <= d for every edge."""
        corners = np.asarray(self.footprint, dtype=float)
        along = np.roll(corners, -1, axis=0) - corners
        normals = np.stack([along[:, 1], -along[:, 0]], axis=1)
        normals /= np.linalg.norm(normals, axis=1)[:, None]
        return normals, np.einsum("ij,ij->i", normals, corners)


def _check_base(base: Base | None, info: ValidationInfo) -> Base | None:
    """The bare machine stands: its centre of gravity, along gravity, falls inside the
    footprint."""
    gravity = info.data.get("gravity")
    if base is None or gravity is None:
        return base
    if abs(gravity[2]) <= 1e-9 * max(math.hypot(*gravity), 1e-300):
        raise ValueError(f"gravity {list(gravity)} lies in the footprint's plane (base x-y): "
                         "nothing stands on it")
    normals, offsets = base.edges()
    inside = offsets - normals @ base.project(np.asarray(base.com), np.asarray(gravity))
    if float(inside.min()) <= 0.0:
        raise ValueError(f"com {list(base.com)} falls outside the footprint (by "
                         f"{-float(inside.min()):.4g} m over its edge {int(np.argmin(inside)) + 1}"
                         "): the bare machine tips; expected its centre of gravity inside")
    return base


def _check_supply(supply: Supply | None, info: ValidationInfo) -> Supply | None:
    """Every pinned cylinder draws from the shared supply at its pressure; at least one does."""
    joints = info.data.get("joints")
    if supply is None or joints is None:
        return supply
    pinned = [j for j in joints if hasattr(params_of(j.actuator), "cylinder")]
    if not pinned:
        raise ValueError("no joint has a pinned cylinder (an actuator with a 'cylinder:' "
                         "section) to draw from this supply")
    if supply.ls_margin is not None and supply.displacement == "fixed":
        raise ValueError("displacement: fixed with an ls_margin: a load-sensing pump has a "
                         "variable displacement (a fixed pump with a load-sensing unloading "
                         "valve is not modelled)")
    if supply.ls_margin is not None and not supply.ls_margin < supply.pressure:
        raise ValueError(f"ls_margin {supply.ls_margin:g} Pa is not below the pump's cut-off "
                         f"pressure {supply.pressure:g} Pa")
    for joint in pinned:
        own = params_of(joint.actuator).supply_pressure
        if own != supply.pressure:
            raise ValueError(f"joint {joint.name}'s actuator.supply_pressure {own:g} Pa differs "
                             f"from the shared supply's pressure {supply.pressure:g} Pa")
    return supply


def _check_control(control: ControlSpec | None, info: ValidationInfo) -> ControlSpec | None:
    """A list of per-joint gains has one gain per joint."""
    joints = info.data.get("joints")
    if control is None or joints is None:
        return control
    for name in ("kp", "ki", "kd"):
        gain = getattr(control.pid_only, name)
        if isinstance(gain, tuple) and len(gain) != len(joints):
            raise ValueError(f"pid_only.{name} has {len(gain)} gains for {len(joints)} joints "
                             f"({', '.join(j.name for j in joints)}); give one number for every "
                             "joint or one per joint")
    return control


@validated(kw_only=True)
class ManipulatorSpec:
    """A serial manipulator, base to end-effector, one joint per degree of freedom.

    Attributes:
        name: the arm's name.
        gravity: gravity vector in base axes, m/s², shape (3,).
        joints: the joints in order from the base; MuJoCo's qpos order.
        end_effector: the payload.
        control: the cascade controller's settings, or None for the defaults.
        supply: a pump shared by the pinned cylinders, with a flow limit, or None (each
            cylinder has a supply of its own).
        base: the machine the arm stands on (mass, centre of gravity, footprint), for the
            load chart's tipping, or None.
        source: the file the spec was read from (for messages; not part of the spec's value).
    """

    name: Annotated[str, Strict(), Field(min_length=1)]
    gravity: Vec3 = (0.0, 0.0, -9.81)
    joints: Annotated[tuple[Joint, ...], Field(min_length=1), BeforeValidator(sequence)]
    end_effector: EndEffector = EndEffector()
    control: Annotated[ControlSpec | None, AfterValidator(_check_control)] = None
    supply: Annotated[Supply | None, AfterValidator(_check_supply)] = None
    base: Annotated[Base | None, AfterValidator(_check_base)] = None
    source: str | None = dataclasses.field(default=None, compare=False, repr=False,
                                           metadata={INTERNAL: True})

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
    def from_dict(cls, data: Any, *, source: str | None = None,
                  lines: Mapping[Loc, int] | None = None,
                  defer_plugins: bool = False) -> ManipulatorSpec:
        """Validate plain data (as read from YAML) into a spec, raising a one-line SpecError.

        Args:
            data: the parsed spec (a mapping); joints without a name are named q1..qn.
            source: the file it came from, for messages (kept as ``spec.source``).
            lines: map from data locations to line numbers (``yaml_io.parse_yaml``), for
                messages.
            defer_plugins: keep an actuator whose plugin is not available as an
                :class:`~maniplab.spec.actuator.UnresolvedActuator` instead of failing (for
                stored data, such as a run file's spec, that is read without simulating).
        """
        return _from_dict(data, source, lines or {}, defer_plugins)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (lists, floats, strings) with every default written out; from_dict inverts it."""
        data: dict[str, Any] = plain(dataclasses.asdict(self))
        del data["source"]
        for optional in ("control", "supply", "base"):
            if getattr(self, optional) is None:
                del data[optional]
        for joint, joint_data in zip(self.joints, data["joints"]):
            joint_data["actuator"] = actuator_dict(joint.actuator)
        return data

    def dump(self, path: str | os.PathLike[str]) -> None:
        """Write the spec as YAML to ``path`` (atomically); load_spec reads it back equal."""
        write_text(Path(path), f"# maniplab spec '{self.name}'\n" + dump_yaml(self.to_dict()))

    def with_overrides(self, overrides: Mapping[str, Any]) -> ManipulatorSpec:
        """A copy with fields replaced, addressed by dotted paths.

        Joints are addressed by name or 0-based index: ``{"end_effector.mass": 800.0,
        "joints.q2.actuator.leakage": 1e-11, "joints.0.friction.viscous": 2e4}``.
        Raises SpecError naming the path when it does not exist or the value is invalid.
        """
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


_TOP_KEYS = ("name", "gravity", "joints", "end_effector", "control", "supply", "base")


def _from_dict(data: Any, source: str | None, lines: Mapping[Loc, int],
               defer_plugins: bool) -> ManipulatorSpec:
    if not isinstance(data, dict):
        raise SpecError(f"expected a mapping with keys {', '.join(_TOP_KEYS)}, got {describe(data)}",
                        file=source)
    if "source" in data:  # an internal field, not a key of the file
        raise SpecError(unknown_key_problem("source", _TOP_KEYS), file=source, field="source",
                        line=line_of(lines, ("source",)))
    named = _with_default_names(data)
    _check_duplicate_names(named, data, source, lines)
    try:
        spec = _ADAPTER.validate_python({**named, "source": source},
                                        context={DEFER_PLUGINS: defer_plugins})
    except ValidationError as exc:
        raise translate_errors(exc.errors(), root=ManipulatorSpec, data=named, source=source,
                               lines=lines) from None
    return spec


_ADAPTER: TypeAdapter[ManipulatorSpec] = TypeAdapter(ManipulatorSpec)


def _with_default_names(data: dict[Any, Any]) -> dict[Any, Any]:
    data = {"name": "manipulator", **data}
    joints = data.get("joints")
    if isinstance(joints, list):
        data["joints"] = [
            {"name": f"q{i + 1}", **j} if isinstance(j, dict) else j for i, j in enumerate(joints)
        ]
    return data


def _check_duplicate_names(data: dict[Any, Any], original: dict[Any, Any], source: str | None,
                           lines: Mapping[Loc, int]) -> None:
    """Duplicate joint names (``data`` has default names filled in, ``original`` does not)."""
    joints = data.get("joints")
    if not isinstance(joints, list):
        return
    seen: dict[str, int] = {}
    for i, joint in enumerate(joints):
        name = joint.get("name") if isinstance(joint, dict) else None
        if not isinstance(name, str):
            continue
        if name in seen:
            first = seen[name]
            unnamed = [k + 1 for k in (first, i) if "name" not in original["joints"][k]]
            hint = (f"; joint {unnamed[0]} has no name and defaults to '{name}', so give it one"
                    if unnamed else "")
            raise SpecError(
                f"duplicate joint name '{name}' (joint {first + 1} has it too){hint}; "
                "expected unique joint names",
                file=source, joint=name, field="name", line=line_of(lines, ("joints", i, "name")),
            )
        seen[name] = i
