"""Load charts: the largest payload the arm holds at each pose, and the joint that limits it.

At rest with the valves closed, the actuators hold the gravity load

    τ(q, m) = G(q) + m h(q),        h(q) = -J(q)ᵀ g

G the arm's own load (no payload), J the Jacobian of the payload's centre of gravity (the
end-effector point, moved by ``end_effector.com`` when the spec gives one; the chart places the
payload at the end-effector point), g the gravity vector and m the payload, kg: linear in m. The
payload's inertia plays no part at rest. Each actuator holds forces
within its holding range (:meth:`~maniplab.actuators.ActuatorPlugin.holding_range`: a cylinder
±A p_max, p_max its relief pressure or else its supply pressure; a torque source ±limit), so the
largest payload at q is the smallest m at which one joint's load leaves its range, and that
joint limits it. Friction is not counted (it helps to hold, by an amount a chart cannot rely on),
nor are the limit stops (the poses lie strictly inside the joint limits).

With a working pressure ``rating`` every hydraulic actuator holds up to that pressure instead
of its relief's setting, and with a ``safety`` factor every holding range is divided by it: the
chart then rates each pose at the largest payload held within the rating over the factor (as
crane makers rate holding at a working pressure with a margin, rather than at the relief valve,
which is a protection, not a rating).

The chart is drawn as crane makers draw theirs: payload over horizontal reach (distance from the
vertical axis through the base) and height (along -g).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import mujoco
import numpy as np

from maniplab.builtin import resolve_spec
from maniplab.errors import ManiplabError
from maniplab.mjcf_gen import END_EFFECTOR, build_model
from maniplab.mjcf_gen.builder import SpecLike
from maniplab.spec import ManipulatorSpec, model_of

MAX_POSES = 20_000
"""Default bound on the poses of a chart's grid (points per joint follow from it)."""


class LoadChartError(ManiplabError):
    """No load chart for this arm (no gravity, or an actuator that declares no holding range)."""


@dataclasses.dataclass(frozen=True, eq=False)
class LoadChart:
    """The largest payload at each pose of a grid.

    Attributes:
        spec: the arm (its end-effector mass is the rated payload; the chart does not use it).
        q: the poses, shape (P, n).
        position: the payload's position at each pose, m, shape (P, 3).
        payload: the largest payload held there, kg, shape (P,) (0: the arm cannot hold itself
            there; inf: no joint limits it).
        joint: index of the limiting joint, shape (P,) (-1 where none limits).
        gravity: the gravity vector, m/s², shape (3,).
    """

    spec: ManipulatorSpec
    q: np.ndarray
    position: np.ndarray
    payload: np.ndarray
    joint: np.ndarray
    gravity: np.ndarray
    rating: float | None = None
    safety: float = 1.0

    @property
    def rule(self) -> str:
        """What the chart counts on, in words."""
        pressure = ("up to its relief pressure (else supply)" if self.rating is None else
                    f"up to the working pressure {self.rating / 1e6:g} MPa")
        factor = "" if self.safety == 1.0 else f", every holding range over a safety factor " \
                                                f"of {self.safety:g}"
        return f"valves closed; each cylinder {pressure}{factor}; friction not counted"

    @property
    def height(self) -> np.ndarray:
        """Height of the payload above the base, along -g, m, shape (P,)."""
        return reach_height(self.position, self.gravity)[1]

    @property
    def reach(self) -> np.ndarray:
        """Horizontal distance of the payload from the vertical axis through the base, m, (P,)."""
        return reach_height(self.position, self.gravity)[0]

    def limiting(self, k: int) -> str | None:
        """Name of the joint that limits pose ``k`` (None: none does)."""
        j = int(self.joint[k])
        return self.spec.joints[j].name if j >= 0 else None

    def to_dict(self) -> dict[str, Any]:
        """Plain data for JSON: the arm, the rule, and per pose q, reach, height, payload and
        the limiting joint (payload null where no joint limits it)."""
        reach, height = self.reach, self.height
        return {
            "spec": self.spec.name,
            "joints": list(self.spec.joint_names),
            "rule": self.rule,
            "poses": [{"q": self.q[k].tolist(), "reach_m": float(reach[k]),
                       "height_m": float(height[k]),
                       "payload_kg": float(self.payload[k]) if math.isfinite(self.payload[k])
                       else None,
                       "limited_by": self.limiting(k)} for k in range(len(self.q))],
        }


