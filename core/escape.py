"""Writing untrusted text into generated code and XML: one escaping function per target.

A parameter set is a file people mail each other; its strings (units, provenance, notes)
end up in the C header comment, the FMU's C source and its model description. Compiling
or loading an export must never run, or be steered by, its author's text. Every string
that reaches a generated file goes through exactly one function here:

* :func:`c_comment` for text inside a C ``/* ... */`` comment,
* :func:`c_string` for a C string literal (quotes included),
* :func:`xml_attr` for an XML attribute value (quotes included).

The C functions keep printable ASCII only and spell everything else as ``U+XXXX``, so no
control character (a newline, a NUL), no bidirectional override (U+202E) and no
non-ASCII look-alike reaches the compiler. In a comment, a backslash is spelled
``U+005C`` as well: a backslash before a newline (even with spaces between, as GCC
accepts) splices lines, and the trigraph ``??/`` (active under ``-std=c99``) is another
backslash, so ``??`` is broken up too; ``*/`` and ``/*`` are broken by a space.
"""

from __future__ import annotations

import re
from xml.sax.saxutils import quoteattr

__all__ = ["c_comment", "c_string", "xml_attr"]

_PRINTABLE = re.compile(r"[^\x20-\x7e]")
#: Characters XML 1.0 cannot hold, and the bidirectional controls (valid XML, but they
#: reorder what a reader sees: "Trojan source").
_NOT_XML = re.compile(
    "[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]|[\u202a-\u202e\u2066-\u2069\u200e\u200f]"
)


def _ascii(text: str, also: str = "") -> str:
    """Printable ASCII; any other character (and those in ``also``) as ``U+XXXX``."""

    def spell(m: re.Match[str]) -> str:
        return f"U+{ord(m.group(0)):04X}"

    out = _PRINTABLE.sub(spell, text)
    if also:
        out = re.sub("[" + re.escape(also) + "]", spell, out)
    return out


def c_comment(text: str) -> str:
    """Text that can stand inside a C block comment and never end it or splice a line.

    Parameters
    ----------
    text : str
        Any text (one line or several; newlines become ``U+000A``).

    Returns
    -------
    str
        Printable ASCII on one line, with no ``*/``, ``/*``, ``??`` or backslash.

    Examples
    --------
    >>> c_comment("V */ int x; /*")
    'V * / int x; / *'
    """
    out = _ascii(text, also="\\")
    # breaking one pair can form the next ("**//" -> "* *//"), so repeat until none is left
    while "*/" in out or "/*" in out or "??" in out:
        out = out.replace("*/", "* /").replace("/*", "/ *").replace("??", "? ?")
    return out


def c_string(text: str) -> str:
    """A C99 string literal (with its quotes) holding ``text``, printable ASCII only.

    Quotes and backslashes are escaped, ``?`` is written ``\\?`` (no trigraph can form)
    and every other character is spelled ``U+XXXX`` in the literal's text.

    Parameters
    ----------
    text : str

    Returns
    -------
    str
        ``"..."``, safe to paste into C source.
    """
    body = _ascii(text).replace("\\", "\\\\").replace('"', '\\"').replace("?", "\\?")
    return f'"{body}"'


def xml_attr(text: str) -> str:
    """An XML attribute value (with its quotes): markup escaped, characters XML 1.0 cannot
    hold and bidirectional controls replaced by ``?``.

    Parameters
    ----------
    text : str

    Returns
    -------
    str
    """
    return quoteattr(_NOT_XML.sub("?", text))
