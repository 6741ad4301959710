"""One finding of a run's health verdict (:mod:`maniplab.sim.health`): its severity, the check
that found it, the joint, what happened and what to change."""

from __future__ import annotations

import dataclasses
import enum


class Severity(enum.Enum):
    """How bad a finding is."""

    WARNING = "warning"
    FAILURE = "failure"


@dataclasses.dataclass(frozen=True)
class Finding:
    """One thing that went wrong in a run.

    Attributes:
        severity: warning or failure.  check: which check found it ("saturation", ...).
        joint: the joint's name (None when not one joint's).  cause: what happened.
        advice: the setting to change.
    """

    severity: Severity
    check: str
    joint: str | None
    cause: str
    advice: str

    def line(self) -> str:
        """``joint q2: <cause>; <advice>``: one line for a terminal."""
        where = f"joint {self.joint}: " if self.joint else ""
        return f"{where}{self.cause}; {self.advice}"
