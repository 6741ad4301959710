"""The Plant: MuJoCo steps the arm, maniplab's friction/limit automaton acts on it, all in C.

One step of length dt (the paper's template plant, its Fig. 5):

1. **prepare** (at t): the commands are clipped and written to ``ctrl``; the friction/limit
   automaton sets the slipping joints' friction and holds the joints that are stuck or on a
   limit; MuJoCo evaluates the dynamics at t (the forward pass of ``mj_step``), and the automaton
   decides the step's modes on them;
2. **advance**: MuJoCo's integrator (RK4 by default) takes the step from that evaluation,
   integrating q, q̇ and every actuator state (the cylinders' and LuGre's engine plugins, Python
   actuators through MuJoCo's callbacks); the automaton handles the step's events (held joints put
   back, stick and limit events); a non-finite value or a state out of its sane range stops the
   run.

Both halves, and whole runs with their recording (:func:`~maniplab.sim.simulate.simulate`), are
the plant in C (``maniplab_native/plant.c``, bound in :mod:`~maniplab.sim.native`): no Python runs
per step unless an actuator or the controller is written in Python, and the GIL is released
while it steps, so plants in several threads run in parallel. This class holds the arm's model
and data, sets and reads the state, and turns the C plant's errors into maniplab's.

All actuator and friction states live in ``d.act`` (ΔP, Q of a cylinder; a plugin's states; LuGre's
z in actuator ``<joint>/lugre``), so ``mj_getState(..., mjSTATE_ACT)``, resets and keyframes include
them (:class:`~.layout.StateLayout` names them). The friction/limit modes are a function of that
state (a held joint has q̇ = 0 exactly and sits on its limit, or has stick/slip friction), so
:meth:`Plant.restore` recomputes them; the next step's start checks them against the forces.
"""

from __future__ import annotations

import contextlib
import copy
import ctypes
import dataclasses
import math
import os
import warnings
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np

from maniplab.actuators import CapabilityError
from maniplab.builtin import resolve_spec
from maniplab.friction import FrictionModel
from maniplab.mjcb import suspended
from maniplab.mjcf_gen import accuracy
from maniplab.mjcf_gen.accuracy import AccurateStep, StepWarning
from maniplab.mjcf_gen.builder import arm_accuracy, arm_step_limit
from maniplab.mjcf_gen.timestep import round_down
from maniplab.sim import native
from maniplab.sim.actuation import Actuation
from maniplab.sim.budget import check_step
from maniplab.sim.callbacks import PluginCallbacks, PythonHooks
from maniplab.sim.energy import EnergyLayout
from maniplab.sim.errors import InputError, InstabilityError, PluginError
from maniplab.sim.layout import StateLayout
from maniplab.sim.plant_model import build_plant_model
from maniplab.sim.state import PlantState
from maniplab.spec import ManipulatorSpec

HOLD_INERTIA = 1e12
"""Held joints get this many times the arm's largest inertia (diagonal of M) as armature."""

MAX_SUBSTEPS = 1000
"""A step that needs more sub-steps than this is refused (the run would take too long)."""

MIN_STEP = 1e-6
"""An arm whose actuators need a shorter step than this, s, is refused (its parameters are
almost surely wrong: a simulated second would take hours)."""

SpecLike = ManipulatorSpec | str | os.PathLike[str]


@dataclasses.dataclass
class StepRecord:
    """What the plant's last step published (a snapshot, :attr:`Plant.record`).

    Attributes:
        t: the time of the prepared step's start, s.
        q, qd: positions and velocities there, (n,).
        act: activations there, (na,).
        u: the clipped commands of the step, (n,).
        mode: the joints' modes over the step (``FrictionMode`` values), (n,).
        fric: the friction force applied over the last advanced step (stiction's holding force
            and LuGre's bristle force at the step's start included, the joint's viscous part
            excluded; a pinned cylinder's rod friction included, its viscous part at the step's
            start), N or N·m, (n,).
        limit: the limit stops' force over the last advanced step, N or N·m, (n,).
    """

    t: float = 0.0
    q: list[float] = dataclasses.field(default_factory=list)
    qd: list[float] = dataclasses.field(default_factory=list)
    act: list[float] = dataclasses.field(default_factory=list)
    u: list[float] = dataclasses.field(default_factory=list)
    mode: list[int] = dataclasses.field(default_factory=list)
    fric: list[float] = dataclasses.field(default_factory=list)
    limit: list[float] = dataclasses.field(default_factory=list)


