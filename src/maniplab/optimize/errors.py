"""Errors of optimisation studies (all derive from :class:`maniplab.ManiplabError`)."""

from __future__ import annotations

from maniplab.errors import SpecError


class StudyError(SpecError):
    """A study file (or dict) is invalid: one line naming the file, the line when known, and
    the field (``variables[1].low``)."""
