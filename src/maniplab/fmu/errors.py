"""The FMU export's error."""

from __future__ import annotations

from maniplab.errors import ManiplabError


class FmuError(ManiplabError, ValueError):
    """The arm cannot become an FMU (an actuator written in Python, no C compiler, a platform
    without a build), or an FMU option is wrong; the message is one line naming the joint."""
