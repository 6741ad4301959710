"""The actuator interface: one model per joint, and the capabilities it declares.

Every joint actuator is an :class:`ActuatorPlugin`: the built-in torque source
(:mod:`~maniplab.actuators.torque`) and hydraulic cylinder (:mod:`~maniplab.actuators.hydraulic`)
as much as a model a user writes in their own module. A spec names one by its ``type``::

    actuator: {type: torque}                                   # built-in
    actuator: {type: "mypkg.motors:GearedDCMotor", resistance: 1.2, ...}   # module:Class
    actuator: {type: dcmotor, resistance: 1.2, ...}            # registered name (entry point)

(see :mod:`~maniplab.actuators.registry`). The plugin's parameters (the actuator's keys besides
``type``) are validated by its ``Params`` dataclass like the rest of the spec, and a bad value
raises SpecError naming the file, the joint and the field.

What an actuator declares, and who uses it:

=========================  ====================================================================
capability                 used by
=========================  ====================================================================
states, state_units        the plant's state layout (MuJoCo activations), the Run's signals
command, command_unit,     the plant's command clipping, the Run's signals, controllers'
command_limit              saturation checks
derivatives, force         the plant (MuJoCo integrates the states through its callbacks),
                           the linearisation
mujoco_plugin              a MuJoCo engine plugin (C) that models the actuator inside MuJoCo:
                           the plant and every MuJoCo tool integrate it with no Python per
                           step (the hydraulic cylinder's ``maniplab.hydraulic``);
                           ``runs_in_mujoco`` tells sweeps they may run it in threads
configure_mjcf, mount      how the exported MJCF declares the actuator and what it acts
                           through (the joint, or a tendon between a cylinder's pins)
check_joint                whether the parameters fit the joint (a cylinder's pins and stroke)
steady, holding            operating points (the state and command that hold a force), the
                           plant's start "held against gravity", the default drive
holding_range              load charts (the largest payload held at each pose)
drive                      how a controller makes the joint exert a desired force (the
                           cascade's force-to-command inversion); the default inverts
                           ``steady``; an actuator without ``steady`` cannot be driven
top_speed                  the controller's weighting of the joints, the PID baseline's limits
stiffness, rates, decays,  the step size the arm needs, the controller's default gains
lag
bounds                     the health verdict of a run (e.g. pressures beyond supply)
check_state, state_limits  the plant's instability check after every step (limits: a cheap
                           comparison, check_state only for the message)
outputs, output_values     signals derived from the states that a Run records too (a pinned
                           cylinder's stroke and force)
describe, details          ``maniplab info`` (a row of the joints' table, lines below it)
=========================  ====================================================================
"""

from __future__ import annotations

import abc
import dataclasses
import keyword
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, ClassVar, NamedTuple

import mujoco
import numpy as np

from maniplab.actuators.drive import ForceDrive, StaticDrive
from maniplab.errors import ManiplabError
from maniplab.schema import validated

if TYPE_CHECKING:
    from maniplab.actuators.plugin_mjcf import EnginePlugin
    from maniplab.spec import ControlSpec, Joint

RESERVED_STATE_NAMES = frozenset(
    {"t", "q", "qd", "qdd", "tau_act", "tau_fric", "tau_limit", "ctrl", "mode", "ee_pos", "z"}
)
"""Signal names of a Run that a plugin state or command may not take."""

STANDARD_STATES = ("dP", "Q")
"""States every Run and operating point carries (NaN at joints without them), so that the
results of any two arms compare: the pressure and flow of maniplab's hydraulic cylinders."""

STANDARD_COMMANDS = ("iv",)
"""Commands every Run carries as signals (NaN at joints commanded otherwise): valve currents."""

FD_STEP = 1e-6
"""Relative step of the central differences in :meth:`ActuatorPlugin.jacobians`."""


class CapabilityError(ManiplabError):
    """An actuator was asked for something it does not declare (e.g. a controller's drive)."""


