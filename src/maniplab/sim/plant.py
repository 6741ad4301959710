"""The Plant: MuJoCo steps the arm's rigid body, maniplab's actuators and friction act on it.

One step of length dt (the paper's template plant, its Fig. 5):

1. **prepare** (at t): the commands are clipped and written to ``ctrl``; the actuators' native
   groups set their forces for the coming step (:mod:`~maniplab.sim.actuation`); the
   friction/limit automaton sets the friction forces and holds the joints that are stuck or on a
   limit (:mod:`~maniplab.sim.automaton`). MuJoCo then evaluates the dynamics at t (the forward
   pass of ``mj_step``), and the automaton decides the step's modes on them;
2. **advance**: MuJoCo's integrator (RK4 by default) takes the step from that evaluation,
   integrating q, q̇ and every MuJoCo-integrated state; the automaton handles the step's events
   (held joints put back, stick and limit events); the native groups and LuGre's z advance; a
   non-finite velocity or a state out of its sane range stops the run.

The plant is four parts, each with one job: the state layout (:class:`~.layout.StateLayout`,
where each named state lives in ``d.act``), the actuators (:class:`~.actuation.Actuation`), the
friction/limit automaton (:class:`~.automaton.Automaton`), and what a step publishes for
recording (:class:`StepRecord`, read by ``simulate``'s recorder).

All actuator and friction states live in ``d.act`` (ΔP, Q of a cylinder; a plugin's states; LuGre's
z in actuator ``<joint>/lugre``), so ``mj_getState(..., mjSTATE_ACT)``, resets and keyframes include
them. The friction/limit modes are a function of that state (a held joint has q̇ = 0 exactly and
sits on its limit, or has stick/slip friction), so :meth:`Plant.restore` recomputes them; the next
step's start checks them against the forces.

Routes: on the **native** route (default) the actuators that declare a native group
(the torque source: MuJoCo's motor; the hydraulic cylinder: its split scheme) and LuGre's z are
advanced without MuJoCo callbacks. Other plugins (and every actuator, and LuGre, with
``route="callbacks"``) are integrated by MuJoCo's RK4 itself through ``mjcb_act_dyn`` /
``mjcb_act_bias``, installed only while the plant steps (:mod:`maniplab.sim.callbacks`). On the
erector (6 hydraulic joints, RK4, dt = 1 ms) the native route costs about 4 bare ``mj_step`` per
step, the callback route about 15 (see the benchmarks).
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import math
import os
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np

from maniplab.actuators import CapabilityError
from maniplab.builtin import resolve_spec
from maniplab.friction import FrictionModel
from maniplab.friction.lugre import LuGreBristles
from maniplab.mjcf_gen.builder import arm_step_limit
from maniplab.mjcf_gen.timestep import default_step, round_down
from maniplab.sim import callbacks as _callbacks
from maniplab.sim.actuation import Actuation
from maniplab.sim.automaton import Automaton
from maniplab.sim.errors import InputError, InstabilityError
from maniplab.sim.layout import LUGRE_SUFFIX, StateLayout
from maniplab.sim.plant_model import build_plant_model
from maniplab.sim.state import PlantState
from maniplab.spec import ManipulatorSpec

ROUTES = ("native", "callbacks")

MAX_SUBSTEPS = 1000
"""A step that needs more sub-steps than this is refused (the run would take too long)."""

MIN_STEP = 1e-6
"""An arm whose actuators need a shorter step than this, s, is refused (its parameters are
almost surely wrong: a simulated second would take hours)."""

SpecLike = ManipulatorSpec | str | os.PathLike[str]


@dataclasses.dataclass
class StepRecord:
    """What the plant publishes about its steps, for a recorder (lists, not copies: a recorder
    keeps the references, and the plant makes new lists each step).

    Attributes:
        t: the time of the prepared step's start, s.
        q, qd: positions and velocities there, (n,).
        act: activations there, (na,).
        u: the clipped commands of the step, (n,).
        mode: the joints' modes over the step (``FrictionMode`` values), (n,).
        fric: the friction force applied over the last advanced step (stiction's holding force
            included, viscous part excluded), N or N·m, (n,).
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
        route: "native" (actuators with a native form and LuGre advanced by maniplab between
            MuJoCo's steps, no callbacks; other plugins still use callbacks) or "callbacks" (every
            actuator and LuGre integrated by MuJoCo through its callbacks).

    Attributes:
        spec: the arm.  dt: s.  n: number of joints.
        step_limit: the largest MuJoCo step the arm's actuators allow, and why.
        substeps: MuJoCo steps per step (dt / substeps is the model's ``opt.timestep``).
        model: the plant's MuJoCo model as compiled, a constant description of the arm (stepping
            uses a private working copy whose held joints' armature and cylinders' bias
            parameters change from step to step).
        data: MuJoCo's data of the plant.
        actuators: the actuator model of each joint.
        layout: where each named state lives in ``data.act``.
        record: what the last step published (:class:`StepRecord`).
        modes: friction/limit mode of each joint (``FrictionMode`` values), int8 (n,).
        tau_fric, tau_limit: friction (incl. stiction's holding force) and limit-stop forces of
            the last step, N or N·m, (n,).
    """

    def __init__(self, spec: SpecLike, *, dt: float | None = None, integrator: str = "RK4",
                 route: str = "native") -> None:
        self.spec = resolve_spec(spec)
        if route not in ROUTES:
            raise InputError(f"unknown route {route!r}; expected 'native' or 'callbacks'")
        self.step_limit = arm_step_limit(self.spec, route == "native")
        self.dt = float(dt) if dt is not None else default_step(self.step_limit)
        if not (self.dt > 0.0 and np.isfinite(self.dt)):
            raise InputError(f"dt must be a positive number of seconds, got {dt!r}")
        if self.step_limit.dt < MIN_STEP:
            raise InstabilityError(
                f"{self.step_limit.describe()}, below the {MIN_STEP:g} s a simulation can afford: "
                "check that actuator's parameters (an oil volume or valve far off?)",
                time=0.0, joint=self.step_limit.joint, dt=self.dt, resolved=True)
        self.substeps = max(1, math.ceil(self.dt / self.step_limit.dt * (1.0 - 1e-9)))
        if self.substeps > MAX_SUBSTEPS:
            raise InstabilityError(
                f"{self.step_limit.describe()}: more than {MAX_SUBSTEPS} sub-steps per step",
                time=0.0, joint=self.step_limit.joint, dt=self.dt,
                works=round_down(self.step_limit.dt * MAX_SUBSTEPS))
        step = self.dt / self.substeps
        self.route = route
        self.integrator = _integrator(integrator)
        self._integrate = _INTEGRATE[self.integrator]
        self.n = self.spec.n
        self.joint_names = self.spec.joint_names
        self._actuation = Actuation(self.spec, native_route=route == "native", dt=step,
                                    integrator=self.integrator)
        self.actuators = self._actuation.models
        self.model = build_plant_model(self.spec, dt=step, integrator=self.integrator,
                                       lugre_integrated=route == "callbacks",
                                       configure=self._actuation.configure)
        self._model = copy.copy(self.model)  # the working copy that steps
        self.data = mujoco.MjData(self._model)
        lugre = [(j, joint.name) for j, joint in enumerate(self.spec.joints)
                 if joint.friction.model is FrictionModel.lugre]
        self.layout = StateLayout(self.model, self.actuators, lugre)
        self.state_names = self.layout.names
        self._actuation.bind(self._model, self.data)
        native_bristles = route == "native"
        self._automaton = Automaton(self.spec.joints, self._model, self.data, step,
                                    self.layout.bristles() if native_bristles else {})
        self._callbacks = self._make_callbacks(lugre, not native_bristles)
        d = self.data  # views into the data, cached: each attribute access makes a new array
        self._qpos, self._qvel, self._act = d.qpos, d.qvel, d.act
        self._ctrl = d.ctrl
        self._ctrl_pad = [0.0] * (self.model.nu - self.n)
        self._warnings = [(name, d.warning[int(getattr(mujoco.mjtWarning, f"mjWARN_BAD{name}"))])
                          for name in ("QPOS", "QVEL", "QACC")]
        self._nan = np.full(self.n, np.nan)
        self._no_limit = [0.0] * self.n
        self.record = StepRecord(fric=self._no_limit, limit=self._no_limit)
        self._prepared = False
        self.reset()

    def _make_callbacks(self, lugre: list[tuple[int, str]],
                        bristles: bool) -> _callbacks.PluginCallbacks | None:
        entries: list[tuple[int, _callbacks.Integrated, int]] = [
            (j, self.actuators[j], j) for j in self._actuation.integrated]
        if bristles:
            by_joint = {L.joint: L for L in self._automaton.lugre.joints}
            entries += [(self.model.actuator(name + LUGRE_SUFFIX).id,
                         LuGreBristles(by_joint[j]), j) for j, name in lugre]
        return _callbacks.PluginCallbacks(self._model, self.data, entries) if entries else None

    def __repr__(self) -> str:
        return f"Plant({self.spec.name!r}, n={self.n}, dt={self.dt:g}, route={self.route!r})"

    # --- state -------------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulation time, s."""
        return float(self.data.time)

    @property
    def modes(self) -> np.ndarray:
        """Friction/limit mode of each joint (``FrictionMode`` values), int8 (n,) (a copy)."""
        return np.array(self._automaton.modes, dtype=np.int8)

    @property
    def viscous(self) -> np.ndarray:
        """Viscous friction coefficient of each joint (0 without friction), (n,)."""
        return self._automaton.viscous

    @property
    def command_limit(self) -> np.ndarray:
        """Each joint's command limit (inf: none), (n,)."""
        return np.array(self._actuation.limit)

    def reset(self) -> None:
        """Back to t = 0, q = q̇ = 0 (clipped to the limits), the actuators' initial states."""
        mujoco.mj_resetData(self._model, self.data)
        self._actuation.reset(self.data)
        self.data.qpos[:] = self._automaton.limits.clip(self.data.qpos.tolist())
        self._resync()

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
            d.time = float(t)
        for name, value in states.items():
            if name not in self.layout:
                raise InputError(f"no state {name!r} in this plant; expected one of "
                                 f"{', '.join(self.state_names) or 'none'}")
            joints, adrs = self.layout[name]
            full = np.full(self.n, np.nan)
            full[joints] = d.act[adrs]
            d.act[adrs] = self._joint_values(name, value, full)[joints]
        d.qpos[:] = self._automaton.limits.clip(d.qpos.tolist())
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
        with self.scope():
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
        """Modes from the state; the actuators' between-step memories cleared."""
        self._automaton.resync()
        self._actuation.resync(self.data)
        for _, warning in self._warnings:
            warning.number = 0
        self._prepared = False

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
            mode=np.array(self._automaton.modes), states=states, joint_names=self.joint_names,
        )

    def actuator_forces(self) -> np.ndarray:
        """Each actuator's force at the current state and command, N or N·m, (n,)."""
        d = self.data
        return self.actuator_forces_at(d.qpos[None, :], d.qvel[None, :], d.act[None, :],
                                       d.ctrl[None, : self.n])[0]

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
        return out

    # --- stepping ----------------------------------------------------------------------------
    def scope(self) -> contextlib.AbstractContextManager[None]:
        """Context in which the plant may step: installs its MuJoCo callbacks if it needs any.

        A plant without callback-route actuators installs none, but suspends any that someone
        else installed while it steps (they would see its user actuators). :meth:`step` enters
        the scope by itself; ``simulate`` enters it once around a whole run.
        """
        if self._callbacks is not None:
            return _callbacks.installed(self._callbacks)
        if self.model.na:  # user dynamics: keep anyone else's callbacks away from our states
            return _callbacks.suspended()
        return contextlib.nullcontext()

    def step(self, commands: Any = None) -> None:
        """Advance one step of ``dt`` with the commands (array (n,) or mapping), held over it."""
        u = self.command_vector(np.zeros(self.n) if commands is None else commands)
        with self.scope():
            self.prepare(u.tolist())
            self.advance()

    def prepare(self, u: list[float]) -> None:
        """First half of a step at the current time (call inside :meth:`scope`).

        Clips and writes the commands, sets the actuator and friction forces for the step, holds
        the joints that are stuck or on a limit, and evaluates the dynamics at the step's start
        (MuJoCo's forward pass, which :meth:`advance` integrates from); from it the automaton
        decides the modes of the step.

        Args:
            u: commands, one per joint (valve current A, or force N / torque N·m, or a plugin's).
        """
        self._u = self._actuation.clip(u)
        q0, v0, act = self._start()
        record = self.record
        record.t, record.q, record.qd, record.act = self.data.time, q0, v0, act
        record.u, record.mode = self._u, list(self._automaton.modes)
        self._prepared = True

    def _start(self) -> tuple[list[float], list[float], list[float]]:
        """The start of one MuJoCo step: forces, holds, the forward pass, the automaton's
        decisions. Returns the step's (q0, v0, act0)."""
        u = self._u
        q0, v0, act = self._qpos.tolist(), self._qvel.tolist(), self._act.tolist()
        ctrl = u + self._ctrl_pad
        self._actuation.prepare(q0, act, u, ctrl)
        self._ctrl[:] = ctrl
        automaton = self._automaton
        fric = automaton.forces(v0, act)
        automaton.hold()
        m, d = self._model, self.data
        mujoco.mj_checkPos(m, d)  # what mj_step does before its forward pass
        mujoco.mj_checkVel(m, d)
        mujoco.mj_forward(m, d)
        if automaton.active:
            fric = automaton.settle(v0, act, fric)
        mujoco.mj_checkAcc(m, d)
        self._step = (q0, v0, act, fric)
        return q0, v0, act

    def advance(self) -> None:
        """Second half of a step (after :meth:`prepare`, inside :meth:`scope`): integrate dt.

        Then the automaton's events at the step's end (held joints put back, stick and limit
        events), the native groups' and LuGre's states, and the instability checks; as many times
        as the step has sub-steps (see :attr:`substeps`), the commands held.
        """
        if not self._prepared:
            raise RuntimeError("Plant.advance() needs a prepare() first")
        self._prepared = False
        self._finish()
        for _ in range(self.substeps - 1):
            self._start()
            self._finish()

    def _finish(self) -> None:
        """The end of one MuJoCo step: integrate, the automaton's events, the actuators."""
        self._integrate(self._model, self.data)
        q0, v0, act0, fric = self._step
        q1, v1 = self._qpos.tolist(), self._qvel.tolist()
        moved, limit = self._automaton.finish(q0, v0, q1, v1, fric)
        if moved:
            self._qpos[:] = q1
            self._qvel[:] = v1
        if not math.isfinite(math.fsum(v1)) or any(w.number for _, w in self._warnings):
            self._unstable_motion()
        self.record.fric, self.record.limit = fric, limit or self._no_limit
        act = self._act.tolist()
        problem = self._actuation.finish(q0, q1, act0, self._u, act)
        self._automaton.advance_bristles(q0, q1, act0, act)
        self._act[:] = act
        if problem is not None:
            resolved = self._model.opt.timestep <= self.step_limit.dt
            raise InstabilityError(problem[1], time=self.t, joint=self.joint_names[problem[0]],
                                   dt=self.dt, resolved=resolved)

    @property
    def tau_fric(self) -> np.ndarray:
        """Friction force on each joint over the last step (stiction's holding force when stuck,
        viscous part at the step's start included), N or N·m, (n,)."""
        return np.array(self.record.fric) - self.viscous * np.array(self.record.qd or self._nan)

    @property
    def tau_limit(self) -> np.ndarray:
        """Force of the limit stops over the last step (0 off the limits), N or N·m, (n,)."""
        return np.array(self.record.limit)

    def _unstable_motion(self) -> None:
        for name, warning in self._warnings:
            if warning.number:
                joint = self.joint_names[warning.lastinfo] if warning.lastinfo < self.n else None
                raise InstabilityError(
                    f"MuJoCo warned of a NaN, infinite or huge value (> 1e10) in {name}",
                    time=self.t, joint=joint, dt=self.dt)
        bad = np.flatnonzero(~np.isfinite(self.data.qvel) | ~np.isfinite(self.data.qpos))
        joint = self.joint_names[bad[0]] if bad.size else None
        raise InstabilityError("the joint velocity is not finite (NaN or infinity)",
                               time=self.t, joint=joint, dt=self.dt)


