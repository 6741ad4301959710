"""Arms whose tool hangs on passive joints: the chain a controller drives, the pose the tool hangs
in, its pendulum, and the sway a move leaves.

A grapple on its rotator link or a hook on its rope hangs from the tip of the actuated chain on
passive joints (``actuator: {type: passive}``) at the end of the chain. The controllers drive the
actuated joints and the **suspension point** (the first passive joint's origin): the hanging part
acts on the chain as its weight at that point, exactly at rest (the tool hangs plumb, so its
weight passes through the point) and approximately while it swings. :func:`suspended` is that
arm: the actuated chain with the hanging mass as its payload at the suspension point, on which a
move is planned. A controller inverts the chain's dynamics without that mass
(:func:`chain`) and holds the hanging weight as a force at the point (:func:`hanging_weight`):
above its pendulum's frequency a hanging tool swings free, and counting its inertia would make
the controller's loops several times too stiff. The plant simulates the whole arm, the passive
joints left to swing; :func:`sway` measures the swing after the move.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
from scipy.optimize import minimize

from maniplab.control.errors import ControlError
from maniplab.spec import ManipulatorSpec, model_of

if TYPE_CHECKING:
    from maniplab.sim.run import Run

TASK_SIGNALS = frozenset({"x_d", "x", "e_x", "a_x"})
"""A controller's logged signals that are of the task, not one value per joint."""

SETTLED = math.radians(1.0)
"""rad: a passive joint within this of its hanging pose has settled (:func:`sway`)."""


def passive_joints(spec: ManipulatorSpec) -> list[int]:
    """The indices of the joints without an actuator (declared ``passive``)."""
    return [j for j, joint in enumerate(spec.joints) if getattr(model_of(joint), "passive", False)]


def hanging_count(spec: ManipulatorSpec) -> int:
    """How many joints at the end of the chain are passive (the hanging tool's).

    Raises:
        ControlError: a passive joint with an actuated one after it (a controller drives the
            chain up to the suspension point, so the passive joints must end the chain).
    """
    passive = passive_joints(spec)
    count = len(passive)
    if passive and passive != list(range(spec.n - count, spec.n)):
        inner = next(j for j in passive if j < spec.n - count)
        raise ControlError(
            f"joint {spec.joint_names[inner]} is passive but an actuated joint follows it: a "
            "controller needs the passive joints at the end of the chain (a hanging tool)")
    if count == spec.n:
        raise ControlError("every joint is passive: there is nothing to control")
    return count


def suspended(spec: ManipulatorSpec) -> ManipulatorSpec:
    """The arm a controller drives: its actuated joints, and as payload at the suspension point
    the mass of everything that hangs from it (the passive joints' bodies and the end
    effector). The arm itself (the same object) when no joint is passive."""
    return _suspended(spec) if hanging_count(spec) else spec


@functools.lru_cache(maxsize=32)
def _suspended(spec: ManipulatorSpec) -> ManipulatorSpec:
    count = hanging_count(spec)
    hanging = spec.joints[spec.n - count:]
    mass = sum(j.body.mass for j in hanging if j.body is not None) + spec.end_effector.mass
    data = spec.to_dict()
    data["joints"] = data["joints"][:spec.n - count]
    if "control" in data:  # per-joint gains lose the passive joints' entries
        data["control"] = _first(data["control"], spec.n, spec.n - count)
    data["end_effector"] = {"mass": mass}
    data["name"] = f"{spec.name}-suspended"
    return ManipulatorSpec.from_dict(data)


def chain(spec: ManipulatorSpec) -> ManipulatorSpec:
    """The actuated chain without what hangs from it (no payload at the suspension point): the
    arm whose inertia a controller inverts, the hanging tool's weight added as a force
    (:func:`hanging_weight`). The arm itself when no joint is passive."""
    if not passive_joints(spec):
        return spec
    return suspended(spec).with_overrides({"end_effector.mass": 0.0})


def hanging_weight(spec: ManipulatorSpec) -> np.ndarray:
    """The weight of everything that hangs from the suspension point, N, base axes, (3,)."""
    mass = suspended(spec).end_effector.mass if passive_joints(spec) else 0.0
    return mass * np.asarray(spec.gravity, dtype=float)


def _first(value: object, n: int, keep: int) -> object:
    """``value`` with every list of n entries cut to its first ``keep``, nested."""
    if isinstance(value, dict):
        return {k: _first(v, n, keep) for k, v in value.items()}
    if isinstance(value, list) and len(value) == n:
        return value[:keep]
    return value


