"""Errors of the controller and its jobs (all derive from :class:`maniplab.ManiplabError`)."""

from __future__ import annotations

from maniplab.errors import ManiplabError


class ControlError(ManiplabError, ValueError):
    """A control job or a controller cannot be set up (bad target, unreachable pose, joint
    limits, bad settings)."""


class TrajectoryError(ControlError):
    """A pose, move or path is malformed (wrong number of values, a duration <= 0, no segments)."""


class LinearizeError(ControlError):
    """An operating point is malformed, or no actuator state holds it."""
