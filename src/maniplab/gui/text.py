"""The page's text conventions shared by the tabs: every text the page shows from the server goes
through :func:`plain` (or :func:`warning`), so a spec's name or an error message is shown as the
text it is, never as Markdown or HTML (``<iframe srcdoc=...>`` in a name would run its script)."""

from __future__ import annotations

import html
import re
from pathlib import Path
from typing import Any

_MARKUP = re.compile(r"([\\`*_{}\[\]()!|~])")  # emphasis, code, links, images, tables
_LEADING = re.compile(r"^(\d*)([#+\-=>:.])")  # a heading, list or quote at the line's start


_PACKAGE = str(Path(__file__).resolve().parents[1])  # .../maniplab
_INTERNAL = re.compile(re.escape(_PACKAGE) + r"[/\\](?:[^\s'\"]*[/\\])?([^/\\\s'\"]+)")


def public(text: object) -> str:
    """``text`` with the paths inside maniplab's own installation shortened to their file names
    (``.../src/maniplab/assets/erector.yaml`` -> ``erector.yaml``): a page shows no internal
    path."""
    return _INTERNAL.sub(r"\1", str(text))


def plain(text: object) -> str:
    """``text`` on one line, as Markdown that shows exactly that text (HTML and Markdown escaped,
    maniplab's internal paths shortened: :func:`public`)."""
    line = _MARKUP.sub(r"\\\1", " ".join(public(text).split()))
    return html.escape(_LEADING.sub(r"\1\\\2", line), quote=False)


def warning(text: object) -> str:
    """``text`` as the page's warning line (Markdown, escaped)."""
    return f"**⚠ {plain(text)}**"


_TROUBLE = ("failed", "busy:", "⚠", "refused", "not a valid", "missed")


class Note:
    """A message line placed next to the control it reports on (hidden while empty): the
    outcome of that control's action, never of another tab's."""

    def __init__(self, gui: Any) -> None:
        self.handle = gui.add_markdown("", visible=False)

    def __call__(self, text: str) -> None:
        """Show ``text`` (as the warning line when it reports a failure or a refusal)."""
        bad = any(word in text for word in _TROUBLE)
        self.handle.content = warning(text.removeprefix("⚠").strip()) if bad else plain(text)
        self.handle.visible = bool(text)

    @property
    def text(self) -> str:
        """What the line shows (Markdown)."""
        return str(self.handle.content)

    def clear(self) -> None:
        """Hide the line."""
        self.handle.content = ""
        self.handle.visible = False
