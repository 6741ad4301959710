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

Each pose's rating is the least of what holds it (``cause``):

- ``"holding"``: the actuators' holding ranges, as above;
- ``"structure"``: each joint's structural limit ``max_moment`` M_j (the spec's rating data):
  the payload at which |G_j(q) + m h_j(q)| reaches M_j, the same linear form as the holding
  (the safety factor does not divide it: it is an allowable load already);
- ``"tipping"``: with a ``base`` in the spec, the payload at which the whole machine's centre of
  gravity (the base's mass at its COM, every link's mass at its COM at q, the payload at its
  centre of gravity), moved along gravity onto the support plane, reaches an edge of the
  footprint. For an edge with outward normal n and offset d (inside: n·x <= d) the combined
  centre (S0 + m p)/(M0 + m) reaches it at m = (d M0 - n·S0)/(n·p - d), where the payload's
  point p lies beyond it (n·p > d); M0, S0 the mass and first moment without the payload, on
  the plane. That payload is divided by a ``stability`` factor (the tipping load over the
  rated load). A machine that tips without a payload at q is rated 0 there.

On a ``slope`` (degrees) gravity is tilted by that angle towards the base's +x (the ground falls
along +x): holding, structure and tipping are all taken with the tilted gravity, and a slew (a
rotational joint whose axis is along the spec's gravity) then carries a torque its drive must
hold (its holding range) and its structure carry (its ``max_moment``). A slew is then charted
over its range, and the figure rates each point at the least over the slew (all round).

The chart is drawn as crane makers draw theirs: payload over horizontal reach (distance from the
vertical axis through the base) and height (along -g, the spec's gravity even on a slope: the
machine's own axes).
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

CAUSES = ("holding", "structure", "tipping")
"""What limits a pose's rating: an actuator's holding range, a joint's structural limit, the
machine's stability against tipping."""

MAX_POSES = 20_000
"""Default bound on the poses of a chart's grid (points per joint follow from it)."""

SLEW_POINTS = 24
"""Default points of a slew the grid spans (every 15° of a full turn): the others get more."""


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
        joint: index of the limiting joint, shape (P,) (-1 where none limits, and where the
            machine tips).
        gravity: the spec's gravity vector, m/s², shape (3,) (the chart's reach and height;
            on a ``slope`` the loads are taken with it tilted).
        rating: the working pressure, Pa, or None (the reliefs').
        safety: the factor every holding range is divided by.
        cause: what limits each pose, one of :data:`CAUSES`, shape (P,) ("" where nothing
            limits).
        edge: the footprint edge the machine tips over (its first corner's index), shape (P,)
            (-1 where tipping does not limit).
        stability: the factor the tipping payload is divided by.
        slope: the ground's slope, degrees (gravity tilted towards the base's +x).
        shape: the grid's values per joint (``q`` is their combinations, the last joint's
            fastest).
        slews: the joints whose axis is along the spec's gravity (their torque comes from a
            slope only) and which the grid spans.
    """

    spec: ManipulatorSpec
    q: np.ndarray
    position: np.ndarray
    payload: np.ndarray
    joint: np.ndarray
    gravity: np.ndarray
    rating: float | None = None
    safety: float = 1.0
    cause: np.ndarray = dataclasses.field(default_factory=lambda: np.array([], dtype=str))
    edge: np.ndarray = dataclasses.field(default_factory=lambda: np.array([], dtype=int))
    stability: float = 1.0
    slope: float = 0.0
    shape: tuple[int, ...] = ()
    slews: tuple[int, ...] = ()

    @property
    def rule(self) -> str:
        """What the chart counts on, in words."""
        pressure = ("up to its relief pressure (else supply)" if self.rating is None else
                    f"up to the working pressure {self.rating / 1e6:g} MPa")
        factor = "" if self.safety == 1.0 else f", every holding range over a safety factor " \
                                                f"of {self.safety:g}"
        words = [f"valves closed; each cylinder {pressure}{factor}"]
        if any(joint.max_moment is not None for joint in self.spec.joints):
            words.append("structural limits")
        if self.spec.base is not None:
            words.append("tipping" + ("" if self.stability == 1.0 else
                                      f" over a stability factor of {self.stability:g}"))
        if self.slope:
            words.append(f"on a {self.slope:g}° slope")
        return "; ".join(words) + "; friction not counted"

    @property
    def height(self) -> np.ndarray:
        """Height of the payload above the base, along -g, m, shape (P,)."""
        return reach_height(self.position, self.gravity)[1]

    @property
    def reach(self) -> np.ndarray:
        """Horizontal distance of the payload from the vertical axis through the base, m, (P,)."""
        return reach_height(self.position, self.gravity)[0]

    def limiting(self, k: int) -> str | None:
        """Name of the joint that limits pose ``k`` (None: none does, or the machine tips)."""
        j = int(self.joint[k])
        return self.spec.joints[j].name if j >= 0 else None

    def describe(self, k: int) -> str:
        """What limits pose ``k``, in words: the cause and the joint, or the tipping edge."""
        cause = str(self.cause[k])
        if cause == "tipping":
            assert self.spec.base is not None
            corners = self.spec.base.footprint
            e = int(self.edge[k])
            a, b = corners[e], corners[(e + 1) % len(corners)]
            return f"tipping over the footprint's edge {list(a)}-{list(b)}"
        return f"{self.limiting(k)} ({cause})" if cause else "no limit"

    def all_round(self) -> np.ndarray:
        """For each pose, the index of the pose that rates it whatever the slews' angles: the
        least payload over the slews' values, the other joints as at the pose. Shape (P,);
        ``arange(P)`` without a slew in the grid."""
        index = np.arange(len(self.q))
        if not self.slews:
            return index
        payload = self.payload.reshape(self.shape)
        picked = index.reshape(self.shape)
        for axis in self.slews:
            at = np.argmin(payload, axis=axis)
            payload = np.take_along_axis(payload, np.expand_dims(at, axis), axis)
            picked = np.take_along_axis(picked, np.expand_dims(at, axis), axis)
        return np.broadcast_to(picked, self.shape).reshape(-1)

    def to_dict(self) -> dict[str, Any]:
        """Plain data for JSON: the arm, the rule, and per pose q, reach, height, payload and
        the limiting joint (payload null where no joint limits it), the cause and the tipping
        edge (null unless the machine tips)."""
        reach, height = self.reach, self.height
        return {
            "spec": self.spec.name,
            "joints": list(self.spec.joint_names),
            "rule": self.rule,
            "slope_deg": self.slope,
            "poses": [{"q": self.q[k].tolist(), "reach_m": float(reach[k]),
                       "height_m": float(height[k]),
                       "payload_kg": float(self.payload[k]) if math.isfinite(self.payload[k])
                       else None,
                       "limited_by": self.limiting(k),
                       "cause": str(self.cause[k]) or None,
                       "edge": int(self.edge[k]) if self.edge[k] >= 0 else None}
                      for k in range(len(self.q))],
        }


def load_chart(spec: SpecLike, *, points: int | None = None, max_poses: int = MAX_POSES,
               rating: float | None = None, safety: float = 1.0, stability: float = 1.0,
               slope: float = 0.0) -> LoadChart:
    """The load chart of ``spec`` over a grid of poses within its joint limits.

    Args:
        spec: a spec, a spec file or a built-in name.
        points: grid points per joint (default: as many as keep the grid within ``max_poses``,
            a slew the grid spans at most :data:`SLEW_POINTS` of them).
        max_poses: bound on the grid's size when ``points`` is not given.
        rating: a working pressure rating, Pa: every hydraulic actuator holds up to it instead
            of its relief's setting (None: the relief's, else the supply's).
        safety: a safety factor (at least 1) every holding range is divided by.
        stability: a stability factor (at least 1) the tipping payload is divided by (with a
            ``base`` in the spec).
        slope: the ground's slope, degrees in [0, 90): gravity tilted by it towards the base's
            +x.

    Raises:
        LoadChartError: the arm has no gravity, an actuator declares no holding range, or a bad
            rating, safety or stability factor or slope.
    """
    spec, links = _suspension(resolve_spec(spec))
    if rating is not None and not (math.isfinite(rating) and rating > 0.0):
        raise LoadChartError(f"rating {rating!r}: a working pressure is a positive number of "
                             "pascals")
    if not (math.isfinite(safety) and safety >= 1.0):
        raise LoadChartError(f"safety factor {safety!r}: it must be a number of at least 1")
    if not (math.isfinite(stability) and stability >= 1.0):
        raise LoadChartError(f"stability factor {stability!r}: it must be a number of at least 1")
    if not (math.isfinite(slope) and 0.0 <= slope < 90.0):
        raise LoadChartError(f"slope {slope!r}: it must be a number of degrees in [0, 90)")
    statics = Statics(spec, rating, safety, stability, slope)
    idle = statics.idle_joints()
    slews = tuple(j for j in statics.slew_joints() if j not in idle)
    if points is None:
        active = max(1, spec.n - len(idle))
        points = max(2, math.floor(max_poses ** (1.0 / active) + 1e-9))
        if slews and active > len(slews) and points > SLEW_POINTS:
            rest = max_poses / SLEW_POINTS ** len(slews)
            points = max(2, math.floor(rest ** (1.0 / (active - len(slews))) + 1e-9))
            counts = [SLEW_POINTS if j in slews else points for j in range(spec.n)]
        else:
            counts = [points] * spec.n
    else:
        counts = [points] * spec.n
    poses = grid(spec, counts, idle)
    shape = tuple(1 if j in idle else counts[j] for j in range(spec.n))
    rated = [statics.rate(q) for q in poses]
    return LoadChart(spec, poses, np.array([r.position for r in rated]),
                     np.maximum(np.array([r.payload for r in rated]) - links, 0.0),
                     np.array([r.joint for r in rated], dtype=int),
                     np.asarray(spec.gravity, dtype=float), rating, safety,
                     np.array([r.cause for r in rated], dtype=str),
                     np.array([r.edge for r in rated], dtype=int), stability, slope, shape, slews)


def _suspension(spec: ManipulatorSpec) -> tuple[ManipulatorSpec, float]:
    """The arm a chart rates, and the mass its payload carries besides the payload, kg: on an
    arm whose tool hangs on passive joints, the actuated chain rated at the suspension point
    (the hanging tool's weight acts there at rest) and the passive links' mass (the tool's own,
    which the payload the chart gives excludes); the arm itself and 0 otherwise."""
    from maniplab.control.suspended import passive_joints, suspended

    if not passive_joints(spec):
        return spec, 0.0
    chain = suspended(spec)
    links = chain.end_effector.mass - spec.end_effector.mass
    return chain.with_overrides({"end_effector.mass": spec.end_effector.mass,
                                 "name": spec.name}), links


@dataclasses.dataclass(frozen=True)
class Rated:
    """One pose's rating: the payload, what limits it, and where the payload is."""

    payload: float
    cause: str
    joint: int
    edge: int
    position: np.ndarray


def grid(spec: ManipulatorSpec, points: int | list[int],
         idle: frozenset[int] = frozenset()) -> np.ndarray:
    """Every combination of ``points`` values per joint (one count for all, or one per joint),
    strictly inside its limits (a stop
    would hold a load there; ±π for an unlimited joint), an ``idle`` joint at the middle of its
    range only. Shape (P, n)."""
    axes = []
    counts = [points] * spec.n if isinstance(points, int) else points
    for j, joint in enumerate(spec.joints):
        low, high = joint.limits or (-math.pi, math.pi)
        if j in idle:
            axes.append(np.array([0.5 * (low + high)]))
        elif joint.limits:
            axes.append(np.linspace(low, high, counts[j] + 2)[1:-1])
        else:
            axes.append(np.linspace(low, high, counts[j], endpoint=False))
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, spec.n)


