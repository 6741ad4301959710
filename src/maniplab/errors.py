"""Exceptions raised by maniplab.

Every error a user can cause derives from :class:`ManiplabError`; the CLI prints its message as one
line and exits with status 2.
"""

from __future__ import annotations


class ManiplabError(Exception):
    """Root of every maniplab error."""


class SpecError(ManiplabError, ValueError):
    """A manipulator spec (file, dict or override) is invalid.

    Attributes:
        file: the spec file, or None for a spec built in memory.
        joint: the joint's name, or None when the problem is not in a joint.
        field: dotted path of the offending field inside the joint (or the spec), e.g. "body.mass".
        line: 1-based line in the file, when known.
    """

    def __init__(
        self,
        problem: str,
        *,
        file: str | None = None,
        joint: str | None = None,
        field: str | None = None,
        line: int | None = None,
    ) -> None:
        self.problem = problem
        self.file = file
        self.joint = joint
        self.field = field
        self.line = line
        super().__init__(self._format())

    def _format(self) -> str:
        where = []
        if self.file:
            where.append(f"{self.file}:{self.line}" if self.line else self.file)
        if self.joint:
            where.append(f"joint {self.joint}")
        if self.field:
            where.append(f"field '{self.field}'")
        return _one_line((", ".join(where) + ": " if where else "") + self.problem)


def _one_line(text: str) -> str:
    """Escape line breaks and other unprintable characters (e.g. from a key typed as "a\\nb")."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode() for c in text)


class ModelError(ManiplabError):
    """The spec is valid but describes an arm MuJoCo cannot simulate (e.g. a joint moving no mass)."""
