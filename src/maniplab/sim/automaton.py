"""The plant's friction/limit automaton: joint modes, exact holding, stick/slip and limit events.

Each joint is in one mode (:class:`~maniplab.friction.FrictionMode`): SLIP (it moves, with its
Coulomb/Stribeck friction applied), STICK (held at rest by stiction) or AT_LOWER / AT_UPPER (held
on a limit). Per step of the plant (:class:`~maniplab.sim.plant.Plant`):

1. at the step's start, :meth:`Automaton.forces` sets the slipping joints' friction and the
   LuGre joints' bristle force (held over the step, in ``qfrc_applied``) and :meth:`hold` makes
   the held joints immovable; after MuJoCo's forward pass :meth:`settle` decides the step's modes
   on the holding forces and accelerations of that instant (break-aways and releases from stops,
   :func:`transitions`; slipping joints that stop within the step), evaluating again after any
   change until the modes agree with the forces;
2. after MuJoCo's step, :meth:`finish` reads the holding forces over the step, puts held joints
   back at rest, sticks slipping joints that reversed or slowed below ``stick_velocity``
   (:func:`~maniplab.friction.sticks`) and puts joints past a limit on it; LuGre's z is advanced
   (:meth:`advance_bristles`).

Holding is exact, not a stiff spring: a held joint gets an armature of HOLD_INERTIA times the
arm's largest inertia (on the plant's working copy of the model), so MuJoCo's own factorisation
of M solves the constrained dynamics (the free joints' accelerations M_FF⁻¹(τ_F - b_F) to ~1e-12
relative, the paper's eq. 8) in every RK4 stage, and the force that holds the joint is read back
as -I q̈ (at t, for the decisions) and -I Δq̇ / dt (over the step, for the record). Mode changes
take effect at step boundaries; events inside a step are put on the nearer boundary where the
step's start predicts them (a velocity reaching zero or ``stick_velocity``), else on its end.

The per-step work is plain Python over the joints' numbers: for the few joints of an arm that is
several times faster than numpy, whose cost per call (~0.5 µs) exceeds the arithmetic.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from maniplab.friction import FrictionMode, HybridFriction, LuGreFriction, slip_force, sticks
from maniplab.friction.lugre import LuGreJoint
from maniplab.sim.limits import JointLimits
from maniplab.spec import Joint

HOLD_INERTIA = 1e12
"""Held joints get this many times the arm's largest inertia (diagonal of M) as armature."""

_SLIP, _STICK = FrictionMode.SLIP.value, FrictionMode.STICK.value
_LOWER, _UPPER = FrictionMode.AT_LOWER.value, FrictionMode.AT_UPPER.value


def transitions(mode: Sequence[int], hold: Sequence[float], breakaway: Sequence[float],
                can_stick: Sequence[bool]) -> tuple[list[int], list[float]]:
    """New modes of k held joints and the slip direction of those that broke away.

    The rules: AT_UPPER is released when the stop had to pull (hold > 0), AT_LOWER when hold < 0;
    the joint becomes STICK if it has stick/slip friction (it may still be held by stiction),
    else SLIP. STICK breaks away (-> SLIP) when |hold| exceeds the break-away force Fc + Fs, in
    the direction the other forces push it (opposite to the hold). Limits are decided first:
    when any limit releases, break-aways wait, because the other holding forces were computed with
    that (one-sided, wrongly active) constraint in place; the automaton evaluates the holding
    forces again without it, in the same step, and asks again.

    Args:
        mode: their modes (STICK, AT_LOWER or AT_UPPER values), (k,).
        hold: the force that held each one, along the joint's axis, N or N·m, (k,).
        breakaway: Fc + Fs of each, N or N·m, (k,).
        can_stick: whether each has stick/slip friction, (k,).

    Returns:
        (mode, direction), each (k,): the new modes, and ±1 for a joint that broke away (the sign
        of its coming motion), 0 for the others.
    """
    k = len(mode)
    new = list(mode)
    direction = [0.0] * k
    released = False
    for i in range(k):
        if (mode[i] == _UPPER and hold[i] > 0.0) or (mode[i] == _LOWER and hold[i] < 0.0):
            new[i] = _STICK if can_stick[i] else _SLIP
            released = True
    if released:
        return new, direction
    for i in range(k):
        if mode[i] == _STICK and abs(hold[i]) > breakaway[i]:
            new[i] = _SLIP
            direction[i] = -1.0 if hold[i] > 0.0 else 1.0
    return new, direction


