"""A pinned hydraulic cylinder drawn as a barrel and a rod along its pin line: where each part
goes for a given pin segment (the GUI's 3D arm, the HTML replay and the offscreen videos draw
the same parts)."""

from __future__ import annotations

from typing import Any

import numpy as np

from maniplab.viz import palette

BARREL: palette.RGBA = (0.10, 0.45, 0.50, 1.0)
"""A pinned cylinder's barrel: dark teal steel (no link, joint state or run has it)."""
ROD: palette.RGBA = (0.86, 0.88, 0.91, 1.0)
"""Its rod: chrome."""


def cylinder_parts(segment: np.ndarray, cylinder: Any) -> list[tuple[np.ndarray, np.ndarray,
                                                                       tuple[float, float, float]]]:
    """Where a pinned cylinder's barrel and rod are drawn when its pins are at ``segment`` (parent
    pin, child pin; m): (start, rotation wxyz of z onto the pin line, scale (radius, radius,
    length)) of each. The barrel starts at the parent pin, as long as the retracted cylinder less
    a tenth; the rod runs from the child pin back into it, as long as the stroke plus that tenth
    (its end reaches the barrel's mouth at full stroke), so it slides out with the stroke and
    keeps its length (a renderer need not rebuild it), shortened only where the pins come closer
    than that."""
    start, end = (np.asarray(p, dtype=float) for p in segment)
    axis = end - start
    length = float(np.linalg.norm(axis))
    if length < 1e-9:
        axis, length = np.array([0.0, 0.0, 1.0]), 1e-9
    direction = axis / length
    barrel_length = min(0.9 * float(cylinder.min_length), length)
    barrel_radius = 0.65 * float(cylinder.bore)  # the tube's wall around the bore
    rod_radius = 0.5 * float(cylinder.rod)
    rod_length = max(min(float(cylinder.stroke) + 0.1 * float(cylinder.min_length), length), 1e-9)
    rotation = _z_onto(direction)
    return [(start, rotation, (barrel_radius, barrel_radius, barrel_length)),
            (end, _z_onto(-direction), (rod_radius, rod_radius, rod_length))]


def pinned_cylinders(model: Any, spec: Any) -> list[tuple[int, str, Any]]:
    """The tendons of ``model`` (compiled from ``spec``) that are pinned cylinders: (tendon id,
    joint name, the joint's cylinder parameters) each, in tendon order. A cylinder's tendon is
    named after its joint (``<joint>/cylinder``); a tendon of no joint, or of a joint whose
    actuator has no cylinder, is left out."""
    found: list[tuple[int, str, Any]] = []
    for k in range(model.ntendon):
        joint = (model.tendon(k).name or "").split("/")[0]
        cylinder = getattr(spec.joint(joint).actuator, "cylinder", None) \
            if joint in spec.joint_names else None
        if cylinder is not None:
            found.append((k, joint, cylinder))
    return found


def tendon_segments(model: Any, data: Any) -> np.ndarray:
    """First to last attachment point of each tendon in the pose of ``data`` (after
    ``mj_tendon``), m, shape (ntendon, 2, 3), float32."""
    segments = np.zeros((model.ntendon, 2, 3), dtype=np.float32)
    for k in range(model.ntendon):
        first, count = data.ten_wrapadr[k], data.ten_wrapnum[k]
        if count >= 2:
            # wrap_xpos holds two points per row: the points are its rows split in half
            segments[k] = data.wrap_xpos.reshape(-1, 3)[first:first + count][[0, count - 1]]
    return segments


def _z_onto(direction: np.ndarray) -> np.ndarray:
    """The quaternion (w, x, y, z) turning the z axis onto the unit vector ``direction``."""
    z = np.array([0.0, 0.0, 1.0])
    w = 1.0 + float(direction @ z)
    if w < 1e-9:  # opposite: half a turn about x
        return np.array([0.0, 1.0, 0.0, 0.0])
    q = np.array([w, *np.cross(z, direction)])
    return q / np.linalg.norm(q)
