"""Where a joint's cylinder is pinned: a side view of the pins at both limits, and the cylinder's
length s(q) and moment arm r(q) over the joint's range.

    python examples/cylinder_pins.py my_arm.yaml lift -o pins.png
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy.spatial.transform import Rotation

import maniplab as ml
from maniplab.atomic import atomic_path
from maniplab.spec import model_of


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("spec", help="spec file or built-in name")
    parser.add_argument("joint", help="a joint driven by a pinned cylinder")
    parser.add_argument("-o", "--output", type=Path, default=Path("out/cylinder_pins.png"))
    args = parser.parse_args(argv)
    spec = ml.resolve_spec(args.spec)
    joint = spec.joint(args.joint)
    actuator = model_of(joint)
    if not hasattr(actuator, "geometry") or joint.prismatic:
        print(f"joint {joint.name} has no pinned cylinder on a rotational joint", file=sys.stderr)
        return 2
    figure = draw(joint, actuator)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(args.output) as path:
        figure.savefig(path, dpi=110)
    print(f"wrote {args.output}")
    return 0


def draw(joint: ml.Joint, actuator: object) -> plt.Figure:
    """The side view (the plane normal to the joint's axis) and the curves s(q), r(q)."""
    geometry = actuator.geometry  # type: ignore[attr-defined]
    cylinder = actuator.params.cylinder  # type: ignore[attr-defined]
    axis = joint.axis_vector
    u = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    u = u - axis * (axis @ u)
    u /= np.linalg.norm(u)
    w = np.cross(u, axis)  # (u, w) span the view: x and z for a joint about y

    def flat(point: np.ndarray) -> tuple[float, float]:
        return float(point @ u), float(point @ w)

    lower, upper = joint.limits
    body = joint.offset if np.linalg.norm(joint.offset) > 0 else u
    fig, (side, curves) = plt.subplots(1, 2, figsize=(10, 4.2))
    parent = np.asarray(cylinder.pins.parent)
    for q, colour in ((lower, "tab:blue"), (upper, "tab:orange")):
        turn = Rotation.from_rotvec(q * axis)
        child, tip = turn.apply(cylinder.pins.child), turn.apply(body)
        side.plot(*zip(flat(np.zeros(3)), flat(tip)), color=colour, lw=3, alpha=0.5,
                  label=f"body at q = {q:g} rad")
        side.plot(*zip(flat(parent), flat(child)), color="goldenrod", lw=6, solid_capstyle="round")
        side.plot(*flat(child), "o", color=colour)
    side.plot(*flat(parent), "ks", label="parent pin")
    side.plot(0, 0, "k+", ms=14, mew=2, label="joint")
    side.set_aspect("equal")
    side.set_title(f"joint {joint.name}: the cylinder at both limits")
    side.legend(fontsize=8, loc="best")
    q = np.linspace(lower, upper, 200)
    curves.plot(q, geometry.length(q), label="length s(q), m")
    curves.plot(q, np.abs(geometry.arm(q)), label="moment arm |r(q)| = |ds/dq|, m")
    curves.axhline(cylinder.min_length, color="grey", ls=":", label="min_length, min_length + stroke")
    curves.axhline(cylinder.max_length, color="grey", ls=":")
    curves.set_xlabel("q, rad")
    curves.legend(fontsize=8)
    fig.tight_layout()
    return fig


if __name__ == "__main__":
    sys.exit(main())
