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
    a tenth; the rod runs from the child pin back into it, so it slides out with the stroke."""
    start, end = (np.asarray(p, dtype=float) for p in segment)
    axis = end - start
    length = float(np.linalg.norm(axis))
    if length < 1e-9:
        axis, length = np.array([0.0, 0.0, 1.0]), 1e-9
    direction = axis / length
    barrel_length = min(0.9 * float(cylinder.min_length), length)
    barrel_radius = 0.65 * float(cylinder.bore)  # the tube's wall around the bore
    rod_radius = 0.5 * float(cylinder.rod)
    rod_length = max(length - 0.5 * barrel_length, 1e-9)  # from the child pin into the barrel
    rotation = _z_onto(direction)
    return [(start, rotation, (barrel_radius, barrel_radius, barrel_length)),
            (end, _z_onto(-direction), (rod_radius, rod_radius, rod_length))]


def _z_onto(direction: np.ndarray) -> np.ndarray:
    """The quaternion (w, x, y, z) turning the z axis onto the unit vector ``direction``."""
    z = np.array([0.0, 0.0, 1.0])
    w = 1.0 + float(direction @ z)
    if w < 1e-9:  # opposite: half a turn about x
        return np.array([0.0, 1.0, 0.0, 0.0])
    q = np.array([w, *np.cross(z, direction)])
    return q / np.linalg.norm(q)