class Automaton:
    """The friction/limit automaton of an arm, acting on the plant's working model and data.

    Args:
        joints: the arm's joints.
        model: the plant's working model (its ``dof_armature`` holds the held joints).
        data: the plant's data.
        dt: the step, s.
        bristles: LuGre's z address in ``data.act`` per LuGre joint, when the automaton advances z
            itself (the plant's native route); empty when MuJoCo integrates it.

    Attributes:
        modes: each joint's mode (``FrictionMode`` values), list (n,).
        hybrid, lugre, limits: the arm's hybrid friction, LuGre joints and limits.
        viscous: each joint's viscous coefficient (0 without friction), (n,).
    """

    def __init__(self, joints: Sequence[Joint], model: mujoco.MjModel, data: mujoco.MjData,
                 dt: float, bristles: Mapping[int, int]) -> None:
        self.n = len(joints)
        self.model, self.data, self.dt = model, data, dt
        frictions = [j.friction for j in joints]
        self.hybrid = HybridFriction(frictions)
        self.lugre = LuGreFriction(frictions)
        self.limits = JointLimits(joints)
        self.viscous = np.array([f.damping for f in frictions])
        self._qvel, self._qacc, self._warm = data.qvel, data.qacc, data.qacc_warmstart
        self._applied = data.qfrc_applied
        self._slip = [(h.joint, h.coulomb, h.static, h.stribeck_velocity)
                      for h in self.hybrid.joints]
        self._sticky = [(h.joint, h.stick_velocity) for h in self.hybrid.sticky]
        self._limited = [(j, self.limits.lower[j], self.limits.upper[j])
                         for j in self.limits.limited]
        self._bristles: list[tuple[LuGreJoint, int]] = [
            (L, bristles[L.joint]) for L in self.lugre.joints if L.joint in bristles]
        # MuJoCo factorises the mass matrix of a "simple" dof (a body it found decoupled when
        # compiling) once, from the armature of that time: for holding to act, none is simple
        model.dof_simplenum[:] = 0
        self._armature = model.dof_armature.copy()
        self._hold_inertia = HOLD_INERTIA * _largest_inertia(model)
        self._slip_acc = [b / self._hold_inertia for b in self.hybrid.breakaway]
        """The acceleration -h / I_hold of a held joint whose holding force h is Fc + Fs."""
        self.modes = [_SLIP] * self.n
        self._direction = [1.0] * self.n
        self._held: list[int] = []
        self.active = bool(self._limited or self._sticky)

    # --- state ---------------------------------------------------------------------------------
    def resync(self) -> None:
        """Modes from the state: on a limit -> AT_*, at rest with stick/slip friction -> STICK
        (velocities of joints on a limit are set to zero)."""
        q, v = self.data.qpos.tolist(), self._qvel.tolist()
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
                self._qvel[j] = 0.0
        self.modes = modes
        self._direction = [1.0] * self.n

    # --- the step's start ------------------------------------------------------------------------
    def forces(self, v0: list[float], act: list[float]) -> list[float]:
        """Slip and LuGre friction of the step, written to ``qfrc_applied``, N or N·m, (n,)."""
        fric = [0.0] * self.n
        if self._slip:
            self._slip_friction(v0, fric)
        for lugre, adr in self._bristles:
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
        modes, direction, half = self.modes, self._direction, 0.5 * self.dt
        acc = self._warm.tolist()
        for j, coulomb, static, stribeck in self._slip:
            if modes[j] == _SLIP:
                v = v0[j]
                if v != 0.0:
                    mid = v + half * acc[j]
                    v = mid if mid * v > 0.0 else 0.5 * v
                fric[j] = slip_force(v, direction[j], coulomb, static, stribeck)

    def hold(self) -> None:
        """Make the joints not slipping immovable for MuJoCo: armature + HOLD_INERTIA on each.

        A held joint must keep q̈ = 0 while the others move with the constrained dynamics
        M_FF q̈_F = τ_F - b_F (the paper's eq. 8). Raising the held joints' inertia by
        ``HOLD_INERTIA`` times the arm's largest inertia makes MuJoCo's own factorisation solve
        exactly that, to about 1e-12 relative, inside every RK4 stage; the holding force is then
        read back from the accelerations. Position and velocity of the held joints are reset
        after each step, so their residual motion (~1e-12) does not accumulate.
        """
        held = [j for j in range(self.n) if self.modes[j] != _SLIP]
        if held != self._held:
            armature = self._armature.copy()
            armature[held] += self._hold_inertia
            self.model.dof_armature[:] = armature
            self._held = held

    def settle(self, v0: list[float], act: list[float], fric: list[float]) -> list[float]:
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
          (:func:`transitions`).

        After any change the forces are set anew and MuJoCo evaluates the new held set, so every
        held joint's holding force is checked again in the same step with its neighbours'
        transitions in place. This repeats until nothing changes (at most ``2 n + 2``
        evaluations); a step without transitions costs one forward pass, the one ``mj_step``
        would have made anyway.

        Args:
            v0: velocities at the step's start (entries of joints that stick now are set to 0).
            act: activations at the step's start.
            fric: the friction forces set by :meth:`forces`.

        Returns:
            The friction forces of the step, N or N·m, (n,).
        """
        modes, dt = self.modes, self.dt
        half = 0.5 * dt
        m, d = self.model, self.data
        slip_acc = self._slip_acc
        for _ in range(2 * self.n + 2):
            acc = self._qacc.tolist()
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
            fric = self.forces(v0, act)
            self.hold()
            mujoco.mj_forward(m, d)
        return fric

    def _release(self, acc: list[float]) -> bool:
        """Transitions of the held joints from their holding forces -I_hold q̈ (``acc``: q̈ of
        all joints); True if a mode changed."""
        modes, direction, scale = self.modes, self._direction, -self._hold_inertia
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

    # --- the step's end ------------------------------------------------------------------------
    def finish(self, q0: list[float], v0: list[float], q1: list[float], v1: list[float],
               fric: list[float]) -> tuple[bool, list[float] | None]:
        """Events at the step's end, in ``q1``, ``v1`` and ``fric`` (lists (n,)).

        Holding forces of the held joints over the step (h = -I_hold Δq̇ / dt, the RK4 average;
        added to ``fric`` when stuck, the limit force when on a stop), held joints put back at
        rest, slipping joints that reversed or slowed below ``stick_velocity`` stuck, joints past
        a limit put on it. Whether a held joint breaks away or leaves its stop is decided at the
        next step's start (:meth:`settle`).

        Returns:
            (changed, limit): whether q1 or v1 changed, and the limit stops' forces (n,) or None
            when no joint is on a limit.
        """
        modes = self.modes
        limit = None
        moved = bool(self._held)
        if moved:
            limit = [0.0] * self.n
            scale = -self._hold_inertia / self.dt
            for j in self._held:
                h = scale * v1[j]  # v1 - 0 = the step's average acceleration times dt
                q1[j], v1[j] = q0[j], 0.0
                if modes[j] == _STICK:
                    fric[j] += h
                else:
                    limit[j] = h
        for j, stick_velocity in self._sticky:
            if modes[j] == _SLIP and sticks(v0[j], v1[j], stick_velocity):
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
        return moved, limit

    def advance_bristles(self, q0: list[float], q1: list[float], act0: list[float],
                         act1: list[float]) -> None:
        """LuGre's z over the step (exact for the step's mean velocity), into ``act1``."""
        dt = self.dt
        for lugre, adr in self._bristles:
            j = lugre.joint
            act1[adr] = lugre.advance(act0[adr], (q1[j] - q0[j]) / dt, dt)


def _largest_inertia(model: mujoco.MjModel) -> float:
    """The largest diagonal entry of M at the model's reference pose (kg, kg·m²), at least 1."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    mujoco.mj_crb(model, data)
    dense = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, dense)
    return max(1.0, float(np.max(np.diag(dense))))
