"""The arm's reach: the length scale for drawing the arm and for judging that a joint moves mass."""

from __future__ import annotations

import numpy as np

from maniplab.spec import ManipulatorSpec


def reach(spec: ManipulatorSpec) -> float:
    """Bound on the distance from the base the arm can get, m (at least 0.1).

    The sum of the body lengths, the largest travel of each limited prismatic joint, the
    end-effector offset and half the diagonal of the payload box.
    """
    total = sum(j.body.length for j in spec.joints if j.body)
    total += sum(max(abs(v) for v in j.limits) for j in spec.joints if j.prismatic and j.limits)
    ee = spec.end_effector
    total += float(np.linalg.norm(ee.offset)) + 0.5 * float(np.linalg.norm(ee.box_size))
    return max(total, 0.1)
