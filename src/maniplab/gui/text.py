"""The page's text conventions shared by the tabs."""

from __future__ import annotations

import html


def warning(text: object) -> str:
    """``text`` as the page's warning line (Markdown, escaped)."""
    return f"**⚠ {html.escape(str(text))}**"