class Bound(NamedTuple):
    """A bound a state keeps in a healthy run: ``|x| <= limit``.

    Attributes:
        state: the state's name.
        limit: its largest healthy magnitude.
        name: what the bound is ("supply pressure").
        hard: a physical cap (a relief valve) that the model enforces: crossing it means the run
            is wrong, not only the design.
    """

    state: str
    limit: float
    name: str
    hard: bool = False


class JointFrame(NamedTuple):
    """What an actuator's parameters are checked against: its joint's kind, axis and limits.

    Attributes:
        prismatic: a sliding joint.
        axis: unit axis in base coordinates, (3,).
        limits: (lower, upper) in rad or m, or None.
    """

    prismatic: bool
    axis: np.ndarray
    limits: tuple[float, float] | None


class ParameterProblem(ValueError):
    """Parameters that do not fit their joint: ``field`` (below ``actuator``) and the message."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(message)
        self.field = field


@dataclasses.dataclass(frozen=True)
class Mount:
    """Where an actuator sits in the arm's MuJoCo model (:meth:`ActuatorPlugin.mount`).

    Attributes:
        spec: the model being built.
        parent: the body before the joint.
        child: the body the joint moves (its origin is the joint's).
        origin: the joint's origin in ``parent``'s frame, m, (3,) (every body keeps the base
            axes, so vectors in base axes at q = 0 need no rotation).
    """

    spec: mujoco.MjSpec
    parent: mujoco.MjsBody
    child: mujoco.MjsBody
    origin: np.ndarray


class Steady(NamedTuple):
    """A steady operating point of one actuator: its states (k,) and its command."""

    x: np.ndarray
    u: float


@dataclasses.dataclass(frozen=True)
class Jacobians:
    """Partial derivatives of an actuator's model at one point (k states).

    Attributes:
        dxdot_dx: ∂ẋ/∂x, (k, k).  dxdot_du, dxdot_dq, dxdot_dv: (k,).
        df_dx: ∂f/∂x, (k,).  df_du, df_dq, df_dv: scalars.
    """

    dxdot_dx: np.ndarray
    dxdot_du: np.ndarray
    dxdot_dq: np.ndarray
    dxdot_dv: np.ndarray
    df_dx: np.ndarray
    df_du: float
    df_dq: float
    df_dv: float


def parameters(cls: type) -> type:
    """Decorator for a plugin's ``Params``: a frozen dataclass validated like the spec.

    Unknown keys, wrong types, NaN and infinities are rejected; use the schema's annotated types
    (``maniplab.schema.Positive``, ``NonNegative``, ``Real``) for range checks::

        @parameters
        class MotorParams:
            resistance: Positive        # Ω
            inductance: Positive        # H
    """
    return validated(cls)


class ActuatorPlugin(abc.ABC):
    """One actuator model on one joint: states x, command u, force f.

    The model is ``ẋ = derivatives(x, u, q, v)`` and the joint force (N on a prismatic joint, N·m
    on a rotational one) is ``force(x, u, q, v)``, with q and v the joint's position and velocity.
    The command u is clipped to ±``command_limit`` before either is called.

    Subclasses set the class attributes and implement :meth:`force` (and :meth:`derivatives` when
    they have states); the other capabilities are optional (see the module's table). An instance
    is made per joint with the validated parameters.

    Class attributes:
        Params: the parameter dataclass (decorate it with :func:`parameters`).
        states: names of the states in order, e.g. ``("current",)``; each becomes a signal of
            the Run (NaN at joints without it). Empty for a stateless actuator.
        state_units: unit of each state, for plots (same length as ``states``).
        command: name of the command, e.g. "iv" (valve current) or "voltage"; it becomes a
            signal of the Run too (the commands of the joints driven this way).
        command_unit: unit of the command.
        spring_name: what :meth:`stiffness` is, in messages ("oil spring").
        outputs: signals derived from the states (name -> unit) that a Run records besides
            them (NaN at joints without them); :meth:`output_values` computes them.
        energy: how a run accounts the actuator's hydraulic energy: "plugin" (its engine
            plugin keeps the terms of :mod:`maniplab.sim.energy`), "unaccounted" (hydraulic,
            not accounted), None (no hydraulic energy).
        lines: the hydraulic lines a run's hose-burst scenario can open (``("a", "b")`` for
            a two-chamber cylinder's; :mod:`maniplab.sim.bursts`); empty for none.
        passive: True for a joint without an actuator (it swings freely): controllers leave
            it alone and control the point it hangs from.
        variants: other models under the same ``type``, chosen by a key of the section.
        variant_key: the key that chooses this model among its type's variants (``cylinder``
            makes a ``hydraulic`` actuator the pinned two-chamber cylinder).

    Args:
        params: an instance of ``Params``.
        joint: the joint the actuator drives (its name, type and limits are there).
    """

    Params: ClassVar[type]
    variants: ClassVar[tuple[type[ActuatorPlugin], ...]] = ()
    variant_key: ClassVar[str | None] = None
    states: ClassVar[tuple[str, ...]] = ()
    state_units: ClassVar[tuple[str, ...]] = ()
    command: ClassVar[str] = "u"
    command_unit: ClassVar[str] = ""
    spring_name: ClassVar[str] = "actuator spring"
    outputs: ClassVar[dict[str, str]] = {}
    energy: ClassVar[str | None] = None
    lines: ClassVar[tuple[str, ...]] = ()
    passive: ClassVar[bool] = False

    def __init__(self, params: Any, joint: Joint) -> None:
        self.params = params
        self.joint = joint

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        for name, what in (*((s, "state") for s in cls.states), (cls.command, "command")):
            if not name.isidentifier() or keyword.iskeyword(name) or name in RESERVED_STATE_NAMES:
                raise TypeError(
                    f"{cls.__qualname__}: {name!r} is not a valid {what} name; expected an "
                    f"identifier other than {', '.join(sorted(RESERVED_STATE_NAMES))}"
                )
        if cls.command in cls.states:
            raise TypeError(f"{cls.__qualname__}: the command {cls.command!r} is also a state")
        if cls.states and cls.derivatives is ActuatorPlugin.derivatives:
            raise TypeError(f"{cls.__qualname__} has states {cls.states} but no derivatives()")

    @classmethod
    def variant(cls, keys: Any = (), params: Any = None) -> type[ActuatorPlugin]:
        """The model of this type for a section with these keys, or for these validated
        parameters: the variant whose ``variant_key`` is among the keys (or whose ``Params``
        the parameters are), else this class."""
        for other in cls.variants:
            if other.variant_key in keys or type(params) is other.Params:
                return other
        return cls

    @classmethod
    def check_joint(cls, params: Any, joint: JointFrame) -> None:
        """Whether the validated parameters fit the joint (nothing to check by default).

        Raises:
            ParameterProblem: naming the field below ``actuator`` that does not fit.
        """

    # --- the model ------------------------------------------------------------------------------
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

    def forces(self, x: np.ndarray, u: np.ndarray, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """:meth:`force` at N samples: x (N, k), u, q, v (N,) -> (N,). Override to vectorise."""
        return np.array([self.force(xi, float(ui), float(qi), float(vi))
                         for xi, ui, qi, vi in zip(x, u, q, v)])

    @property
    def lag(self) -> float:
        """The time constant between a command and its effect on the force, s (a valve's lag;
        0 for an ideal source): a controller's force loop must be slower."""
        return 0.0

    def stiffness(self, q: float) -> float:
        """The spring rate of the actuator's states against the joint's motion at q (N/m or
        N·m/rad; 0 for none): with the arm's inertia it sets the actuators' natural frequencies,
        which the step size and the controller's gains follow."""
        return 0.0

    def rates(self, native: bool = False) -> dict[str, float]:
        """The rates of the actuator's own dynamics, 1/s, by what they are (e.g. a valve's lag
        1/τ), that the step must resolve: all of them when MuJoCo integrates the states through
        the callbacks, or (``native``, an actuator with an engine plugin) those the plugin does not
        advance exactly (the hydraulic plugin takes its relief valve's stiff regime exactly)."""
        return {}

    def decays(self, native: bool = False) -> dict[str, float]:
        """Stiff decay rates of the actuator's states, 1/s, by what they are (a chamber filling
        through a wide-open orifice): the step must keep them stable, not resolve them (RK4 is
        stable to λ dt = 2.78). ``native`` as for :meth:`rates`."""
        return {}

    def bounds(self) -> list[Bound]:
        """The bounds the states keep in a healthy run (a run's health verdict checks them)."""
        return []

    def check_state(self, x: np.ndarray) -> str | None:
        """None, or what is wrong when the states (k,) left the range a stable run keeps them in
        (the plant stops the run with InstabilityError naming the joint)."""
        return None

    def state_limits(self) -> tuple[float, ...] | None:
        """The largest |x| of each state in a stable run (inf: any finite value), or None.

        With limits, the plant compares the states with them after every step (a NaN fails too)
        and calls :meth:`check_state` only for the message once one is beyond; without (the
        default), it calls :meth:`check_state` after every step, which costs a Python call per
        actuator per step.
        """
        return None

    # --- optional capabilities ------------------------------------------------------------------
    def steady(self, force: float, q: float, v: float) -> Steady:
        """The states and command that make the actuator exert ``force`` steadily at (q, v).

        Raises:
            CapabilityError: the actuator does not declare it (the default).
        """
        raise CapabilityError(f"{self.label()} declares no steady state (ActuatorPlugin.steady)")

    def holding(self, force: float, q: float) -> np.ndarray:
        """The states (k,) of an actuator that exerts ``force`` on a joint at rest at q, as a run
        starts "held against gravity" (the default: the steady state's)."""
        return self.steady(force, q, 0.0).x

    def holding_range(self, q: float) -> tuple[float, float]:
        """The forces (N or N·m) the actuator can hold the joint at rest against at q, as
        (lowest, highest): what a load chart counts on (inf: no bound).

        Raises:
            CapabilityError: the actuator does not declare it (the default).
        """
        raise CapabilityError(f"{self.label()} declares no holding range "
                              "(ActuatorPlugin.holding_range), so no load chart counts on it")

    def rated_holding_range(self, q: float, pressure: float) -> tuple[float, float]:
        """:meth:`holding_range` with a hydraulic actuator's chambers up to a working pressure
        rating ``pressure`` (Pa) instead of its relief's setting; an actuator that is not
        hydraulic has no pressure to rate, and gives its holding range (the default)."""
        return self.holding_range(q)

    @classmethod
    def has_steady(cls) -> bool:
        """Whether the class implements :meth:`steady`."""
        return cls.steady is not ActuatorPlugin.steady

    @property
    def top_speed(self) -> float:
        """The joint speed at full command with no load, rad/s or m/s (inf: not limited)."""
        return math.inf

    @classmethod
    def drive(cls, actuators: Sequence[ActuatorPlugin], joints: Sequence[int], *, dt: float,
              settings: ControlSpec) -> ForceDrive:
        """How a controller makes these joints (all with an actuator of this class) exert forces.

        The default inverts :meth:`steady` at each sample (:class:`StaticDrive`).

        Args:
            actuators: the actuators, one per joint.
            joints: their joint indices in the arm.
            dt: the controller's sample time, s.
            settings: the controller's settings (the spec's ``control:`` section).

        Raises:
            CapabilityError: the class has neither ``steady`` nor its own ``drive``.
        """
        if not cls.has_steady():
            names = ", ".join(a.joint.name for a in actuators)
            raise CapabilityError(
                f"joint {names}: actuator {actuators[0].type_name()} cannot be driven by a force "
                "controller: it declares neither steady() (the command that holds a force) nor "
                "its own drive()"
            )
        return StaticDrive(actuators, joints, dt=dt, settings=settings)

    def jacobians(self, x: np.ndarray, u: float, q: float, v: float) -> Jacobians:
        """Partial derivatives of :meth:`derivatives` and :meth:`force` at (x, u, q, v).

        The default takes central differences (relative step :data:`FD_STEP`); override with
        exact ones where the model has them.
        """
        x = np.asarray(x, dtype=float)
        k = len(x)
        point = np.concatenate([x, [u, q, v]])

        def both(p: np.ndarray) -> np.ndarray:
            xs, (uu, qq, vv) = p[:k], p[k:]
            return np.concatenate([self.derivatives(xs, uu, qq, vv), [self.force(xs, uu, qq, vv)]])

        columns = []
        for i in range(k + 3):
            h = FD_STEP * max(1.0, abs(point[i]))
            e = np.zeros(k + 3)
            e[i] = h
            columns.append((both(point + e) - both(point - e)) / (2.0 * h))
        J = np.array(columns).T  # (k + 1, k + 3)
        return Jacobians(J[:k, :k], J[:k, k], J[:k, k + 1], J[:k, k + 2], J[k, :k],
                         float(J[k, k]), float(J[k, k + 1]), float(J[k, k + 2]))

    def runs_in_mujoco(self) -> bool:
        """Whether MuJoCo computes the actuator by itself, with no Python per step: it has an
        engine plugin, or declares itself in :meth:`configure_mjcf` otherwise than the default
        (which makes it a ``user`` actuator that the plant's callbacks compute in Python)."""
        return (self.mujoco_plugin() is not None
                or type(self).configure_mjcf is not ActuatorPlugin.configure_mjcf)

    def mujoco_plugin(self) -> EnginePlugin | None:
        """The MuJoCo engine plugin (C code registered with MuJoCo) that models this actuator
        inside MuJoCo, or None (the default: MuJoCo's own actuator as :meth:`configure_mjcf`
        declares it, or the plant's callbacks).

        With a plugin, the actuator in the arm's model (and the exported MJCF) is an instance of
        it with these parameters: MuJoCo's integrator advances its states in the plant and in
        every MuJoCo tool, with no Python per step. :meth:`configure_mjcf` is then applied first,
        for what the plugin does not set (the command range).
        """
        return None

    def configure_mjcf(self, act: mujoco.MjsActuator) -> None:
        """Declare the actuator in the MuJoCo model of the arm (the exported MJCF).

        The default is inert in a plain MuJoCo tool: one ``user`` activation per state, zero
        gain and a ``user`` bias (without the plant's callbacks MuJoCo leaves the states as they
        are and applies no force); the command range is ±command_limit.
        """
        k = len(self.states)
        if k:
            act.dyntype = mujoco.mjtDyn.mjDYN_USER
            act.actdim = k
            act.actlimited = mujoco.mjtLimited.mjLIMITED_FALSE
        act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
        act.gainprm = [0.0] * 10
        act.biastype = mujoco.mjtBias.mjBIAS_USER
        set_command_range(act, self.command_limit)

    def output_values(self, x: np.ndarray, q: np.ndarray) -> dict[str, np.ndarray]:
        """The :attr:`outputs` at N samples of the states x (N, k) and joint positions q (N,),
        each (N,)."""
        return {}

    def mount(self, act: mujoco.MjsActuator, mount: Mount) -> None:
        """What the actuator acts through in the MuJoCo model: the default is its joint (as
        ``act`` is made); a pinned cylinder adds its pins and a tendon between them."""

    def describe(self) -> str:
        """One line for tables (``maniplab info``): the type and its main parameters."""
        return self.type_name()

    def details(self) -> list[str]:
        """Lines ``maniplab info`` prints below the joints' table (none by default)."""
        return []

    # --- naming ---------------------------------------------------------------------------------
    def type_name(self) -> str:
        """The actuator's ``type`` as the spec gives it (``hydraulic``, ``mypkg:Motor``)."""
        return str(getattr(self.joint.actuator, "type", type(self).__qualname__))

    def label(self) -> str:
        """``actuator <type> of joint <name>``, for messages."""
        return f"actuator {self.type_name()} of joint {self.joint.name}"

    def __repr__(self) -> str:
        return f"{type(self).__name__}(joint={self.joint.name!r})"


def set_command_range(act: mujoco.MjsActuator, limit: float | None) -> None:
    """``ctrlrange`` ±limit, or no range."""
    if limit is None:
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
    else:
        act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.ctrlrange = [-limit, limit]