def load_chart(spec: SpecLike, *, points: int | None = None, max_poses: int = MAX_POSES,
               rating: float | None = None, safety: float = 1.0) -> LoadChart:
    """The load chart of ``spec`` over a grid of poses within its joint limits.

    Args:
        spec: a spec, a spec file or a built-in name.
        points: grid points per joint (default: as many as keep the grid within ``max_poses``).
        max_poses: bound on the grid's size when ``points`` is not given.
        rating: a working pressure rating, Pa: every hydraulic actuator holds up to it instead
            of its relief's setting (None: the relief's, else the supply's).
        safety: a safety factor (at least 1) every holding range is divided by.

    Raises:
        LoadChartError: the arm has no gravity, an actuator declares no holding range, or a bad
            rating or safety factor.
    """
    spec = resolve_spec(spec)
    if rating is not None and not (math.isfinite(rating) and rating > 0.0):
        raise LoadChartError(f"rating {rating!r}: a working pressure is a positive number of "
                             "pascals")
    if not (math.isfinite(safety) and safety >= 1.0):
        raise LoadChartError(f"safety factor {safety!r}: it must be a number of at least 1")
    statics = Statics(spec, rating, safety)
    idle = statics.idle_joints()
    if points is None:
        active = max(1, spec.n - len(idle))
        points = max(2, math.floor(max_poses ** (1.0 / active) + 1e-9))
    poses = grid(spec, points, idle)
    loads = [statics.loads(q) for q in poses]
    positions = np.array([p for _, _, p in loads])
    best = [statics.largest(g, h, q) for (g, h, _), q in zip(loads, poses)]
    return LoadChart(spec, poses, positions, np.array([m for m, _ in best]),
                     np.array([j for _, j in best], dtype=int), statics.gravity.copy(),
                     rating, safety)


def grid(spec: ManipulatorSpec, points: int, idle: frozenset[int] = frozenset()) -> np.ndarray:
    """Every combination of ``points`` values per joint, strictly inside its limits (a stop
    would hold a load there; ±π for an unlimited joint), an ``idle`` joint at the middle of its
    range only. Shape (P, n)."""
    axes = []
    for j, joint in enumerate(spec.joints):
        low, high = joint.limits or (-math.pi, math.pi)
        if j in idle:
            axes.append(np.array([0.5 * (low + high)]))
        elif joint.limits:
            axes.append(np.linspace(low, high, points + 2)[1:-1])
        else:
            axes.append(np.linspace(low, high, points, endpoint=False))
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, spec.n)


