"""Cartesian reference trajectories: minimum-jerk moves, arcs, holds and via-point sequences.

A trajectory maps time to a :class:`Reference` (pose, twist and its derivative in base axes).
Every segment follows the minimum-jerk profile s(τ) = 10τ³ - 15τ⁴ + 6τ⁵, τ = (t - t0)/T, which
starts and ends at rest with zero acceleration (Flash and Hogan 1985); a sequence of segments
therefore stops at each via point. Orientation moves about one fixed axis (in base axes):
R(t) = exp(s(t) w) R0 with w = log(R1 R0ᵀ), so ω = ṡ w and ω̇ = s̈ w.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from maniplab.control.errors import TrajectoryError
from maniplab.control.kinematics import matrix_to_rpy, rotation_exp, rotation_log, rpy_to_matrix


def min_jerk(tau: float) -> tuple[float, float, float]:
    """Minimum-jerk profile at normalised time τ (clipped to [0, 1]): (s, ds/dτ, d²s/dτ²)."""
    t = min(max(tau, 0.0), 1.0)
    t2 = t * t
    return (t2 * t * (10.0 - 15.0 * t + 6.0 * t2),
            30.0 * t2 * (1.0 - 2.0 * t + t2),
            60.0 * t * (1.0 - 3.0 * t + 2.0 * t2))


@dataclasses.dataclass(frozen=True, eq=False)
class Pose:
    """A Cartesian pose: position p (3,), m, and rotation matrix R (3, 3), base axes."""

    position: np.ndarray
    rotation: np.ndarray = dataclasses.field(default_factory=lambda: np.eye(3))

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", np.asarray(self.position, dtype=float).reshape(3))
        object.__setattr__(self, "rotation", np.asarray(self.rotation, dtype=float).reshape(3, 3))

    @classmethod
    def from_xyzrpy(cls, values: Sequence[float]) -> Pose:
        """From [x, y, z] or [x, y, z, roll, pitch, yaw] (m, rad; R = Rz(yaw) Ry(pitch) Rx(roll))."""
        v = [float(x) for x in values]
        if len(v) not in (3, 6):
            raise TrajectoryError(f"expected 3 or 6 values (x,y,z[,roll,pitch,yaw]), got {len(v)}")
        return cls(np.array(v[:3]), rpy_to_matrix(*v[3:]) if len(v) == 6 else np.eye(3))

    @classmethod
    def from_matrix(cls, H: ArrayLike) -> Pose:
        """From a 4x4 homogeneous transform (e.g. ``AnalyticModel.fk``)."""
        H = np.asarray(H, dtype=float)
        return cls(H[:3, 3].copy(), H[:3, :3].copy())

    @property
    def rpy(self) -> np.ndarray:
        """(roll, pitch, yaw), rad, shape (3,)."""
        return matrix_to_rpy(self.rotation)

    @property
    def xyzrpy(self) -> np.ndarray:
        """[x, y, z, roll, pitch, yaw], shape (6,)."""
        return np.concatenate([self.position, self.rpy])

    def translated(self, offset: ArrayLike) -> Pose:
        """The same orientation, moved by ``offset`` (3,), m, in base axes."""
        return Pose(self.position + np.asarray(offset, dtype=float), self.rotation)


@dataclasses.dataclass(frozen=True, eq=False)
class Reference:
    """The reference at one instant, base axes.

    Attributes:
        position: p_d, m, (3,).  rotation: R_d, (3, 3).
        twist: [ṗ_d (m/s); ω_d (rad/s)], (6,).  accel: [p̈_d (m/s²); ω̇_d (rad/s²)], (6,).
    """

    position: np.ndarray
    rotation: np.ndarray
    twist: np.ndarray
    accel: np.ndarray

    @classmethod
    def of(cls, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray,
           rotation: np.ndarray, angular_velocity: np.ndarray,
           angular_acceleration: np.ndarray) -> Reference:
        """From the six parts (each (3,), rotation (3, 3))."""
        return cls(position, rotation, np.concatenate([velocity, angular_velocity]),
                   np.concatenate([acceleration, angular_acceleration]))

    @property
    def velocity(self) -> np.ndarray:
        """ṗ_d, m/s, (3,)."""
        return self.twist[:3]

    @property
    def acceleration(self) -> np.ndarray:
        """p̈_d, m/s², (3,)."""
        return self.accel[:3]

    @property
    def angular_velocity(self) -> np.ndarray:
        """ω_d, rad/s, (3,)."""
        return self.twist[3:]

    @property
    def angular_acceleration(self) -> np.ndarray:
        """ω̇_d, rad/s², (3,)."""
        return self.accel[3:]

    @property
    def pose(self) -> Pose:
        """The reference pose (p_d, R_d)."""
        return Pose(self.position, self.rotation)


class Trajectory(Protocol):
    """Anything that gives a reference at time t, with a start time, duration, start and end pose.

    The members are read-only: frozen dataclasses and properties satisfy them.
    """

    @property
    def t0(self) -> float:
        """Start time, s."""
        ...

    @property
    def duration(self) -> float:
        """Duration, s."""
        ...

    @property
    def start(self) -> Pose:
        """The pose at the start."""
        ...

    @property
    def end(self) -> Pose:
        """The pose at the end."""
        ...

    def sample(self, t: float) -> Reference:
        """The reference at time t, s."""
        ...


def _at_rest(pose: Pose) -> Reference:
    return Reference(pose.position.copy(), pose.rotation.copy(), np.zeros(6), np.zeros(6))


@dataclasses.dataclass(frozen=True, eq=False)
class Hold:
    """Stay at ``pose`` from t0 for ``duration`` s."""

    pose: Pose
    duration: float
    t0: float = 0.0

    @property
    def start(self) -> Pose:
        """The pose at the start."""
        return self.pose

    @property
    def end(self) -> Pose:
        """The pose at the end."""
        return self.pose

    def sample(self, t: float) -> Reference:
        """The reference at time t, s."""
        return _at_rest(self.pose)


@dataclasses.dataclass(frozen=True, eq=False)
class MinJerkMove:
    """Minimum-jerk straight-line move from ``start`` to ``goal`` in ``duration`` s from t0.

    The position moves along the straight line; the orientation turns about the fixed axis of
    log(R_goal R_startᵀ). Before t0 the reference is ``start``, after t0 + duration ``goal``.
    """

    start: Pose
    goal: Pose
    duration: float
    t0: float = 0.0
    # derived in __post_init__: rotation axis-angle w (3,) and [goal - start position; w] (6,)
    _w: np.ndarray = dataclasses.field(init=False, repr=False)
    _dpw: np.ndarray = dataclasses.field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not self.duration > 0.0:
            raise TrajectoryError(f"duration must be > 0, got {self.duration!r}")
        dp = self.goal.position - self.start.position
        w = rotation_log(self.goal.rotation @ self.start.rotation.T)
        object.__setattr__(self, "_w", w)
        object.__setattr__(self, "_dpw", np.concatenate([dp, w]))

    @property
    def end(self) -> Pose:
        """The pose at the end."""
        return self.goal

    def sample(self, t: float) -> Reference:
        """The reference at time t, s."""
        T = self.duration
        s, ds, dds = min_jerk((t - self.t0) / T)
        w, dpw = self._w, self._dpw
        R = rotation_exp(s * w) @ self.start.rotation if s and w.any() else self.start.rotation
        return Reference(self.start.position + s * dpw[:3], R, (ds / T) * dpw,
                         (dds / T**2) * dpw)


@dataclasses.dataclass(frozen=True, eq=False)
class ArcMove:
    """Rotate ``start`` by ``angle`` rad about a fixed axis through ``center``, minimum-jerk in time.

    Position and orientation turn together (the pose is carried rigidly), as a tunnel erector
    turns a segment about the tunnel axis to its ring position.

    Attributes:
        start: the initial pose.  axis: rotation axis, unit vector (3,), base axes.
        center: a point on the axis, m, (3,).  angle: rad.  duration: s.  t0: start time, s.
    """

    start: Pose
    axis: np.ndarray
    center: np.ndarray
    angle: float
    duration: float
    t0: float = 0.0

    def __post_init__(self) -> None:
        if not self.duration > 0.0:
            raise TrajectoryError(f"duration must be > 0, got {self.duration!r}")
        a = np.asarray(self.axis, dtype=float)
        object.__setattr__(self, "axis", a / np.linalg.norm(a))
        object.__setattr__(self, "center", np.asarray(self.center, dtype=float))

    @property
    def end(self) -> Pose:
        """The pose at the end."""
        Rz = rotation_exp(self.angle * self.axis)
        return Pose(self.center + Rz @ (self.start.position - self.center), Rz @ self.start.rotation)

    @property
    def length(self) -> float:
        """Arc length of the position's path, m."""
        r = self.start.position - self.center
        return abs(self.angle) * float(np.linalg.norm(r - (r @ self.axis) * self.axis))

    def sample(self, t: float) -> Reference:
        """The reference at time t, s."""
        T = self.duration
        s, ds, dds = min_jerk((t - self.t0) / T)
        k = self.axis
        Rz = rotation_exp(s * self.angle * k)
        r = Rz @ (self.start.position - self.center)
        w, wd = ds / T * self.angle, dds / T**2 * self.angle
        kr = np.cross(k, r)
        return Reference.of(self.center + r, w * kr, wd * kr + w * w * np.cross(k, kr),
                            Rz @ self.start.rotation, w * k, wd * k)


