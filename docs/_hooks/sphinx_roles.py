"""MkDocs hook: the Sphinx roles of maniplab's docstrings as code, linked where the site has them.

Some docstrings cross-reference with reStructuredText roles (``:class:`~maniplab.x.Y```,
``:func:`name```). mkdocstrings renders those as the role's name followed by code; this hook turns
each into the code alone and, when the name is a full path (``maniplab....``), into a cross-
reference that mkdocs-autorefs resolves if the object is documented on the site (an ``optional``
one: a name the site does not document stays plain code, without a warning). A leading ``~``
shows only the last part of the name, as Sphinx does.
"""

from __future__ import annotations

import html
import re

ROLE = re.compile(r":(?:py:)?(?:class|mod|func|meth|attr|data|exc|obj|const):<code>(~?)([\w.]+)</code>")


def _replace(match: re.Match[str]) -> str:
    short, name = match.group(1), match.group(2)
    title = f"<code>{html.escape(name.rsplit('.', 1)[-1] if short else name)}</code>"
    if name.startswith("maniplab."):
        return f'<autoref identifier="{html.escape(name)}" optional>{title}</autoref>'
    return title


def on_page_content(html_: str, **kwargs: object) -> str:
    """Rewrite the roles in a page's HTML."""
    return ROLE.sub(_replace, html_)
