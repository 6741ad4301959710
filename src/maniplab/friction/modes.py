"""Discrete modes of the hybrid friction and joint-limit automaton (the paper's eqs. 5-8)."""

from __future__ import annotations

import enum


class FrictionMode(enum.IntEnum):
    """Mode of one joint, stored per sample in ``run["mode"]`` as its integer value.

    SLIP: the joint moves (or has no stick/slip friction). STICK: held at zero velocity by
    stiction. AT_LOWER / AT_UPPER: held at a joint limit until the net force points back inside.
    """

    SLIP = 0
    STICK = 1
    AT_LOWER = 2
    AT_UPPER = 3
