"""The Plant: MuJoCo steps the arm's rigid body, maniplab's actuators and friction act on it.

One step of length dt (the paper's template plant, its Fig. 5):

1. **prepare** (at t): the commands are clipped and written to ``ctrl``; native hydraulic
   actuators get the affine force ``b0 - k q`` of the coming step and their flow ramp (see
   :mod:`~maniplab.sim.plant_model`); slipping joints get their Coulomb/Stribeck friction and
   LuGre joints their bristle force (held over the step, in ``qfrc_applied``); the held joints
   (STICK, AT_LOWER, AT_UPPER) are made immovable for MuJoCo (:meth:`Plant._arm`). MuJoCo then
   evaluates the dynamics at t (the forward pass of ``mj_step``), which gives every held joint's
   holding force and every free joint's acceleration at that instant, and the automaton decides
   the step's modes on them (:meth:`Plant._settle`): break-aways and releases from stops
   (:mod:`~maniplab.actuators.automaton`), slipping joints that stop within the step; after any
   change the new held set is evaluated again, until the modes agree with the forces.
2. **advance**: MuJoCo's integrator (RK4 by default) takes the step from that evaluation,
   integrating q, q̇ and every MuJoCo-integrated state (plugin states on the callback route): the
   free joints move with the constrained dynamics of the held set (the paper's eq. 8) and the
   holding forces over the step come out of it; held joints are put back exactly (q, q̇ = 0);
   slipping joints that reversed or slowed below ``stick_velocity`` stick (velocity reset to 0);
   joints past a limit are put on it with zero velocity; the native hydraulic states and LuGre's
   z are advanced with the step's exact displacement; a non-finite velocity or a pressure beyond
   10 Ps stops the run.

Holding is exact, not a stiff spring: a held joint gets an armature of 1e12 times the arm's
largest inertia, so MuJoCo's own factorisation of M solves the constrained dynamics (the free
joints' accelerations M_FF⁻¹(τ_F - b_F) to ~1e-12 relative) in every RK4 stage, and the force that
holds the joint is read back as -I q̈ (at t, for the automaton) and -I Δq̇ / dt (over the step, for
the record). That costs nothing beyond the step itself: the evaluation at t is the forward pass
``mj_step`` makes anyway, split off (``mj_forward`` + ``mj_RungeKutta``); only a step with a
transition evaluates again. Mode changes take effect at step boundaries; events inside a step
are put on the nearer boundary where the step's start predicts them (a velocity reaching zero
or ``stick_velocity``), else on its end.

All actuator and friction states live in ``d.act`` (ΔP, Q of a cylinder; a plugin's states; LuGre's
z in actuator ``<joint>/lugre``), so ``mj_getState(..., mjSTATE_ACT)``, resets and keyframes include
them (the cylinders' flow ramps, actuators ``<joint>/flow``, are zero between steps). The
friction/limit modes are a function of that state (a held joint has q̇ = 0 exactly and sits on its
limit, or has stick/slip friction), so :meth:`Plant.restore` recomputes them; the next step's
start checks them against the forces.

Routes: on the **native** route (default) the torque source is MuJoCo's motor, the hydraulic
cylinders are advanced by :class:`~maniplab.actuators.hydraulic.HydraulicBank` and LuGre's z by
an exact exponential update; no MuJoCo callback is used. Plugin actuators (and every actuator, and
LuGre, with ``route="callbacks"``) are integrated by MuJoCo's RK4 itself through
``mjcb_act_dyn``/``mjcb_act_bias``, installed only while the plant steps
(:mod:`maniplab.sim.callbacks`). On the erector (6 hydraulic joints, RK4, dt = 1 ms) the native
route costs about 4 bare ``mj_step`` per step, the callback route about 15 (README).

The per-step work is plain Python over the joints' numbers: for the few joints of an arm that is
several times faster than numpy, whose cost per call (~0.5 µs) exceeds the arithmetic.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np

from maniplab.actuators.automaton import transitions
from maniplab.actuators.friction import HybridFriction, slip_force
from maniplab.actuators.hydraulic import PRESSURE_LIMIT, HydraulicBank, HydraulicCylinder
from maniplab.actuators.limits import JointLimits
from maniplab.actuators.lugre import LuGreBristles, LuGreFriction
from maniplab.actuators.modes import FrictionMode
from maniplab.actuators.plugin import ActuatorPlugin, plugin_of
from maniplab.actuators.torque import TorqueSource
from maniplab.builtin import resolve_spec
from maniplab.mjcf_gen.builder import TIMESTEP
from maniplab.sim import callbacks as _callbacks
from maniplab.sim.errors import InputError, InstabilityError
from maniplab.sim.plant_model import LUGRE_SUFFIX, build_plant_model
from maniplab.sim.state import PlantState
from maniplab.spec import FrictionModel, ManipulatorSpec

ROUTES = ("native", "callbacks")

HOLD_INERTIA = 1e12
"""Held joints get this many times the arm's largest inertia (diagonal of M) as armature."""
_SLIP = FrictionMode.SLIP.value
_STICK = FrictionMode.STICK.value
_LOWER = FrictionMode.AT_LOWER.value
_UPPER = FrictionMode.AT_UPPER.value