class Statics:
    """The gravity loads of an arm at rest, from its MuJoCo model without the payload."""

    def __init__(self, spec: ManipulatorSpec, rating: float | None = None,
                 safety: float = 1.0, stability: float = 1.0, slope: float = 0.0) -> None:
        self.spec, self.rating, self.safety = spec, rating, safety
        self.stability, self.base = stability, spec.base
        if not np.any(spec.gravity):
            raise LoadChartError(f"{_where(spec)}no gravity (gravity: [0, 0, 0]): nothing to "
                                 "hold, no load chart")
        self.gravity = tilted(np.asarray(spec.gravity, dtype=float), slope)
        self.structure = np.array([math.inf if joint.max_moment is None else joint.max_moment
                                   for joint in spec.joints])
        self.actuators = [model_of(joint) for joint in spec.joints]
        # The arm's own model with the payload's mass and inertia taken out after compiling: a
        # spec without them may be refused (a rotator that turns only the payload drives no mass).
        self.model = build_model(spec)
        self.body = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, END_EFFECTOR)
        self.model.body_mass[self.body] = 0.0
        self.model.body_inertia[self.body] = 0.0
        self.model.opt.gravity[:] = self.gravity
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
        self._cog = cog
        return self._bias.copy(), -self._jac.T @ self.gravity, position

    def rate(self, q: np.ndarray) -> Rated:
        """The rating of pose q: the least of holding, structure and tipping."""
        g, h, position = self.loads(q)
        held, holder = self.largest(g, h, q)
        carried, carrier = _room(g, h, -self.structure, self.structure)
        stands, edge = self.tipping()
        options = [(held, holder, -1), (carried, carrier, -1), (stands, -1, edge)]
        k = min(range(3), key=lambda i: options[i][0])  # ties: holding, structure, tipping
        payload, joint, edge = options[k]
        if not math.isfinite(payload):
            return Rated(math.inf, "", -1, -1, position)
        return Rated(payload, CAUSES[k], joint, edge, position)

    def moments(self) -> tuple[float, np.ndarray, np.ndarray]:
        """At the pose of the last :meth:`loads`: the machine's mass without the payload (kg),
        its first moment (kg·m) and the payload's point (m), on the support plane along gravity,
        each [x, y] shape (2,)."""
        assert self.base is not None
        masses = self.model.body_mass[1:]
        points = self.base.project(self.data.xipos[1:], self.gravity)
        mass = self.base.mass + float(masses.sum())
        moment = self.base.mass * self.base.project(np.asarray(self.base.com), self.gravity) + \
            masses @ points
        return mass, moment, self.base.project(self._cog, self.gravity)

    def tipping(self) -> tuple[float, int]:
        """At the pose of the last :meth:`loads`: the largest payload before the machine tips,
        over the stability factor (inf without a base), and the edge it tips over (-1: none)."""
        if self.base is None:
            return math.inf, -1
        mass, moment, point = self.moments()
        normals, offsets = self.base.edges()
        room = offsets * mass - normals @ moment
        if room.min() < 0.0:  # it tips without a payload
            return 0.0, int(np.argmin(room))
        beyond = normals @ point - offsets
        with np.errstate(divide="ignore"):
            largest = np.where(beyond > 0.0, room / np.where(beyond > 0.0, beyond, 1.0), np.inf)
        e = int(np.argmin(largest))
        return (float(largest[e]) / self.stability, e) if math.isfinite(largest[e]) else \
            (math.inf, -1)

    def slew_joints(self) -> tuple[int, ...]:
        """The rotational joints whose axis is along the spec's gravity (slews)."""
        down = np.asarray(self.spec.gravity, dtype=float)
        down /= np.linalg.norm(down)
        return tuple(j for j, joint in enumerate(self.spec.joints)
                     if not joint.prismatic and abs(abs(joint.axis_vector @ down) - 1.0) < 1e-12)

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
        reach, height = reach_height(position, np.asarray(self.spec.gravity, dtype=float))
        tipping = np.r_[self.moments()[1:]] if self.base is not None else np.zeros(0)
        return np.r_[g, h, low, high, reach, height, tipping]

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
        return _room(g, h, *self.ranges(q))