class Plant:
    """A MuJoCo model of the arm with its actuators, friction and limit automaton.

    Args:
        spec: the arm (a spec, a spec file or a built-in name).
        dt: time step, s: the commands are held and the state recorded per step. Default: the
            step the arm's actuators need (1 ms when they allow it; see
            :mod:`~maniplab.mjcf_gen.timestep`). A step coarser than that is taken in as many
            MuJoCo sub-steps as it needs.
        integrator: MuJoCo integrator name, "RK4" (default), "Euler", "implicit" or "implicitfast".
        accuracy: the step the arm's accuracy allows, when known (a variant of an arm runs at the
            arm's: a sweep's, an identification's); default: measured on this arm (cached).

    Attributes:
        spec: the arm.  dt: s.  n: number of joints.
        step_limit: the largest MuJoCo step the arm's actuators allow, and why.
        substeps: MuJoCo steps per step (dt / substeps is the model's ``opt.timestep``).
        model: the plant's MuJoCo model as compiled, a constant description of the arm (stepping
            uses a private working copy whose held joints' armature changes from step to step).
        data: MuJoCo's data of the plant.
        actuators: the actuator model of each joint.
        layout: where each named state lives in ``data.act``.
        hold_inertia: the armature that holds a stuck joint or one on a limit, kg or kg·m².
        modes: friction/limit mode of each joint (``FrictionMode`` values), int8 (n,).
        tau_fric, tau_limit: friction (incl. stiction's holding force) and limit-stop forces of
            the last step, N or N·m, (n,).
    """

    def __init__(self, spec: SpecLike, *, dt: float | None = None,
                 integrator: str = "RK4", accuracy: AccurateStep | None = None) -> None:
        self.spec = resolve_spec(spec)
        given = check_step(dt) if dt is not None else None
        self.step_limit = arm_step_limit(self.spec)
        if self.step_limit.dt < MIN_STEP:
            where = f" in {self.spec.source}" if self.spec.source else ""
            raise InstabilityError(
                f"{self.step_limit.describe()}, below the {MIN_STEP:g} s a simulation can afford: "
                f"check that actuator's parameters{where} (an oil volume or valve far off?)",
                time=0.0, joint=self.step_limit.joint, dt=dt or self.step_limit.dt, resolved=True)
        self.accuracy = accuracy or arm_accuracy(self.spec)
        """The step the arm's accuracy allows (:mod:`~maniplab.mjcf_gen.accuracy`)."""
        self.dt = given if given is not None else self.accuracy.dt
        ratio = self.dt / self.step_limit.dt * (1.0 - 1e-9)  # inf for a dt of 1e308
        self.substeps = max(1, math.ceil(ratio)) if ratio <= MAX_SUBSTEPS else MAX_SUBSTEPS + 1
        if self.substeps > MAX_SUBSTEPS:
            raise InstabilityError(
                f"{self.step_limit.describe()}: more than {MAX_SUBSTEPS} sub-steps per step",
                time=0.0, joint=self.step_limit.joint, dt=self.dt,
                works=round_down(self.step_limit.dt * MAX_SUBSTEPS))
        _check_accuracy(self.accuracy, given, self.dt / self.substeps, self.spec.source)
        self.integrator = _integrator(integrator)
        self.n = self.spec.n
        self.joint_names = self.spec.joint_names
        self._actuation = Actuation(self.spec)
        self.actuators = self._actuation.models
        self.model = build_plant_model(self.spec, dt=self.dt / self.substeps,
                                       integrator=self.integrator)
        self._actuation.bind(self.model)
        self._model = copy.copy(self.model)  # the working copy that steps
        self.data = mujoco.MjData(self._model)
        lugre = [(j, joint.name) for j, joint in enumerate(self.spec.joints)
                 if joint.friction.model is FrictionModel.lugre]
        self.layout = StateLayout(self.model, self.actuators, lugre)
        self.energy = EnergyLayout(self.model, self.actuators)
        self.state_names = self.layout.names
        self.hold_inertia = HOLD_INERTIA * _largest_inertia(self.model)
        frictions = [j.friction for j in self.spec.joints]
        self.viscous = np.array([f.damping for f in frictions])
        """Viscous friction coefficient of each joint (0 without friction), (n,)."""
        self._lower = [j.limits[0] if j.limits else -math.inf for j in self.spec.joints]
        self._upper = [j.limits[1] if j.limits else math.inf for j in self.spec.joints]
        self._hooks = self._python_hooks()
        self._c = _CPlant(self)
        self._nan = np.full(self.n, np.nan)
        self.reset()

    def native_config(self) -> dict[str, list[Any]]:
        """The C plant's per-joint settings (``ml_plant_config``'s arrays, by field name): joint
        limits (±inf: none), command limits, friction (slip flags, Coulomb, stiction, Stribeck
        and stick velocities), the actuator states' bounds (activation address, bound, joint)
        and the pinned cylinders' rod friction in newtons (flags, Coulomb, stiction, Stribeck,
        viscous and stick velocities; 0 without). A joint slips with the hybrid automaton when
        its own model is hybrid or its rod has Coulomb or static friction (its own friction is
        then 0 unless hybrid). The FMU export writes the same into its C code."""
        joints, act = self.spec.joints, self._actuation
        rods = [j.rod_friction for j in joints]
        own = [j.friction.model is FrictionModel.hybrid or r is None or not r.sticks
               for j, r in zip(joints, rods)]  # whether the joint's own values count

        def rod(field: str) -> list[float]:
            return [0.0 if r is None else float(getattr(r, field)) for r in rods]

        return {
            "lower": list(self._lower), "upper": list(self._upper),
            "command_limit": list(act.limit),
            "slip": [int(j.friction.model is FrictionModel.hybrid or (r is not None and r.sticks))
                     for j, r in zip(joints, rods)],
            "coulomb": [j.friction.coulomb if o else 0.0 for j, o in zip(joints, own)],
            "stiction": [j.friction.static if o else 0.0 for j, o in zip(joints, own)],
            "stribeck": [j.friction.stribeck_velocity for j in joints],
            "stick_velocity": [j.friction.stick_velocity for j in joints],
            "bound_adr": [i for _, i, _ in act.bounds],
            "bound_value": [b for _, _, b in act.bounds],
            "bound_joint": [j for j, _, _ in act.bounds],
            "rod": [int(r is not None and (r.sticks or r.viscous > 0.0)) for r in rods],
            "rod_coulomb": rod("coulomb"), "rod_stiction": rod("static"),
            "rod_stribeck": rod("stribeck_velocity"), "rod_viscous": rod("viscous"),
            "rod_stick_velocity": rod("stick_velocity"),
        }

    @property
    def python_actuators(self) -> list[int]:
        """The joints whose actuator runs Python while the plant steps (MuJoCo's callbacks, or a
        check of its states after every step)."""
        return sorted(set(self._actuation.integrated) | set(self._actuation.unbounded))

    def _python_hooks(self) -> PythonHooks | None:
        """The C plant's hooks into the Python actuators, or None when there are none."""
        act = self._actuation
        entries = [(j, self.actuators[j], j) for j in act.integrated]
        callbacks = PluginCallbacks(self._model, self.data, entries) if entries else None
        check = (lambda: act.first_problem(self.data.act)) if act.unbounded else None
        return PythonHooks(callbacks, check) if callbacks or check else None

    def __repr__(self) -> str:
        return f"Plant({self.spec.name!r}, n={self.n}, dt={self.dt:g})"

    # --- state -------------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulation time, s."""
        return float(self.data.time)

    @property
    def modes(self) -> np.ndarray:
        """Friction/limit mode of each joint (``FrictionMode`` values), int8 (n,) (a copy)."""
        return self._c.modes()

    @property
    def command_limit(self) -> np.ndarray:
        """Each joint's command limit (inf: none), (n,)."""
        return np.array(self._actuation.limit)

    def reset(self) -> None:
        """Back to t = 0, q = q̇ = 0 (clipped to the limits), the actuators' initial states."""
        mujoco.mj_resetData(self._model, self.data)
        self._actuation.reset(self.data)
        self.data.qpos[:] = self._clip(self.data.qpos)
        self._resync()

    def _clip(self, q: np.ndarray) -> list[float]:
        """q moved onto the joint limits where it is beyond them."""
        return [min(max(x, lo), hi) for x, lo, hi in zip(q.tolist(), self._lower, self._upper)]

    def set_state(self, *, q: Any = None, qd: Any = None, t: float | None = None,
                  **states: Any) -> None:
        """Set positions, velocities, time and named states (``dP``, ``Q``, ``z``, plugin states).

        Each value is an array of shape (n,) (NaN entries, and entries of joints without that
        state, are left as they are) or a mapping joint name -> value. Positions beyond a limit
        are put on it. The friction/limit modes are recomputed from the new state.

        Raises:
            InputError: unknown joint or state, wrong shape, non-finite value.
        """
        d = self.data
        if q is not None:
            d.qpos[:] = self._joint_values("q", q, d.qpos)
        if qd is not None:
            d.qvel[:] = self._joint_values("qd", qd, d.qvel)
        if t is not None:
            d.time = _start_time(t)
        for name, value in states.items():
            if name not in self.layout:
                raise InputError(f"no state {name!r} in this plant; expected one of "
                                 f"{', '.join(self.state_names) or 'none'}")
            joints, adrs = self.layout[name]
            full = np.full(self.n, np.nan)
            full[joints] = d.act[adrs]
            d.act[adrs] = self._joint_values(name, value, full)[joints]
        d.qpos[:] = self._clip(d.qpos)
        self._resync()

    def balance_pressures(self) -> None:
        """Set the actuators' states that hold the arm still against gravity at the current pose.

        For each actuator with states that declares how it holds a force
        (:meth:`~maniplab.actuators.ActuatorPlugin.holding`), its states become those that exert
        the gravity force G_j(q) at rest (MuJoCo's ``qfrc_bias`` at q̇ = 0): a cylinder's
        ΔP_j = G_j / A_j with no valve flow. Stateless actuators (a torque source) are left alone.
        """
        d = self.data
        saved = d.qvel.copy()
        d.qvel[:] = 0.0
        with suspended():  # only the bias forces are wanted: no foreign actuator callbacks
            mujoco.mj_forward(self._model, d)
        gravity = d.qfrc_bias.copy()
        d.qvel[:] = saved
        adr = self._model.actuator_actadr
        for j, act in enumerate(self.actuators):
            k = len(act.states)
            if not k:
                continue
            with contextlib.suppress(CapabilityError):  # one that cannot say is left alone
                d.act[adr[j]:adr[j] + k] = act.holding(float(gravity[j]), float(d.qpos[j]))
        self._resync()

    def save(self) -> np.ndarray:
        """The plant's state as ``mj_getState`` gives it: time, q, q̇, act, ctrl and the last
        acceleration (``mjSTATE_FULLPHYSICS | mjSTATE_CTRL | mjSTATE_WARMSTART``)."""
        size = mujoco.mj_stateSize(self._model, _STATE)
        state = np.empty(size)
        mujoco.mj_getState(self._model, self.data, state, _STATE)
        return state

    def restore(self, state: np.ndarray) -> None:
        """Set a state saved by :meth:`save` (an ``mj_getState`` vector of that signature)."""
        mujoco.mj_setState(self._model, self.data, np.asarray(state, dtype=float), _STATE)
        self._resync()

    def _resync(self) -> None:
        """Modes from the state, MuJoCo's warnings cleared."""
        self._c.resync()

    def states(self) -> dict[str, np.ndarray]:
        """Every named state, each shape (n,) with NaN at joints without it."""
        return self.layout.read(self.data.act)

    def state(self) -> PlantState:
        """A snapshot for a controller (copies)."""
        d = self.data
        states = self.states()
        return PlantState(
            t=float(d.time), q=d.qpos.copy(), qd=d.qvel.copy(),
            dP=states["dP"] if "dP" in states else self._nan.copy(),
            Q=states["Q"] if "Q" in states else self._nan.copy(),
            mode=self._c.modes(), states=states, joint_names=self.joint_names,
        )

    def actuator_forces(self) -> np.ndarray:
        """Each actuator's force at the current state and command, N or N·m, (n,)."""
        d = self.data
        return self.actuator_forces_at(d.qpos[None, :], d.qvel[None, :], d.act[None, :],
                                       d.ctrl[None, : self.n])[0]

    def actuator_outputs_at(self, q: np.ndarray, act: np.ndarray) -> dict[str, np.ndarray]:
        """The actuators' derived outputs (:attr:`~maniplab.actuators.ActuatorPlugin.outputs`)
        at N samples: q (N, n), act (N, na) -> name -> (N, n), NaN at joints without it."""
        return self._actuation.outputs(q, act)

    def actuator_forces_at(self, q: np.ndarray, qd: np.ndarray, act: np.ndarray,
                           ctrl: np.ndarray) -> np.ndarray:
        """Each actuator's force at N samples: q, qd, ctrl (N, n), act (N, na) -> (N, n)."""
        return self._actuation.forces(q, qd, act, ctrl)

    # --- commands ----------------------------------------------------------------------------
    def command_vector(self, commands: Any) -> np.ndarray:
        """Commands as an array (n,): from an array-like (n,) or a mapping joint name -> value."""
        return self._joint_values("command", commands, np.zeros(self.n))

    def _joint_values(self, what: str, value: Any, base: np.ndarray) -> np.ndarray:
        """``base`` with the entries ``value`` gives (array (n,), NaN = keep; or a mapping).

        Joints where ``base`` is NaN do not have the quantity; array entries for them are ignored.
        """
        out = np.array(base, dtype=float, copy=True)
        has = ~np.isnan(out)
        if isinstance(value, Mapping):
            for key, item in value.items():
                if key not in self.joint_names:
                    raise InputError(f"{what}: no joint {key!r}; expected one of "
                                     f"{', '.join(self.joint_names)}")
                i = self.joint_names.index(key)
                if not has[i]:
                    raise InputError(f"{what}: joint {key} has no such state")
                out[i] = float(item)
        else:
            arr = np.asarray(value, dtype=float)
            if arr.shape != (self.n,):
                raise InputError(f"{what}: expected shape ({self.n},) or a mapping joint -> "
                                 f"value, got shape {arr.shape}")
            out = np.where(np.isnan(arr) | ~has, out, arr)
        if not np.isfinite(out[has]).all():
            raise InputError(f"{what}: values must be finite, got {out.tolist()}")
        huge = np.flatnonzero(np.abs(out) > mujoco.mjMAXVAL)
        if what in ("q", "qd") and huge.size:
            raise InputError(f"{what}: joint {self.joint_names[huge[0]]}: {out[huge[0]]:g} is "
                             f"beyond MuJoCo's bound on positions and velocities "
                             f"({mujoco.mjMAXVAL:g})")
        return out

    # --- stepping ----------------------------------------------------------------------------
    def step(self, commands: Any = None) -> None:
        """Advance one step of ``dt`` with the commands (array (n,) or mapping), held over it."""
        u = self.command_vector(np.zeros(self.n) if commands is None else commands)
        self.prepare(u.tolist())
        self.advance()

    def prepare(self, u: list[float]) -> None:
        """First half of a step at the current time.

        Clips and writes the commands, sets the friction forces for the step, holds the joints
        that are stuck or on a limit, and evaluates the dynamics at the step's start (MuJoCo's
        forward pass, which :meth:`advance` integrates from); from it the automaton decides the
        modes of the step.

        Args:
            u: commands, one per joint (valve current A, or force N / torque N·m, or a plugin's).

        Raises:
            InputError: a command is NaN or infinite (naming the joint); the step is not taken.
        """
        self.check(self._c.prepare(u))
        self._prepared = True

    def advance(self) -> None:
        """Second half of a step (after :meth:`prepare`): integrate dt.

        Then the automaton's events at the step's end (held joints put back, stick and limit
        events) and the instability checks; as many times as the step has sub-steps (see
        :attr:`substeps`), the commands held.
        """
        if not getattr(self, "_prepared", False):
            raise RuntimeError("Plant.advance() needs a prepare() first")
        self._prepared = False
        self.check(self._c.advance())

    @property
    def record(self) -> StepRecord:
        """What the last step published (the prepared step's start, its command and modes, the
        forces of the last advanced step)."""
        return self._c.record()

    @property
    def tau_fric(self) -> np.ndarray:
        """Friction force on each joint over the last step (stiction's holding force when stuck,
        LuGre's bristle force and the viscous part at the step's start included, and a pinned
        cylinder's rod friction through r(q)), N or N·m, (n,)."""
        r = self.record
        return np.array(r.fric) - self.viscous * np.array(r.qd)

    @property
    def tau_limit(self) -> np.ndarray:
        """Force of the limit stops over the last step (0 off the limits), N or N·m, (n,)."""
        return np.array(self.record.limit)

    def check(self, status: int) -> None:
        """Raise the error a call of the C plant returned (``native.OK``, ``PAUSED``: nothing).

        Raises:
            InputError: a non-finite command (naming the joint), or a run's counts out of range.
            InstabilityError: unstable motion, or a state beyond its bound (naming the joint).
            PluginError: a Python actuator failed.
        """
        if status in (native.OK, native.PAUSED):
            return
        error = self._c.error()
        joint = self.joint_names[error.joint] if 0 <= error.joint < self.n else None
        if status == native.UNSTABLE_MOTION:
            raise InstabilityError(_motion_problem(error.index), time=self.t, joint=joint,
                                   dt=self.dt)
        if status == native.BAD_COMMAND:
            raise InputError(f"joint {joint}: the command at t = {error.time:.6g} s is not a "
                             f"finite number (NaN or infinity)")
        if status == native.BAD_RUN:
            raise InputError("the run's step, duration or recording interval is out of range")
        if status == native.STATE_BOUND:
            text = self._actuation.problem(error.joint, self.data.act, error.index)
            resolved = self._model.opt.timestep <= self.step_limit.dt
            raise InstabilityError(text, time=self.t, joint=joint, dt=self.dt, resolved=resolved)
        if self._hooks is not None and self._hooks.error is not None:
            self._hooks.raise_error()
        raise PluginError(f"the plant stopped at t = {error.time:.6g} s (status {status})")