SpecLike = ManipulatorSpec | str | os.PathLike[str]


class Plant:
    """A MuJoCo model of the arm with its actuators, friction and limit automaton.

    Args:
        spec: the arm (a spec, a spec file or a built-in name).
        dt: time step, s (default 1e-3: see the README's accuracy figures).
        integrator: MuJoCo integrator name, "RK4" (default), "Euler", "implicit" or "implicitfast".
        route: "native" (built-in actuators and LuGre advanced by maniplab between MuJoCo's
            steps, no callbacks; plugins still use callbacks) or "callbacks" (every actuator
            and LuGre integrated by MuJoCo through its callbacks).

    Attributes:
        spec: the arm.  model, data: MuJoCo's.  dt: s.  n: number of joints.
        actuators: the actuator model of each joint.
        modes: friction/limit mode of each joint (``FrictionMode`` values), int8 (n,).
        tau_fric, tau_limit: friction (incl. stiction's holding force) and limit-stop forces of
            the last step, N or N·m, (n,).
        state_layout: state name -> (joint indices, activation addresses) in ``data.act``.
    """

    def __init__(self, spec: SpecLike, *, dt: float | None = None, integrator: str = "RK4",
                 route: str = "native") -> None:
        self.spec = resolve_spec(spec)
        self.dt = float(dt) if dt is not None else TIMESTEP
        if not (self.dt > 0.0 and np.isfinite(self.dt)):
            raise InputError(f"dt must be a positive number of seconds, got {dt!r}")
        if route not in ROUTES:
            raise InputError(f"unknown route {route!r}; expected 'native' or 'callbacks'")
        self.route = route
        self.integrator = _integrator(integrator)
        self._integrate = _INTEGRATE[self.integrator]
        self.n = self.spec.n
        self.joint_names = self.spec.joint_names
        self.actuators: list[ActuatorPlugin] = [plugin_of(j) for j in self.spec.joints]
        native = [route == "native" and type(a) in (TorqueSource, HydraulicCylinder)
                  for a in self.actuators]
        self.model = build_plant_model(
            self.spec, dt=self.dt, integrator=self.integrator, native=native,
            states=[len(a.states) for a in self.actuators], lugre_integrated=route == "callbacks",
        )
        self.data = mujoco.MjData(self.model)
        d = self.data  # views into the data, cached: each attribute access makes a new array
        self._qpos, self._qvel, self._act = d.qpos, d.qvel, d.act
        self._ctrl, self._all_ctrl, self._applied = d.ctrl[: self.n], d.ctrl, d.qfrc_applied
        self._warm = d.qacc_warmstart
        self._warnings = [(name, d.warning[int(getattr(mujoco.mjtWarning, f"mjWARN_BAD{name}"))])
                          for name in ("QPOS", "QVEL", "QACC")]
        self._layout_states()
        self._nan = np.full(self.n, np.nan)
        self._setup_actuators(native)
        self._setup_friction()
        self._modes = [_SLIP] * self.n
        self._direction = [1.0] * self.n
        self._no_limit = (0.0,) * self.n
        self._tau_applied = self._tau_limit = self._no_limit
        self._v0 = [0.0] * self.n
        self._prepared = False
        self.reset()

    def __repr__(self) -> str:
        return f"Plant({self.spec.name!r}, n={self.n}, dt={self.dt:g}, route={self.route!r})"

    # --- set-up ------------------------------------------------------------------------------
    def _layout_states(self) -> None:
        """Where each named state sits in d.act: name -> (joint indices, act indices)."""
        m = self.model
        layout: dict[str, tuple[list[int], list[int]]] = {}
        for i, act in enumerate(self.actuators):
            adr = int(m.actuator_actadr[i])
            for k, name in enumerate(act.states):
                joints, adrs = layout.setdefault(name, ([], []))
                joints.append(i)
                adrs.append(adr + k)
        for j, joint in enumerate(self.spec.joints):
            if joint.friction.model is FrictionModel.lugre:
                a = m.actuator(joint.name + LUGRE_SUFFIX).id
                joints, adrs = layout.setdefault("z", ([], []))
                joints.append(j)
                adrs.append(int(m.actuator_actadr[a]))
        self.state_layout = {k: (np.array(j), np.array(a)) for k, (j, a) in layout.items()}
        self.state_names = tuple(self.state_layout)

    def _setup_actuators(self, native: list[bool]) -> None:
        limits = [a.command_limit for a in self.actuators]
        self._command_limit = [math.inf if lim is None else float(lim) for lim in limits]
        self.command_limit = np.array(self._command_limit)
        adr = [int(a) for a in self.model.actuator_actadr]
        hj = [i for i, a in enumerate(self.actuators)
              if native[i] and isinstance(a, HydraulicCylinder)]
        self._bank = (HydraulicBank([self.actuators[i].params for i in hj], self.dt,
                                    joints=hj, adrs=[adr[i] for i in hj]) if hj else None)
        self._bias = self.model.actuator_biasprm[: self.n, 0]  # a view into the model
        self._b0 = [0.0] * self.n
        # the cylinders' flow actuators (<joint>/flow) come last, one activation each
        first = self.model.nu - len(hj)
        self._ctrl_pad = [0.0] * (first - self.n)  # controls of the LuGre actuators between
        self._flow_act = slice(adr[first], adr[first] + len(hj)) if hj else slice(0, 0)
        self._flow_zero = [0.0] * len(hj)
        self._flow_ramp = self.integrator == int(mujoco.mjtIntegrator.mjINT_RK4)
        cylinders = [i for i, a in enumerate(self.actuators) if isinstance(a, HydraulicCylinder)]
        self._pressure_checks = [
            (i, adr[i], PRESSURE_LIMIT * self.actuators[i].params.supply_pressure)
            for i in cylinders
        ]
        self._integrated_cylinders = [i for i in cylinders if not native[i]]
        self._integrated = [(i, a, i) for i, a in enumerate(self.actuators) if not native[i]]

    def _setup_friction(self) -> None:
        frictions = [j.friction for j in self.spec.joints]
        self.hybrid = HybridFriction(frictions)
        self.lugre = LuGreFriction(frictions)
        self.limits = JointLimits(self.spec.joints)
        self.viscous = np.array([f.viscous if f.model is not FrictionModel.none else 0.0
                                 for f in frictions])
        """Viscous friction coefficient of each joint (0 without friction), (n,)."""
        joints, adrs = self.state_layout.get("z", ([], []))
        z_adr = {int(j): int(a) for j, a in zip(joints, adrs)}
        if self.route == "callbacks":  # MuJoCo integrates z (the generic, stiff way)
            for lugre in self.lugre.joints:
                name = self.joint_names[lugre.joint] + LUGRE_SUFFIX
                bristles = LuGreBristles(lugre, self.spec.joints[lugre.joint])
                self._integrated.append((self.model.actuator(name).id, bristles, lugre.joint))
            self._lugre = []
        else:
            self._lugre = [(L, z_adr[L.joint]) for L in self.lugre.joints]
        self._callbacks = (_callbacks.PluginCallbacks(self.model, self.data, self._integrated)
                           if self._integrated else None)
        self._slip = [(h.joint, h.coulomb, h.static, h.stribeck_velocity)
                      for h in self.hybrid.joints]
        self._sticky = [(h.joint, h.stick_velocity) for h in self.hybrid.sticky]
        self._limited = [(j, self.limits.lower[j], self.limits.upper[j])
                         for j in self.limits.limited]
        self._armature = self.model.dof_armature.copy()
        self._hold_inertia = HOLD_INERTIA * _largest_inertia(self.model)
        self._slip_acc = [b / self._hold_inertia for b in self.hybrid.breakaway]
        """The acceleration -h / I_hold of a held joint whose holding force h is Fc + Fs."""
        self._held: list[int] = []

    # --- state -------------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulation time, s."""
        return float(self.data.time)

    @property
    def modes(self) -> np.ndarray:
        """Friction/limit mode of each joint (``FrictionMode`` values), int8 (n,) (a copy)."""
        return np.array(self._modes, dtype=np.int8)

    def reset(self) -> None:
        """Back to t = 0, q = q̇ = 0 (clipped to the limits), the actuators' initial states."""
        mujoco.mj_resetData(self.model, self.data)
        for i, act in enumerate(self.actuators):
            k = len(act.states)
            if k:
                adr = int(self.model.actuator_actadr[i])
                self.data.act[adr:adr + k] = act.initial_state()
        self.data.qpos[:] = self.limits.clip(self.data.qpos.tolist())
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
            if name not in self.state_layout:
                raise InputError(f"no state {name!r} in this plant; expected one of "
                                 f"{', '.join(self.state_names) or 'none'}")
            joints, adrs = self.state_layout[name]
            full = np.full(self.n, np.nan)
            full[joints] = d.act[adrs]
            d.act[adrs] = self._joint_values(name, value, full)[joints]
        d.qpos[:] = self.limits.clip(d.qpos.tolist())
        self._resync()

    def balance_pressures(self) -> None:
        """Set each cylinder's ΔP to hold the arm still against gravity at the current pose.

        ΔP_j = G_j(q) / A_j with G the gravity forces at q̇ = 0 (MuJoCo's ``qfrc_bias``); the valve
        flows are set to zero. Torque joints are left alone.
        """
        d = self.data
        saved = d.qvel.copy()
        d.qvel[:] = 0.0
        with self.scope():
            mujoco.mj_forward(self.model, d)
        gravity = d.qfrc_bias.copy()
        d.qvel[:] = saved
        for i, act in enumerate(self.actuators):
            if isinstance(act, HydraulicCylinder):
                adr = int(self.model.actuator_actadr[i])
                d.act[adr] = gravity[i] / act.params.area
                d.act[adr + 1] = 0.0
        self._resync()

    def save(self) -> np.ndarray:
        """The plant's state as ``mj_getState`` gives it: time, q, q̇, act, ctrl and the last
        acceleration (``mjSTATE_FULLPHYSICS | mjSTATE_CTRL | mjSTATE_WARMSTART``)."""
        size = mujoco.mj_stateSize(self.model, _STATE)
        state = np.empty(size)
        mujoco.mj_getState(self.model, self.data, state, _STATE)
        return state

    def restore(self, state: np.ndarray) -> None:
        """Set a state saved by :meth:`save` (an ``mj_getState`` vector of that signature)."""
        mujoco.mj_setState(self.model, self.data, np.asarray(state, dtype=float), _STATE)
        self._resync()

    def _resync(self) -> None:
        """Modes from the state: on a limit -> AT_*, at rest with stick/slip friction -> STICK."""
        q, v = self.data.qpos.tolist(), self.data.qvel.tolist()
        lower, upper, can_stick = self.limits.lower, self.limits.upper, self.hybrid.can_stick
        modes = []
        for j in range(self.n):
            if q[j] <= lower[j] and v[j] <= 0.0:
                modes.append(_LOWER)
            elif q[j] >= upper[j] and v[j] >= 0.0:
                modes.append(_UPPER)
            else:
                modes.append(_STICK if can_stick[j] and v[j] == 0.0 else _SLIP)
            if modes[j] in (_LOWER, _UPPER):
                self.data.qvel[j] = 0.0
        if self._bank is not None:
            self.data.act[self._flow_act] = 0.0  # the flow ramps start from zero in every step
        self._modes = modes
        self._direction = [1.0] * self.n
        for _, warning in getattr(self, "_warnings", ()):
            warning.number = 0
        self._prepared = False

    def states(self) -> dict[str, np.ndarray]:
        """Every named state, each shape (n,) with NaN at joints without it."""
        act = self.data.act
        out = {}
        for name, (joints, adrs) in self.state_layout.items():
            full = self._nan.copy()
            full[joints] = act[adrs]
            out[name] = full
        return out

    def state(self) -> PlantState:
        """A snapshot for a controller (copies)."""
        d = self.data
        states = self.states()
        return PlantState(
            t=float(d.time), q=d.qpos.copy(), qd=d.qvel.copy(),
            dP=states["dP"] if "dP" in states else self._nan.copy(),
            Q=states["Q"] if "Q" in states else self._nan.copy(),
            mode=np.array(self._modes), states=states, joint_names=self.joint_names,
        )

    def actuator_forces(self) -> np.ndarray:
        """Each actuator's force at the current state and command, N or N·m, (n,)."""
        d = self.data
        out = np.zeros(self.n)
        for i, act in enumerate(self.actuators):
            adr, k = int(self.model.actuator_actadr[i]), len(act.states)
            x = d.act[adr:adr + k].copy() if k else np.zeros(0)
            out[i] = act.force(x, float(d.ctrl[i]), float(d.qpos[i]), float(d.qvel[i]))
        return out

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

        Clips and writes the commands, sets the actuator and friction forces for the step, makes
        the held joints immovable (see :meth:`_arm`) and evaluates the dynamics at the step's start
        (MuJoCo's forward pass, which :meth:`advance` integrates from); from it the automaton
        decides the modes of the step (see :meth:`_settle`).

        Args:
            u: commands, one per joint (valve current A, or force N / torque N·m).
        """
        n = self.n
        u = [x if -lim <= x <= lim else (lim if x > 0.0 else -lim)
             for x, lim in zip(u, self._command_limit)]
        q0, v0, act = self._qpos.tolist(), self._qvel.tolist(), self._act.tolist()
        modes = self._modes
        if self._bank is None:
            self._ctrl[:] = u
        else:
            rates = self._bank.prepare(q0, act, u, self._b0)
            self._bias[:] = self._b0
            if self._flow_ramp:  # RK4 sees the flow's pressure rise as a ramp in its stages
                self._all_ctrl[:] = u + self._ctrl_pad + rates  # (the ramps start at 0)
            else:  # single-stage integrators: its mean over the step, held
                self._all_ctrl[:] = u + self._ctrl_pad + self._flow_zero
                half = 0.5 * self.dt
                self._act[self._flow_act] = [half * r for r in rates]
        self._u = u
        fric = self._forces(v0, act)
        held = [j for j in range(n) if modes[j] != _SLIP]
        if held != self._held:
            self._arm(held)
        m, d = self.model, self.data
        mujoco.mj_checkPos(m, d)  # what mj_step does before its forward pass
        mujoco.mj_checkVel(m, d)
        mujoco.mj_forward(m, d)
        if self._held or self._sticky:
            fric = self._settle(v0, act, fric)
        mujoco.mj_checkAcc(m, d)
        self._fric = fric
        self._q0, self._v0, self._act0 = q0, v0, act
        self._prepared = True

    def _forces(self, v0: list[float], act: list[float]) -> list[float]:
        """Slip and LuGre friction of the step, written to ``qfrc_applied``, N or N·m, (n,)."""
        fric = [0.0] * self.n
        if self._slip:
            self._slip_friction(v0, fric)
        for lugre, adr in self._lugre:
            j = lugre.joint
            fric[j] += lugre.force(act[adr], v0[j])
        self._applied[:] = fric
        return fric

    def _slip_friction(self, v0: list[float], fric: list[float]) -> None:
        """Coulomb + Stribeck force of the slipping hybrid joints, held over the step.

        It is evaluated at the step's predicted mid-point velocity v + a dt/2, with a the last
        step's final acceleration (MuJoCo's ``qacc_warmstart``, part of the saved state), which
        makes smooth slip phases second order in dt (a 1-DOF stick-slip run at dt = 2 ms: 1.2 mm
        from the exact hybrid solution, against 3.2 mm at the step's start velocity). A velocity
        that would change sign within the step is taken as half the start velocity.
        """
        modes, direction, half = self._modes, self._direction, 0.5 * self.dt
        acc = self._warm.tolist()
        for j, coulomb, static, stribeck in self._slip:
            if modes[j] == _SLIP:
                v = v0[j]
                if v != 0.0:
                    mid = v + half * acc[j]
                    v = mid if mid * v > 0.0 else 0.5 * v
                fric[j] = slip_force(v, direction[j], coulomb, static, stribeck)

    def _settle(self, v0: list[float], act: list[float], fric: list[float]) -> list[float]:
        """The automaton at the step's start, on the dynamics MuJoCo just evaluated there.

        The forward pass gives every held joint's holding force at this instant, h = -I_hold q̈
        (the constrained dynamics of the whole held set under the step's actuator and friction
        forces), and every slipping joint's acceleration a. From them:

        - a slipping joint with stick/slip friction sticks now (velocity reset to zero) when it
          decelerates and either reaches zero velocity within the step (v and v + a dt of
          opposite signs) or is below ``stick_velocity`` by the middle of the step
          (|v + a dt/2| < stick_velocity: the paper's SLIP -> STICK rule, its event rounded to
          the nearer step boundary); a joint at rest that was released in one direction but
          accelerates in the other sticks too. Left slipping over a step in which it reverses,
          its slip friction would push it on through zero for the rest of the step, and drive
          its neighbours with that wrong force through the inertia coupling;
        - held joints whose holding force breaks away or pulls on a stop are released
          (:func:`~maniplab.actuators.automaton.transitions`).

        After any change the forces are set anew and MuJoCo evaluates the new held set, so every
        held joint's holding force is checked again in the same step with its neighbours'
        transitions in place (a newly stuck joint pushed harder than Fc + Fs reverses at once; a
        release or a stick shifts the others' holding forces). This repeats until nothing
        changes (at most ``2 n + 2`` evaluations); a step without transitions costs one forward
        pass, the one ``mj_step`` would have made anyway.

        Returns:
            The friction forces of the step, N or N·m, (n,).
        """
        modes, dt = self._modes, self.dt
        half = 0.5 * dt
        m, d = self.model, self.data
        qacc, slip_acc = d.qacc, self._slip_acc
        for _ in range(2 * self.n + 2):
            acc = qacc.tolist()
            changed = False
            for j, stick_velocity in self._sticky:
                if modes[j] == _SLIP:
                    v, a = v0[j], acc[j]
                    if v > 0.0:
                        hit = a < 0.0 and (v + a * dt <= 0.0 or v + a * half < stick_velocity)
                    elif v < 0.0:
                        hit = a > 0.0 and (v + a * dt >= 0.0 or v + a * half > -stick_velocity)
                    else:
                        hit = a * self._direction[j] < 0.0
                    if hit:
                        modes[j] = _STICK
                        v0[j] = 0.0
                        changed = True
            for j in self._held:  # h = -I_hold q̈ beyond Fc + Fs, or pulling on its stop?
                a, mode = acc[j], modes[j]
                if (a > slip_acc[j] or a < -slip_acc[j] if mode == _STICK
                        else a < 0.0 if mode == _UPPER else a > 0.0):
                    changed = self._release(acc) or changed
                    break
            if not changed:
                break
            self._qvel[:] = v0
            fric = self._forces(v0, act)
            self._arm([j for j in range(self.n) if modes[j] != _SLIP])
            mujoco.mj_forward(m, d)
        return fric

    def _release(self, acc: list[float]) -> bool:
        """Transitions of the held joints from their holding forces -I_hold q̈ (``acc``: q̈ of
        all joints); True if a mode changed."""
        modes, direction, scale = self._modes, self._direction, -self._hold_inertia
        held = self._held
        new, sign = transitions([modes[j] for j in held], [scale * acc[j] for j in held],
                                [self.hybrid.breakaway[j] for j in held],
                                [self.hybrid.can_stick[j] for j in held])
        changed = False
        for j, mode, s in zip(held, new, sign):
            changed = changed or mode != modes[j]
            modes[j] = mode
            if s:
                direction[j] = s
        return changed

    def _arm(self, held: list[int]) -> None:
        """Make the ``held`` joints immovable for MuJoCo: armature + HOLD_INERTIA on each.

        A held joint must keep q̈ = 0 while the others move with the constrained dynamics
        M_FF q̈_F = τ_F - b_F (the paper's eq. 8). Raising the held joints' inertia by
        ``HOLD_INERTIA`` times the arm's largest inertia makes MuJoCo's own factorisation solve
        exactly that, to about 1e-12 relative, inside every RK4 stage; the holding force is then
        read back from the accelerations (-I_hold q̈, see :meth:`_settle` and :meth:`advance`).
        Position and velocity of the held joints are reset after each step, so their residual
        motion (~1e-12) does not accumulate.
        """
        armature = self._armature.copy()
        armature[held] += self._hold_inertia
        self.model.dof_armature[:] = armature
        self._held = held

    def advance(self) -> None:
        """Second half of a step (after :meth:`prepare`, inside :meth:`scope`): integrate dt.

        Then: holding forces of the held joints over the step (h = -I_hold Δq̇ / dt, the RK4
        average; recorded as their friction or stop force); held joints back to their position at
        rest; slipping joints that reversed or slowed below ``stick_velocity`` stick; joints past
        a limit are put on it; hydraulic and LuGre states advanced. Whether a held joint breaks
        away or leaves its stop is decided at the next step's start (:meth:`_settle`).
        """
        if not self._prepared:
            raise RuntimeError("Plant.advance() needs a prepare() first")
        m, d, dt = self.model, self.data, self.dt
        self._integrate(m, d)
        self._prepared = False
        q0, v0, modes = self._q0, self._v0, self._modes
        q1, v1 = self._qpos.tolist(), self._qvel.tolist()
        fric, limit = self._fric, self._no_limit
        moved = bool(self._held)
        if moved:
            limit = [0.0] * self.n
            self._hold_forces(q0, q1, v1, fric, limit)
        for j, stick_velocity in self._sticky:  # friction.sticks, inlined
            if modes[j] == _SLIP:
                a, b = v0[j], v1[j]
                if a * b < 0.0 or (abs(b) < stick_velocity and abs(b) < abs(a)):
                    v1[j] = 0.0
                    modes[j] = _STICK
                    moved = True
        for j, lower, upper in self._limited:
            x = q1[j]
            if x < lower:
                q1[j], v1[j], modes[j] = lower, 0.0, _LOWER
                moved = True
            elif x > upper:
                q1[j], v1[j], modes[j] = upper, 0.0, _UPPER
                moved = True
        if moved:
            self._qpos[:] = q1
            self._qvel[:] = v1
        if not math.isfinite(math.fsum(v1)) or any(w.number for _, w in self._warnings):
            self._unstable_motion()
        self._tau_applied, self._tau_limit = fric, limit
        act = self._act.tolist()
        if self._bank is not None:
            act[self._flow_act] = self._flow_zero  # the flows' scratch activations
            if not self._bank.finish(q0, q1, self._act0, self._u, act):
                self._check_pressures(act)
        for lugre, adr in self._lugre:
            j = lugre.joint
            act[adr] = lugre.advance(self._act0[adr], (q1[j] - q0[j]) / dt, dt)
        self._act[:] = act
        if self._integrated_cylinders:
            self._check_pressures(act)

    def _hold_forces(self, q0: list[float], q1: list[float], v1: list[float], fric: list[float],
                     limit: list[float]) -> None:
        """Holding forces of the held joints over the step (into ``fric`` or ``limit``), and
        the held joints put back at rest where they were."""
        modes, scale = self._modes, -self._hold_inertia / self.dt
        for j in self._held:
            h = scale * v1[j]  # v1 - 0 = the step's average acceleration times dt
            q1[j], v1[j] = q0[j], 0.0
            if modes[j] == _STICK:
                fric[j] += h
            else:
                limit[j] = h

    @property
    def tau_fric(self) -> np.ndarray:
        """Friction force on each joint over the last step (stiction's holding force when stuck,
        viscous part at the step's start included), N or N·m, (n,)."""
        return np.array(self._tau_applied) - self.viscous * np.array(self._v0)

    @property
    def tau_limit(self) -> np.ndarray:
        """Force of the limit stops over the prepared step (0 off the limits), N or N·m, (n,)."""
        return np.array(self._tau_limit)

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

    def _check_pressures(self, act: list[float]) -> None:
        for joint, adr, bound in self._pressure_checks:
            if not abs(act[adr]) <= bound:
                self._unstable_pressure(joint, act[adr], bound)

    def _unstable_pressure(self, joint: int, pressure: float, bound: float) -> None:
        raise InstabilityError(
            f"ΔP = {pressure:.4g} Pa is beyond {PRESSURE_LIMIT:g} times the supply pressure "
            f"({bound / PRESSURE_LIMIT:.4g} Pa)",
            time=self.t, joint=self.joint_names[joint], dt=self.dt,
        )


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
