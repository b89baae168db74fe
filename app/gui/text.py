"""User strings inside viser Markdown: shown as text, never as markup.

viser renders ``add_markdown`` content as Markdown with HTML, so a CSV header, a file
name or an error message that quotes a cell could draw an image or a link. Every such
string goes through :func:`md_text` first.
"""

from __future__ import annotations

import re

__all__ = ["md_text"]

_HTML = {"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;"}
_MD = re.compile(r"([\\`*_{}\[\]()#+\-.!|~])")


def md_text(value: object) -> str:
    """``value`` as literal text for a Markdown element (HTML and Markdown escaped).

    Examples
    --------
    >>> md_text("<img src=x onerror=alert(1)>")
    '&lt;img src=x onerror=alert\\\\(1\\\\)&gt;'
    """
    s = _MD.sub(r"\\\1", str(value))
    return "".join(_HTML.get(c, c) for c in s)