MAX_TIME = 1e9
"""The largest start time a plant takes, s (about 32 years): beyond it a step of 1 µs would be
lost in the time's rounding."""


def _start_time(t: Any) -> float:
    """A start time, s, checked: finite and within ±:data:`MAX_TIME`."""
    try:
        value = float(t)
    except (TypeError, ValueError):
        raise InputError(f"t must be a number of seconds, got {t!r}") from None
    if not (math.isfinite(value) and abs(value) <= MAX_TIME):
        raise InputError(f"t must be a finite time within ±{MAX_TIME:g} s, got {t!r}")
    return value


def _motion_problem(warning: int) -> str:
    """The message of an unstable motion: a bad value of the kind of MuJoCo's warning ``warning``
    (``mjWARN_BADQPOS``, ``QVEL`` or ``QACC``)."""
    names = {int(getattr(mujoco.mjtWarning, f"mjWARN_BAD{name}")): name
             for name in ("QPOS", "QVEL", "QACC")}
    return f"a NaN, infinite or huge value (> 1e10) in {names.get(warning, 'QVEL')}"


_INT_FIELDS = ("slip", "bound_adr", "bound_joint", "rod")


class _CPlant:
    """The C plant of a :class:`Plant` (``ml_plant``): made, called and freed here."""

    def __init__(self, plant: Plant) -> None:
        self.lib = native.library()
        self.n, self.na = plant.n, plant.model.na
        arrays = plant.native_config()
        keep = {k: native.ints(v) if k in _INT_FIELDS else native.doubles(v)
                for k, v in arrays.items()}
        config = native.Config(n=plant.n, substeps=plant.substeps,
                               hold_inertia=plant.hold_inertia,
                               nbounds=len(arrays["bound_adr"]), **keep)
        self.model, self.data = plant._model, plant.data  # kept alive with the C plant
        self.ptr = self.lib.ml_plant_new(self.model._address, self.data._address,
                                         ctypes.byref(config))
        if not self.ptr:
            raise InputError(f"the plant of {plant.spec.name} could not be made (out of memory?)")
        hooks = plant._hooks
        if hooks is not None:
            self.lib.ml_plant_set_python(self.ptr, hooks.actuator, hooks.check)
        self._u = np.zeros(plant.n)
        self._modes = np.zeros(plant.n, dtype=np.int8)

    def __del__(self) -> None:
        if getattr(self, "ptr", None):
            self.lib.ml_plant_free(self.ptr)
            self.ptr = None

    def resync(self) -> None:
        self.lib.ml_plant_resync(self.ptr)

    def prepare(self, u: list[float]) -> int:
        self._u[:] = u
        self._t = float(self.data.time)
        return int(self.lib.ml_plant_prepare(self.ptr, native.pointer(self._u)))

    def advance(self) -> int:
        return int(self.lib.ml_plant_advance(self.ptr))

    def run(self, run: native.RunStruct) -> int:
        return int(self.lib.ml_plant_run(self.ptr, ctypes.byref(run)))

    def modes(self) -> np.ndarray:
        self.lib.ml_plant_modes(self.ptr, native.pointer(self._modes, ctypes.c_byte))
        return self._modes.copy()

    def error(self) -> native.Error:
        return self.lib.ml_plant_error(self.ptr)

    def record(self) -> StepRecord:
        n, na = self.n, self.na
        arrays = [np.zeros(n), np.zeros(n), np.zeros(na), np.zeros(n), np.zeros(n, np.int8),
                  np.zeros(n), np.zeros(n)]
        ptrs = [native.pointer(a, ctypes.c_byte if a.dtype == np.int8 else ctypes.c_double)
                for a in arrays]
        self.lib.ml_plant_record(self.ptr, *ptrs)
        q, qd, act, u, mode, fric, limit = (a.tolist() for a in arrays)
        return StepRecord(t=getattr(self, "_t", 0.0), q=q, qd=qd, act=act, u=u, mode=mode,
                          fric=fric, limit=limit)