_STATE = (int(mujoco.mjtState.mjSTATE_FULLPHYSICS) | int(mujoco.mjtState.mjSTATE_CTRL)
          | int(mujoco.mjtState.mjSTATE_WARMSTART))

_INTEGRATORS = {
    "RK4": mujoco.mjtIntegrator.mjINT_RK4,
    "Euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
}

_INTEGRATE = {  # what mj_step does after its forward pass, which Plant.prepare makes
    int(mujoco.mjtIntegrator.mjINT_RK4): lambda m, d: mujoco.mj_RungeKutta(m, d, 4),
    int(mujoco.mjtIntegrator.mjINT_EULER): mujoco.mj_Euler,
    int(mujoco.mjtIntegrator.mjINT_IMPLICIT): mujoco.mj_implicit,
    int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST): mujoco.mj_implicit,
}


def _integrator(name: str) -> int:
    for key, value in _INTEGRATORS.items():
        if str(name).lower() == key.lower():
            return int(value)
    raise InputError(f"unknown integrator {name!r}; expected RK4, Euler, implicit or implicitfast")


def integrator_name(value: int) -> str:
    """'RK4', 'Euler', 'implicit' or 'implicitfast' for a ``mujoco.mjtIntegrator`` value."""
    return next(k for k, v in _INTEGRATORS.items() if int(v) == int(value))