@dataclasses.dataclass(frozen=True, eq=False)
class Path:
    """Segments run one after another (each segment's t0 is set from the previous one's end).

    Build it with :meth:`via_points` or from segments with relative start times 0.
    """

    segments: tuple[Any, ...]
    t0: float = 0.0
    names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.segments:
            raise TrajectoryError("a path needs at least one segment")
        t = self.t0
        placed = []
        for seg in self.segments:
            placed.append(dataclasses.replace(seg, t0=t))
            t += seg.duration
        object.__setattr__(self, "segments", tuple(placed))
        if self.names and len(self.names) != len(self.segments):
            raise TrajectoryError(f"{len(self.names)} names for {len(self.segments)} segments")

    @classmethod
    def via_points(cls, poses: Sequence[Pose], durations: Sequence[float], *,
                   dwell: float = 0.0, t0: float = 0.0) -> Path:
        """Minimum-jerk moves through ``poses`` (stopping at each), ``dwell`` s at each via point.

        Args:
            poses: k >= 2 poses, the first is the start.
            durations: k - 1 move durations, s.
            dwell: hold time at each intermediate pose, s.
            t0: start time, s.
        """
        if len(poses) < 2 or len(durations) != len(poses) - 1:
            raise TrajectoryError(f"expected k >= 2 poses and k - 1 durations, got {len(poses)} "
                                  f"poses and {len(durations)} durations")
        segs: list[Any] = []
        for i, T in enumerate(durations):
            if i and dwell > 0.0:
                segs.append(Hold(poses[i], dwell))
            segs.append(MinJerkMove(poses[i], poses[i + 1], T))
        return cls(tuple(segs), t0=t0)

    @property
    def duration(self) -> float:
        """Total duration, s."""
        return sum(seg.duration for seg in self.segments)

    @property
    def start(self) -> Pose:
        """The first pose."""
        return self.segments[0].start

    @property
    def end(self) -> Pose:
        """The last pose."""
        return self.segments[-1].end

    def segment_at(self, t: float) -> int:
        """Index of the segment active at time t (the first before t0, the last after the end)."""
        for i, seg in enumerate(self.segments):
            if t < seg.t0 + seg.duration:
                return i
        return len(self.segments) - 1

    def sample(self, t: float) -> Reference:
        """The reference at time t, s."""
        return self.segments[self.segment_at(t)].sample(t)