def _largest_inertia(model: mujoco.MjModel) -> float:
    """The largest diagonal entry of M at the model's reference pose (kg, kg·m²), at least 1."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_crb(model, data)
    dense = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, dense)
    return max(1.0, float(np.max(np.diag(dense))))


_STATE = (int(mujoco.mjtState.mjSTATE_FULLPHYSICS) | int(mujoco.mjtState.mjSTATE_CTRL)
          | int(mujoco.mjtState.mjSTATE_WARMSTART))

_INTEGRATORS = {
    "RK4": mujoco.mjtIntegrator.mjINT_RK4,
    "Euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
}


def _integrator(name: str) -> int:
    for key, value in _INTEGRATORS.items():
        if str(name).lower() == key.lower():
            return int(value)
    raise InputError(f"unknown integrator {name!r}; expected RK4, Euler, implicit or implicitfast")


def integrator_name(value: int) -> str:
    """'RK4', 'Euler', 'implicit' or 'implicitfast' for a ``mujoco.mjtIntegrator`` value."""
    return next(k for k, v in _INTEGRATORS.items() if int(v) == int(value))


def _check_accuracy(found: AccurateStep, given: float | None, mujoco_step: float,
                    source: str | None) -> None:
    """Refuse an arm whose accuracy needs a step below what a run can afford (the derived step),
    or warn when a ``given`` step makes MuJoCo's steps (``mujoco_step``, s) coarser than the
    accuracy allows."""
    where = f" in {source}" if source else ""
    if given is None and not found.met:
        raise InstabilityError(
            f"joint {found.joint}'s {found.signal} needs dt <= {found.needs:.2g} s to stay within "
            f"{accuracy.TOLERANCE:g} of its range, below the {accuracy.SMALLEST:g} s a "
            f"simulation can afford: check that actuator's parameters{where} (a tiny oil volume "
            "or a huge valve?), or give dt explicitly to run less accurately", time=0.0,
            joint=found.joint or None, dt=found.dt, resolved=True)
    if given is not None and found.signal and mujoco_step > found.needs * 1.000001:
        warnings.warn(f"dt {mujoco_step:g} s is coarser than the {found.needs:.2g} s that keeps "
                      f"joint {found.joint}'s {found.signal} within {accuracy.TOLERANCE:g} of "
                      "its range", StepWarning, stacklevel=4)