def _room(g: np.ndarray, h: np.ndarray, low: np.ndarray, high: np.ndarray) -> tuple[float, int]:
    """The largest m >= 0 at which every joint's load g + m h stays within [low, high], and the
    joint that bounds it (-1: none): (0, j) where the arm alone is beyond joint j's range."""
    over = np.flatnonzero((g < low) | (g > high))
    if over.size:  # the arm alone is more than that joint holds
        return 0.0, int(over[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        room = np.where(h > 0.0, (high - g) / h, np.where(h < 0.0, (low - g) / h, np.inf))
    j = int(np.argmin(room))
    return (float(room[j]), j) if math.isfinite(room[j]) else (math.inf, -1)


def tilted(gravity: np.ndarray, slope: float) -> np.ndarray:
    """``gravity`` tilted by ``slope`` degrees towards the base's +x (towards +y when gravity is
    along x): the gravity of a machine standing on ground that falls along +x."""
    if slope == 0.0:
        return gravity
    norm = float(np.linalg.norm(gravity))
    down = gravity / norm
    for axis in np.eye(3)[:2]:
        downhill = axis - (axis @ down) * down
        if np.linalg.norm(downhill) > 1e-6:
            break
    downhill /= np.linalg.norm(downhill)
    angle = math.radians(slope)
    return norm * (math.cos(angle) * down + math.sin(angle) * downhill)


def reach_height(position: np.ndarray, gravity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal reach (distance from the vertical axis through the base) and height (along
    -g) of ``position`` (m, shape (..., 3)), each shape (...)."""
    down = np.asarray(gravity, dtype=float) / np.linalg.norm(gravity)
    height = -(position @ down)
    return np.linalg.norm(position + height[..., None] * down, axis=-1), height


def _where(spec: ManipulatorSpec) -> str:
    return f"{spec.source}: " if spec.source else ""
