"""The page's text conventions shared by the tabs: every text the page shows from the server goes
through :func:`plain` (or :func:`warning`), so a spec's name or an error message is shown as the
text it is, never as Markdown or HTML (``<iframe srcdoc=...>`` in a name would run its script)."""

from __future__ import annotations

import html
import re

_MARKUP = re.compile(r"([\\`*_{}\[\]()!|~])")  # emphasis, code, links, images, tables
_LEADING = re.compile(r"^(\d*)([#+\-=>:.])")  # a heading, list or quote at the line's start


def plain(text: object) -> str:
    """``text`` on one line, as Markdown that shows exactly that text (HTML and Markdown escaped)."""
    line = _MARKUP.sub(r"\\\1", " ".join(str(text).split()))
    return html.escape(_LEADING.sub(r"\1\\\2", line), quote=False)


def warning(text: object) -> str:
    """``text`` as the page's warning line (Markdown, escaped)."""
    return f"**⚠ {plain(text)}**"