@functools.lru_cache(maxsize=16)
def _compiled(spec: ManipulatorSpec) -> mujoco.MjModel:
    from maniplab.mjcf_gen import build_model

    return build_model(spec)


def hanging(spec: ManipulatorSpec, q: np.ndarray, guess: np.ndarray | None = None) -> np.ndarray:
    """``q`` (n,) with the passive joints at the pose the tool hangs in at rest (the least
    potential energy within their limits), the actuated joints as given; ``guess``: the passive
    joints' pose to start the search from (a nearby solution: one search instead of three)."""
    q = np.asarray(q, dtype=float).copy()
    passive = passive_joints(spec)
    if not passive:
        return q
    model = _compiled(spec)
    data = mujoco.MjData(model)
    g = np.asarray(spec.gravity, dtype=float)
    bounds = [spec.joints[j].limits or (-math.pi, math.pi) for j in passive]
    torque = np.zeros(model.nv)

    def energy(x: np.ndarray) -> tuple[float, np.ndarray]:
        """The potential energy, J, and its gradient, the gravity torques (MuJoCo's bias
        forces at rest), N·m."""
        data.qpos[:] = q
        data.qpos[passive] = x
        mujoco.mj_fwdPosition(model, data)
        mujoco.mj_rne(model, data, 0, torque)
        return (float(-np.sum(model.body_mass[:, None] * data.xipos * g)),
                torque[model.jnt_dofadr[passive]].copy())

    best = None
    starts = ([np.asarray(guess, dtype=float)] if guess is not None else
              [np.zeros(len(passive)), *(np.full(len(passive), s) for s in (-1.5, 1.5))])
    for start in starts:
        x0 = np.clip(start, [b[0] for b in bounds], [b[1] for b in bounds])
        found = minimize(energy, x0, jac=True, method="L-BFGS-B", bounds=bounds,
                         options={"ftol": 1e-15, "gtol": 1e-10})
        if best is None or found.fun < best.fun - 1e-9:
            best = found
    assert best is not None
    q[passive] = best.x
    return q


def pendulum_frequency(spec: ManipulatorSpec, q: np.ndarray) -> float:
    """The lowest small-angle frequency of the hanging tool at pose q (hanging), the suspension
    point held still, rad/s: from the passive joints' block of the arm's mass matrix M_pp and of
    the gravity torques' slope K_pp = ∂G_p/∂q_p, the smallest root of det(K_pp - ω² M_pp) = 0."""
    from maniplab.model import AnalyticModel

    passive = passive_joints(spec)
    model = AnalyticModel(spec)
    q = np.asarray(q, dtype=float)
    M = np.asarray(model.M(q))[np.ix_(passive, passive)]
    K = np.empty((len(passive), len(passive)))
    for i, j in enumerate(passive):
        h = 1e-6
        up, down = q.copy(), q.copy()
        up[j] += h
        down[j] -= h
        K[:, i] = (np.asarray(model.G(up)) - np.asarray(model.G(down)))[passive] / (2.0 * h)
    squares = np.linalg.eigvals(np.linalg.solve(M, K)).real
    return float(math.sqrt(max(squares.min(), 0.0)))


@dataclasses.dataclass(frozen=True)
class Sway:
    """The swing of one passive joint after a move.

    Attributes:
        joint: its name.
        amplitude: the largest deviation from its hanging pose after the move's end, rad.
        settling: the time after the move's end from which it stays within :data:`SETTLED`
            of its hanging pose, s (inf: not within the run, or not for a whole pendulum period
            before the run ends).
    """

    joint: str
    amplitude: float
    settling: float

    def to_dict(self) -> dict[str, float | str | None]:
        """JSON-friendly: the amplitude in degrees, the settling time (None: not settled)."""
        return {"joint": self.joint, "amplitude_deg": math.degrees(self.amplitude),
                "settling_s": self.settling if math.isfinite(self.settling) else None}


def sway(run: Run, end: float) -> list[Sway]:
    """Each passive joint's sway in ``run`` after the time ``end`` (the move's end, s): its
    deviation from the pose it hangs in at the run's last actuated pose (settled from the
    last sample outside :data:`SETTLED`, when the run goes on for a pendulum period after it)."""
    spec = run.spec
    passive = passive_joints(spec)
    if not passive:
        return []
    t, q = np.asarray(run.t, dtype=float), np.asarray(run.q, dtype=float)
    rest = hanging(spec, q[-1])
    period = 2.0 * math.pi / max(pendulum_frequency(spec, rest), 1e-9)
    after = t >= end
    out = []
    for j in passive:
        deviation = np.abs(q[after, j] - rest[j])
        amplitude = float(deviation.max()) if deviation.size else 0.0
        outside = np.flatnonzero(deviation > SETTLED)
        settling = 0.0 if not outside.size else float(t[after][outside[-1]] - end)
        if outside.size and t[-1] - (end + settling) < period:  # a swing's crossing, not rest
            settling = math.inf
        out.append(Sway(spec.joint_names[j], amplitude, settling))
    return out