def segment_placement(pick: Pose, *, lift: float = 0.3, ring_angle: float = 0.3,
                      push: float = 0.2, durations: Sequence[float] = (2.0, 4.0, 2.0),
                      dwell: float = 0.5, up: ArrayLike = (0.0, 1.0, 0.0),
                      tunnel_axis: ArrayLike = (0.0, 0.0, 1.0), t0: float = 0.0) -> Path:
    """The segment-placement manoeuvre of a tunnel erector, as a via-point path.

    1. *pick*: lift the segment off the feeder by ``lift`` m along ``up``;
    2. *rotate*: turn it about the tunnel axis (through the base origin) by ``ring_angle`` rad to
       its ring position (position and orientation together, an arc);
    3. *push*: push it home by ``push`` m along the tunnel axis.

    Each move is minimum-jerk; the path holds ``dwell`` s between moves.

    Args:
        pick: the segment's pose on the feeder (the start).
        lift: the lift off the feeder, m.
        ring_angle: the turn about the tunnel axis, rad.
        push: the push home, m.
        durations: the three move durations, s.
        dwell: hold between moves, s.
        up: lift direction (against gravity), (3,).
        tunnel_axis: the erector's rotation and push axis, (3,).
        t0: start time, s.
    """
    up_v = np.asarray(up, dtype=float) / np.linalg.norm(up)
    axis = np.asarray(tunnel_axis, dtype=float) / np.linalg.norm(tunnel_axis)
    lifted = pick.translated(lift * up_v)
    rotate = ArcMove(lifted, axis, np.zeros(3), ring_angle, durations[1])
    ring = rotate.end
    segs: list[Any] = [MinJerkMove(pick, lifted, durations[0])]
    names = ["pick"]
    if dwell > 0.0:
        segs.append(Hold(lifted, dwell))
        names.append("dwell")
    segs.append(rotate)
    names.append("rotate")
    if dwell > 0.0:
        segs.append(Hold(ring, dwell))
        names.append("dwell")
    segs.append(MinJerkMove(ring, ring.translated(push * axis), durations[2]))
    names.append("push")
    return Path(tuple(segs), t0=t0, names=tuple(names))

