"""Issue 35 item 7: viser turned a bare URL in lesson text into a link.

viser renders Markdown with GitHub's extensions (remark-gfm), whose autolink literals turn
``https://...``, ``www....`` and ``name@host.tld`` in plain text into links, after the
escapes and character references are decoded. The patterns below are those of
mdast-util-gfm-autolink-literal (the transform remark-gfm runs on decoded text).
"""

from __future__ import annotations

import html
import re

import pytest

from app.gui.text import md_text

URL = re.compile(r"(https?:\/\/|www(?=\.))([-.\w]+)([^ \t\r\n]*)", re.IGNORECASE)
EMAIL = re.compile(r"(?<![^\s\W])([-.\w+]+)@([-\w]+(?:\.[-\w]+)+)")
MARKDOWN_ESCAPE = re.compile(r"\\([!-/:-@\[-`{-~])")


def rendered_text(markdown: str) -> str:
    """The text a CommonMark renderer shows for ``markdown`` (escapes and references
    decoded)."""
    return html.unescape(MARKDOWN_ESCAPE.sub(r"\1", markdown))


@pytest.mark.parametrize("text", [
    "Read https://evil.example/login?next=1 first",
    "see HTTP://EVIL.EXAMPLE and www.evil.example/x",
    "write to teacher@school.example.org",
    "ftp://files.example/a mailto:someone@example.com xmpp:me@example.com",
])
def test_a_bare_url_in_lesson_text_stays_text(text: str) -> None:
    assert URL.search(text) or EMAIL.search(text)  # the pattern would link the raw text
    shown = rendered_text(md_text(text))
    assert not URL.search(shown) and not EMAIL.search(shown), shown
    assert shown.replace("\u2060", "") == text  # what the reader sees is unchanged


def test_ordinary_text_is_unchanged() -> None:
    text = "The loop opens at u = 4.5 (see paper 001, Fig. 3); no link here."
    assert rendered_text(md_text(text)) == text