class HangingController:
    """A controller of the :func:`suspended` arm driving the whole arm: it sees the actuated
    joints' states, commands them (the passive joints get 0, which they ignore), and adds to
    the run the suspension point it tracks (``p_suspension``, m, which the tracking metrics and
    the health verdict judge instead of the hanging end effector). Everything else is the inner
    controller's (its sample time, reference, log and native form)."""

    def __init__(self, inner: Any, spec: ManipulatorSpec) -> None:
        self.inner, self.spec = inner, spec
        self.n = spec.n
        self.actuated = suspended(spec).n

    def __getattr__(self, name: str) -> object:
        if name.startswith("__") or name == "inner":  # copying and unpickling ask before init
            raise AttributeError(name)
        return getattr(self.inner, name)

    def __setattr__(self, name: str, value: object) -> None:
        if name == "tolerances":  # the run's verdict reads the inner controller's
            setattr(self.inner, name, value)
        object.__setattr__(self, name, value)

    def reset(self, state: object = None) -> None:
        reset = getattr(self.inner, "reset", None)
        if callable(reset):
            reset(_Actuated(state, self.actuated) if state is not None else None)

    def __call__(self, t: float, state: object) -> np.ndarray:
        out = np.zeros(self.n)
        out[:self.actuated] = np.asarray(self.inner(t, _Actuated(state, self.actuated)),
                                         dtype=float)
        return out

    def output(self, t: float, state: object) -> np.ndarray:
        return self(t, state)

    def native(self, plant: object, times: np.ndarray) -> object:
        """The inner controller's C form: it reads the first joints' states and writes their
        commands, which are the actuated ones (the passive joints end the chain)."""
        native = getattr(self.inner, "native", None)
        return native(_Sized(plant, self.actuated), times) if callable(native) else None

    def annotate(self, run: Run) -> Run:
        """The inner controller's log (its per-joint signals widened to every joint, NaN at the
        passive ones) and ``p_suspension``."""
        from maniplab.model import AnalyticModel

        annotate = getattr(self.inner, "annotate", None)
        out = annotate(run) if callable(annotate) else run
        per_joint = set(getattr(self.inner, "log_signals", {})) - TASK_SIGNALS
        signals = {}
        for name, values in out.signals.items():
            values = np.asarray(values)
            if name in per_joint and values.ndim == 2 and values.shape[1] == self.actuated:
                wide = np.full((values.shape[0], self.n), np.nan)
                wide[:, :self.actuated] = values
                values = wide
            signals[name] = values
        model = AnalyticModel(suspended(self.spec))
        signals["p_suspension"] = model.fk(np.asarray(run.q)[:, :self.actuated])[:, :3, 3]
        meta = dict(out.meta)
        meta["units"] = {**dict(meta.get("units") or {}), "p_suspension": "m"}
        return type(out)(t=out.t, signals=signals, spec=out.spec, meta=meta)

    def __deepcopy__(self, memo: dict[int, object]) -> HangingController:
        import copy

        return HangingController(copy.deepcopy(self.inner, memo), self.spec)


class _Actuated:
    """A plant state seen by the suspended arm's controller: each per-joint field (q, qd, dP,
    a plugin's state such as pA) cut to the actuated joints."""

    def __init__(self, state: object, n: int) -> None:
        self._state, self._n = state, n

    def _cut(self, value: object) -> object:
        if isinstance(value, dict):
            return {k: self._cut(v) for k, v in value.items()}
        if isinstance(value, np.ndarray) and value.ndim == 1 and value.size > self._n:
            return value[:self._n]
        return value

    def __getattr__(self, name: str) -> object:
        if name.startswith("__") or name in ("_state", "_n"):
            raise AttributeError(name)
        state = self._state
        value = state.get(name) if isinstance(state, dict) else getattr(state, name)
        return self._cut(value)


class _Sized:
    """The plant as the suspended arm's controller sees it: its first ``n`` joints."""

    def __init__(self, plant: object, n: int) -> None:
        self._plant, self.n = plant, n

    def __getattr__(self, name: str) -> object:
        if name.startswith("__") or name == "_plant":
            raise AttributeError(name)
        return getattr(self._plant, name)
