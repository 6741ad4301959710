"""Errors of the analytic model (all derive from :class:`maniplab.ManiplabError`)."""

from __future__ import annotations

from maniplab.errors import ManiplabError


class ModelArgumentError(ManiplabError, ValueError):
    """A bad argument to the analytic model: an unknown backend, symbolic engine, export format or
    parameter group, a stuck-joint mask of the wrong shape, or the C backend asked for where it
    cannot be built.

    It is also a ValueError, which these arguments raised before.
    """
