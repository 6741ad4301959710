"""Names of the MuJoCo elements that maniplab generates for a spec.

Joints and actuators are named exactly like the spec's joints (``m.joint("q1")``,
``m.actuator("q1")``). Bodies carry a ``link_`` prefix (``m.body("link_q1")``): a joint may be called
``world`` or ``end_effector``, and MuJoCo's world body and the end-effector body already own those
names. Body ``link_<joint>`` is frame j of eq. (1) *after* the joint's motion, so ``d.xpos`` of it is
frame j's origin moved by the joint (unchanged for a rotational joint), ``d.xipos`` is the body's
COG, and ``d.xpos`` of the next body (or of ``end_effector`` minus the offset) is frame j+1's origin.
"""

from __future__ import annotations

END_EFFECTOR = "end_effector"
"""Name of the end-effector body (a fixed child of the last link) and of its site."""

PAYLOAD = "payload"
"""Name of the payload's box geom on the end-effector body."""

FLOOR = "floor"
"""Name of the floor plane."""

TRACK_CAMERA = "track"
"""Camera that follows the arm's centre of mass at a fixed offset (image up = against gravity)."""

OVERVIEW_CAMERA = "overview"
"""Fixed camera that sees the whole reach of the arm around the base."""


LUGRE_SUFFIX = "/lugre"
"""Name of a LuGre joint's bristle-state actuator: ``<joint>/lugre`` (``/`` cannot occur in a
joint name, so the name is free)."""

LUGRE_PLUGIN = "maniplab.lugre"
"""The MuJoCo engine plugin (C, :mod:`maniplab_native`) of LuGre friction."""

INITIAL_KEY = "initial"
"""The model's first keyframe: the actuators' initial states, where the plant starts a run."""


def body_name(joint_name: str) -> str:
    """Name of the MuJoCo body moved by the spec joint ``joint_name`` (e.g. 'q1' -> 'link_q1')."""
    return f"link_{joint_name}"


def link_geom_name(joint_name: str) -> str:
    """Name of the capsule drawn for the body after joint ``joint_name``."""
    return f"{joint_name}_link"


def joint_geom_name(joint_name: str) -> str:
    """Name of the cylinder (rotational) or box (prismatic) drawn at joint ``joint_name``."""
    return f"{joint_name}_joint"
