"""The plant's friction/limit automaton and step as maniplab computed them in Python (frozen).

maniplab's plant now runs in C (``src/maniplab_native/plant.c``); this is the Python code it
replaced, kept as an independent reference: stepped on a copy of the same MuJoCo model from the
same state under the same commands, both must agree to round-off (tests/test_plant_native.py).
LuGre is left out (its bristle state is advanced by the engine plugin in both).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence

import mujoco
import numpy as np

import maniplab as ml

SLIP, STICK, LOWER, UPPER = 0, 1, 2, 3


def slip_force(v: float, direction: float, coulomb: float, static: float,
               stribeck_velocity: float) -> float:
    r = v / stribeck_velocity
    magnitude = coulomb + static * math.exp(-r * r)
    if v > 0.0:
        return -magnitude
    if v < 0.0:
        return magnitude
    return -magnitude * direction


def sticks(v0: float, v1: float, stick_velocity: float) -> bool:
    a1 = abs(v1)
    return v0 * v1 < 0.0 or (a1 < stick_velocity and a1 < abs(v0))


def transitions(mode: Sequence[int], hold: Sequence[float], breakaway: Sequence[float],
                can_stick: Sequence[bool]) -> tuple[list[int], list[float]]:
    k = len(mode)
    new = list(mode)
    direction = [0.0] * k
    released = False
    for i in range(k):
        if (mode[i] == UPPER and hold[i] > 0.0) or (mode[i] == LOWER and hold[i] < 0.0):
            new[i] = STICK if can_stick[i] else SLIP
            released = True
    if released:
        return new, direction
    for i in range(k):
        if mode[i] == STICK and abs(hold[i]) > breakaway[i]:
            new[i] = SLIP
            direction[i] = -1.0 if hold[i] > 0.0 else 1.0
    return new, direction


class PythonPlant:
    """The old Python stepping of a plant's model (a private working copy of ``plant.model``)."""

    def __init__(self, plant: ml.Plant) -> None:
        spec = plant.spec
        self.n, self.substeps = plant.n, plant.substeps
        self.model = copy.copy(plant.model)
        self.data = mujoco.MjData(self.model)
        self.dt = self.model.opt.timestep
        self.limit_u = [math.inf if a.command_limit is None else float(a.command_limit)
                        for a in plant.actuators]
        frictions = [j.friction for j in spec.joints]
        hybrid = [f.model is ml.FrictionModel.hybrid for f in frictions]
        # a pinned cylinder's rod friction, on its joint through the lever |r| of each step
        self._rods = {j: joint.rod_friction for j, joint in enumerate(spec.joints)
                      if joint.rod_friction is not None}
        self._pin_breakaway = [f.coulomb + f.static if h else 0.0
                               for f, h in zip(frictions, hybrid)]
        self._pin_stick = [f.stick_velocity for f in frictions]
        self.breakaway = list(self._pin_breakaway)
        self.can_stick = [b > 0.0 or (j in self._rods and self._rods[j].breakaway > 0.0)
                          for j, b in enumerate(self._pin_breakaway)]
        own = [(f.coulomb, f.static, f.stribeck_velocity) if h else (0.0, 0.0, f.stribeck_velocity)
               for f, h in zip(frictions, hybrid)]
        self._slip = [(j, *own[j]) for j in range(self.n) if hybrid[j] or j in self._rods]
        self._stick_velocity = list(self._pin_stick)
        self._lever = [0.0] * self.n
        self.lower = [j.limits[0] if j.limits else -math.inf for j in spec.joints]
        self.upper = [j.limits[1] if j.limits else math.inf for j in spec.joints]
        self._limited = [(j, self.lower[j], self.upper[j]) for j, joint in enumerate(spec.joints)
                         if joint.limits]
        self.model.dof_simplenum[:] = 0
        self._armature = self.model.dof_armature.copy()
        self._hold_inertia = plant.hold_inertia
        self._slip_acc = [b / self._hold_inertia for b in self.breakaway]
        self._sticky = [(j, self._stick_velocity[j]) for j in range(self.n) if self.can_stick[j]]
        self.modes = [SLIP] * self.n
        self._direction = [1.0] * self.n
        self._held: list[int] = []
        self.active = bool(self._limited or self._sticky)
        self.fric = [0.0] * self.n
        self.limit = [0.0] * self.n

    def set_state(self, qpos: np.ndarray, qvel: np.ndarray, act: np.ndarray, time: float) -> None:
        d = self.data
        d.qpos[:], d.qvel[:], d.act[:], d.time = qpos, qvel, act, time
        self.resync()

    def resync(self) -> None:
        q, v = self.data.qpos.tolist(), self.data.qvel.tolist()
        modes = []
        for j in range(self.n):
            if q[j] <= self.lower[j] and v[j] <= 0.0:
                modes.append(LOWER)
            elif q[j] >= self.upper[j] and v[j] >= 0.0:
                modes.append(UPPER)
            else:
                modes.append(STICK if self.can_stick[j] and v[j] == 0.0 else SLIP)
            if modes[j] in (LOWER, UPPER):
                self.data.qvel[j] = 0.0
        self.modes = modes
        self._direction = [1.0] * self.n

    # --- the automaton ----------------------------------------------------------------------
    def forces(self, v0: list[float]) -> list[float]:
        fric = [0.0] * self.n
        half, acc = 0.5 * self.dt, self.data.qacc_warmstart.tolist()
        for j, coulomb, static, stribeck in self._slip:
            if self.modes[j] == SLIP:
                v = v0[j]
                if v != 0.0:
                    mid = v + half * acc[j]
                    v = mid if mid * v > 0.0 else 0.5 * v
                fric[j] = slip_force(v, self._direction[j], coulomb, static, stribeck)
                if j in self._rods:  # the rod's, at the rod's speed v|r|, times |r|
                    rod, a = self._rods[j], self._lever[j]
                    fric[j] += slip_force(v * a, self._direction[j], a * rod.coulomb,
                                          a * rod.static, rod.stribeck_velocity)
        self.data.qfrc_applied[:] = fric
        return fric

    def hold(self) -> None:
        held = [j for j in range(self.n) if self.modes[j] != SLIP]
        if held != self._held:
            armature = self._armature.copy()
            armature[held] += self._hold_inertia
            self.model.dof_armature[:] = armature
            self._held = held

    def settle(self, v0: list[float], fric: list[float]) -> list[float]:
        modes, dt = self.modes, self.dt
        half = 0.5 * dt
        for _ in range(2 * self.n + 2):
            acc = self.data.qacc.tolist()
            changed = False
            for j, stick_velocity in self._sticky:
                if modes[j] == SLIP:
                    v, a = v0[j], acc[j]
                    if v > 0.0:
                        hit = a < 0.0 and (v + a * dt <= 0.0 or v + a * half < stick_velocity)
                    elif v < 0.0:
                        hit = a > 0.0 and (v + a * dt >= 0.0 or v + a * half > -stick_velocity)
                    else:
                        hit = a * self._direction[j] < 0.0
                    if hit:
                        modes[j] = STICK
                        v0[j] = 0.0
                        changed = True
            for j in self._held:
                a, mode = acc[j], modes[j]
                if (a > self._slip_acc[j] or a < -self._slip_acc[j] if mode == STICK
                        else a < 0.0 if mode == UPPER else a > 0.0):
                    changed = self._release(acc) or changed
                    break
            if not changed:
                break
            self.data.qvel[:] = v0
            fric = self.forces(v0)
            self.hold()
            mujoco.mj_forward(self.model, self.data)
        return fric

    def _release(self, acc: list[float]) -> bool:
        held = self._held
        new, sign = transitions([self.modes[j] for j in held],
                                [-self._hold_inertia * acc[j] for j in held],
                                [self.breakaway[j] for j in held],
                                [self.can_stick[j] for j in held])
        changed = False
        for j, mode, s in zip(held, new, sign):
            changed = changed or mode != self.modes[j]
            self.modes[j] = mode
            if s:
                self._direction[j] = s
        return changed

    def finish(self, q0: list[float], v0: list[float], q1: list[float], v1: list[float],
               fric: list[float]) -> tuple[bool, list[float]]:
        modes, limit = self.modes, [0.0] * self.n
        moved = bool(self._held)
        scale = -self._hold_inertia / self.dt
        for j in self._held:
            h = scale * v1[j]
            q1[j], v1[j] = q0[j], 0.0
            if modes[j] == STICK:
                fric[j] += h
            else:
                limit[j] = h
        for j, stick_velocity in self._sticky:
            if modes[j] == SLIP and sticks(v0[j], v1[j], stick_velocity):
                v1[j] = 0.0
                modes[j] = STICK
                moved = True
        for j, lower, upper in self._limited:
            if q1[j] < lower:
                q1[j], v1[j], modes[j] = lower, 0.0, LOWER
                moved = True
            elif q1[j] > upper:
                q1[j], v1[j], modes[j] = upper, 0.0, UPPER
                moved = True
        return moved, limit

    def levers(self) -> None:
        """Each rod joint's lever |r| (its actuator's moment on it) at the pose of the step's
        start, and its break-away and stick velocity with the rod's friction through it."""
        m, d = self.model, self.data
        mujoco.mj_fwdPosition(m, d)
        for j, rod in self._rods.items():
            row = m.actuator_outadr[j]
            start, count = d.moment_rowadr[row], d.moment_rownnz[row]
            r = sum(d.actuator_moment[k] for k in range(start, start + count)
                    if d.moment_colind[k] == j)
            a = abs(r)
            self._lever[j] = a
            if not self.can_stick[j]:
                continue
            held = a * rod.breakaway
            self.breakaway[j] = self._pin_breakaway[j] + held
            self._slip_acc[j] = self.breakaway[j] / self._hold_inertia
            sv = self._pin_stick[j] if self._pin_breakaway[j] > 0.0 else math.inf
            if held > 0.0:
                sv = min(sv, rod.stick_velocity / a)
            self._stick_velocity[j] = sv if sv < math.inf else self._pin_stick[j]
        self._sticky = [(j, self._stick_velocity[j]) for j in range(self.n) if self.can_stick[j]]

    # --- the step ---------------------------------------------------------------------------
    def _start(self) -> None:
        m, d = self.model, self.data
        q0, v0 = d.qpos.tolist(), d.qvel.tolist()
        d.ctrl[:] = self._u + [0.0] * (m.nu - self.n)
        if self._rods:
            self.levers()
        fric = self.forces(v0)
        self.hold()
        mujoco.mj_checkPos(m, d)
        mujoco.mj_checkVel(m, d)
        mujoco.mj_forward(m, d)
        if self.active:
            fric = self.settle(v0, fric)
        mujoco.mj_checkAcc(m, d)
        self._step = (q0, v0, fric)

    def _finish(self) -> None:
        mujoco.mj_RungeKutta(self.model, self.data, 4)
        q0, v0, fric = self._step
        q1, v1 = self.data.qpos.tolist(), self.data.qvel.tolist()
        moved, limit = self.finish(q0, v0, q1, v1, fric)
        if moved:
            self.data.qpos[:] = q1
            self.data.qvel[:] = v1
        for j, rod in self._rods.items():  # the record has the rod's viscous force too
            fric[j] -= rod.viscous * self._lever[j] ** 2 * v0[j]
        self.fric, self.limit = fric, limit

    def step(self, u: Sequence[float]) -> None:
        """One plant step under commands u (n,), held over it."""
        self._u = [x if -lim <= x <= lim else (lim if x > 0.0 else -lim)
                   for x, lim in zip(u, self.limit_u)]
        self._start()
        self.modes_at_start = list(self.modes)
        self.qd_at_start = list(self._step[1])
        self._finish()
        for _ in range(self.substeps - 1):
            self._start()
            self._finish()