class Statics:
    """The gravity loads of an arm at rest, from its MuJoCo model without the payload."""

    def __init__(self, spec: ManipulatorSpec, rating: float | None = None,
                 safety: float = 1.0) -> None:
        self.spec, self.rating, self.safety = spec, rating, safety
        self.gravity = np.asarray(spec.gravity, dtype=float)
        if not np.any(self.gravity):
            raise LoadChartError(f"{_where(spec)}no gravity (gravity: [0, 0, 0]): nothing to "
                                 "hold, no load chart")
        self.actuators = [model_of(joint) for joint in spec.joints]
        # The arm's own model with the payload's mass and inertia taken out after compiling: a
        # spec without them may be refused (a rotator that turns only the payload drives no mass).
        self.model = build_model(spec)
        self.body = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, END_EFFECTOR)
        self.model.body_mass[self.body] = 0.0
        self.model.body_inertia[self.body] = 0.0
        self.data = mujoco.MjData(self.model)
        self.com = np.asarray(spec.end_effector.com, dtype=float)
        self._jac = np.zeros((3, self.model.nv))
        self._bias = np.zeros(self.model.nv)

    def loads(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(G(q) without payload, h(q) per kg of payload, the end-effector point): N or N·m
        per joint, N or N·m per kg, m. The payload's weight acts at its centre of gravity."""
        m, d = self.model, self.data
        d.qpos[:] = q
        d.qvel[:] = 0.0
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_rne(m, d, 0, self._bias)  # at rest: the gravity load
        position = d.xpos[self.body].copy()
        cog = position + d.xmat[self.body].reshape(3, 3) @ self.com
        mujoco.mj_jac(m, d, self._jac, None, cog, self.body)
        return self._bias.copy(), -self._jac.T @ self.gravity, position

    def idle_joints(self, trials: int = 4) -> frozenset[int]:
        """The joints whose motion changes neither the loads, the holding ranges nor the payload's
        reach and height (a slew about the vertical axis): one value of theirs charts them all. Tried at the
        home pose and random poses, each joint over three values of its range."""
        poses = grid(self.spec, 1)
        rng = np.random.default_rng(0)
        poses = np.vstack([poses, [[rng.uniform(*(j.limits or (-math.pi, math.pi)))
                                    for j in self.spec.joints] for _ in range(trials)]])
        idle = set(range(self.spec.n))
        for q in poses:
            for j in list(idle):
                low, high = self.spec.joints[j].limits or (-math.pi, math.pi)
                seen = [self._invariants(np.r_[q[:j], x, q[j + 1:]])
                        for x in np.linspace(low, high, 5)[1:-1]]
                if not all(np.allclose(seen[0], other, rtol=1e-9, atol=1e-9) for other in seen):
                    idle.discard(j)
        return frozenset(idle)

    def _invariants(self, q: np.ndarray) -> np.ndarray:
        """What a chart shows of pose q: the loads, the holding ranges, the reach and the
        height."""
        g, h, position = self.loads(q)
        low, high = self.ranges(q)
        reach, height = reach_height(position, self.gravity)
        return np.r_[g, h, low, high, reach, height]

    def ranges(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each joint's holding range at q, (lowest, highest), N or N·m, each shape (n,)."""
        pairs = []
        for actuator, x in zip(self.actuators, q):
            try:
                pairs.append(actuator.holding_range(float(x)) if self.rating is None else
                             actuator.rated_holding_range(float(x), self.rating))
            except ManiplabError as exc:
                raise LoadChartError(f"{_where(self.spec)}{exc}") from None
        low, high = np.array(pairs, dtype=float).T
        return low / self.safety, high / self.safety

    def largest(self, g: np.ndarray, h: np.ndarray, q: np.ndarray) -> tuple[float, int]:
        """The largest payload held at q (kg) and the joint that limits it (-1: none)."""
        low, high = self.ranges(q)
        over = np.flatnonzero((g < low) | (g > high))
        if over.size:  # the arm alone is more than that joint holds
            return 0.0, int(over[0])
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(h > 0.0, (high - g) / h, np.where(h < 0.0, (low - g) / h, np.inf))
        j = int(np.argmin(room))
        return (float(room[j]), j) if math.isfinite(room[j]) else (math.inf, -1)


def reach_height(position: np.ndarray, gravity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal reach (distance from the vertical axis through the base) and height (along
    -g) of ``position`` (m, shape (..., 3)), each shape (...)."""
    down = np.asarray(gravity, dtype=float) / np.linalg.norm(gravity)
    height = -(position @ down)
    return np.linalg.norm(position + height[..., None] * down, axis=-1), height


def _where(spec: ManipulatorSpec) -> str:
    return f"{spec.source}: " if spec.source else ""
