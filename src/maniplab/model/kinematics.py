"""Homogeneous transforms of the paper's eq. (1) and geometric Jacobians, symbolically.

Frame j+1 = frame j · joint motion (rotation about, or translation along, the axis by q_j) ·
translation(length · direction). All frames coincide in orientation with the base at q = 0, so each
joint's axis, each COG and each offset is written in base axes. Vectors are lists of three
expressions, rotations lists of three rows; ``H`` matrices are 4x4 nested lists.
"""

from __future__ import annotations

import dataclasses

from maniplab.model.engine import Engine, Expr, Mat, Vec
from maniplab.model.parameters import ArmTerms
from maniplab.spec import ManipulatorSpec


@dataclasses.dataclass
class Chain:
    """Poses along the arm as expressions of the joint positions ``q``.

    Attributes:
        axes: joint j's axis in base coordinates, n vectors.
        origins: joint j's position (before its own motion), m, n vectors.
        rotations: orientation of body j's frame (after joint j's motion), n 3x3 matrices.
        positions: origin of body j's frame (after joint j's motion), m, n vectors.
        cogs: body j's centre of gravity, m, n vectors.
        ee_rotation: orientation of the end-effector frame (that of the last frame).
        ee_position: the end-effector point, m.
        payload_cog: the payload's centre of gravity (``com`` from the end-effector point), m.
        prismatic: True for a prismatic joint, n flags.
    """

    axes: list[Vec]
    origins: list[Vec]
    rotations: list[Mat]
    positions: list[Vec]
    cogs: list[Vec]
    ee_rotation: Mat
    ee_position: Vec
    payload_cog: Vec
    prismatic: list[bool]


def rotation(engine: Engine, axis: str, angle: Expr) -> Mat:
    """Rotation matrix about the base axis ``axis`` ("x", "y" or "z") by ``angle`` (rad)."""
    c, s, o, z = engine.cos(angle), engine.sin(angle), engine.one, engine.zero
    if axis == "x":
        return [[o, z, z], [z, c, -s], [z, s, c]]
    if axis == "y":
        return [[c, z, s], [z, o, z], [-s, z, c]]
    return [[c, -s, z], [s, c, z], [z, z, o]]


def matmul(a: Mat, b: Mat) -> Mat:
    """3x3 product a·b."""
    return [[a[r][0] * b[0][c] + a[r][1] * b[1][c] + a[r][2] * b[2][c] for c in range(3)]
            for r in range(3)]


def matvec(a: Mat, v: Vec) -> Vec:
    """3x3 matrix times vector."""
    return [a[r][0] * v[0] + a[r][1] * v[1] + a[r][2] * v[2] for r in range(3)]


def transpose(a: Mat) -> Mat:
    return [[a[c][r] for c in range(3)] for r in range(3)]


def add(a: Vec, b: Vec) -> Vec:
    return [x + y for x, y in zip(a, b)]


def sub(a: Vec, b: Vec) -> Vec:
    return [x - y for x, y in zip(a, b)]


def scale(a: Vec, k: Expr) -> Vec:
    return [x * k for x in a]


def cross(a: Vec, b: Vec) -> Vec:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a: Vec, b: Vec) -> Expr:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def homogeneous(engine: Engine, rot: Mat, pos: Vec) -> list[list[Expr]]:
    """4x4 homogeneous transform [[R, p], [0, 1]]."""
    z = engine.zero
    return [rot[0] + [pos[0]], rot[1] + [pos[1]], rot[2] + [pos[2]], [z, z, z, engine.one]]


def chain(spec: ManipulatorSpec, terms: ArmTerms, q: list[Expr], engine: Engine) -> Chain:
    """Every pose along the arm (eq. 1) for joint positions ``q`` (n symbols)."""
    z, o = engine.zero, engine.one
    rot: Mat = [[o, z, z], [z, o, z], [z, z, o]]
    pos: Vec = [z, z, z]
    out = Chain([], [], [], [], [], rot, pos, pos, [])
    for j, joint in enumerate(spec.joints):
        axis_index = "xyz".index(joint.axis.value)
        axis = [rot[r][axis_index] for r in range(3)]  # R_j a_j: a column of R_j
        out.axes.append(axis)
        out.origins.append(pos)
        out.prismatic.append(joint.prismatic)
        if joint.prismatic:
            pos = add(pos, scale(axis, q[j]))
        else:
            rot = matmul(rot, rotation(engine, joint.axis.value, q[j]))
        body = terms.bodies[j]
        out.rotations.append(rot)
        out.positions.append(pos)
        out.cogs.append(add(pos, matvec(rot, body.com)))
        pos = add(pos, matvec(rot, body.offset))
    out.ee_rotation = rot
    out.ee_position = add(pos, matvec(rot, terms.ee_offset))
    out.payload_cog = add(out.ee_position, matvec(rot, terms.ee_com))
    return out


def point_jacobian(ch: Chain, point: Vec, upto: int, engine: Engine) -> tuple[list[Vec], list[Vec]]:
    """Geometric Jacobian of a point fixed to body ``upto`` (0-based), base frame.

    Returns:
        (linear columns, angular columns): n vectors each; columns after ``upto`` are zero.
    """
    z = engine.zero
    linear, angular = [], []
    for i in range(len(ch.axes)):
        if i > upto:
            linear.append([z, z, z])
            angular.append([z, z, z])
        elif ch.prismatic[i]:
            linear.append(ch.axes[i])
            angular.append([z, z, z])
        else:
            linear.append(cross(ch.axes[i], sub(point, ch.origins[i])))
            angular.append(ch.axes[i])
    return linear, angular
