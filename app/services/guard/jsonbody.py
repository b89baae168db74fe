"""The one strict reader of request documents (JSON or TOML text), whatever their content type.

Python's :mod:`json` accepts ``NaN``, ``Infinity`` and ``-Infinity``, turns ``1e400`` into
``inf``, refuses an integer of more than 4,300 digits with a bare ``ValueError`` and keeps a
lone surrogate (``"\\ud800"``) in a key or a string; :mod:`tomllib` likewise, and gives
dates and times. Each of them failed later, deep in the work or when the answer was encoded
(issue 35 item 5: 500s from a parameter set or lesson sent as text/plain, TOML or
multipart). :func:`read_document` parses a body and refuses the first of them with
:class:`DocumentError`, naming its path (``body.signal.amplitude``);
:func:`json_body_problem` is the same rule for the outer guard, which checks every body that
is JSON whatever its declared type.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import re
import tomllib
from typing import Any

from core.exceptions import ParameterError

__all__ = ["MAX_DIGITS", "DocumentError", "json_body_problem", "read_document"]

#: Longest integer (digits) a document may hold; longer ones are refused with their path.
MAX_DIGITS = 300


class DocumentError(ParameterError):
    """A request document that cannot be read; the message names the path and the fix.

    Attributes
    ----------
    path : str or None
        Where in the document (``body.steps[0].title``), when known.
    """

    def __init__(self, message: str, path: str | None = None) -> None:
        super().__init__(message)
        self.path = path

_SURROGATE = re.compile("[\ud800-\udfff]")


class _NonFinite:
    """Stands for a number literal that is not a finite float (``NaN``, ``1e400``)."""

    __slots__ = ("text",)

    def __init__(self, text: str) -> None:
        self.text = text


def _number(text: str) -> float | _NonFinite:
    v = float(text)
    return v if math.isfinite(v) else _NonFinite(text)


def _integer(text: str) -> int | _NonFinite:
    digits = sum(c.isdigit() for c in text)
    return _NonFinite(text) if digits > MAX_DIGITS else int(text)


def _shown(text: str) -> str:
    """A number literal as a message shows it (a long one by its length)."""
    digits = sum(c.isdigit() for c in text)
    return text if len(text) <= 40 else f"a number of {digits:,} digits ({text[:12]}...)"


def _key_path(path: str, key: str) -> str:
    if key.isidentifier():
        return f"{path}.{key}"
    return f"{path}[{json.dumps(key)}]"


def _bad_text(s: str) -> str | None:
    m = _SURROGATE.search(s)
    return None if m is None else json.dumps(m.group())


def _decode(body: bytes | str) -> str:
    if isinstance(body, str):
        return body
    try:
        return body.decode(json.detect_encoding(body))
    except UnicodeDecodeError as exc:
        line = body.count(b"\n", 0, exc.start) + 1
        raise DocumentError(f"the body is not valid UTF-8 at byte {exc.start} (line {line}); "
                            "send the text encoded as UTF-8") from None


def _parse_json(text: str) -> Any:
    """JSON with every number kept as read (markers for non-finite and over-long ones)."""
    return json.loads(text, parse_float=_number, parse_int=_integer,
                      parse_constant=_NonFinite)


def _parse_toml(text: str) -> Any:
    try:
        return tomllib.loads(text, parse_float=_number)
    except tomllib.TOMLDecodeError:
        raise
    except ValueError:  # an integer beyond Python's conversion limit
        m = re.search(rf"[0-9][0-9_]{{{MAX_DIGITS},}}", text)
        line = 1 if m is None else text.count("\n", 0, m.start()) + 1
        raise DocumentError(f"line {line} holds an integer of more than {MAX_DIGITS} digits; "
                            "write an ordinary number", None) from None


def _problem(doc: Any, where: str) -> DocumentError | None:
    """The first value of ``doc`` a document may not hold, with its path."""
    stack: list[tuple[Any, str]] = [(doc, where)]
    while stack:
        node, path = stack.pop()
        if isinstance(node, _NonFinite):
            word = node.text.lstrip("+-").lower()
            why = ("not a finite number (NaN is not a number at all)" if word == "nan"
                   else "not a finite number" if word in ("inf", "infinity")
                   else "not a finite number of ordinary size")
            return DocumentError(f"{path} is {_shown(node.text)}, which is {why}; numbers "
                                 "must be finite and of ordinary size: send an ordinary "
                                 "number (or leave the field out)", path)
        if isinstance(node, int) and not isinstance(node, bool) and \
                node.bit_length() > 3.33 * MAX_DIGITS:
            return DocumentError(
                f"{path} is an integer of more than {MAX_DIGITS} digits; send an ordinary "
                "number", path)
        if isinstance(node, _dt.date | _dt.time):
            return DocumentError(
                f"{path} is a date or time ({node.isoformat()}); these documents hold text "
                "and numbers only: put it in quotes to make it text", path)
        if isinstance(node, str):
            bad = _bad_text(node)
            if bad:
                return DocumentError(
                    f"{path} holds the unpaired surrogate {bad}, which is not valid Unicode; "
                    "remove it or send the whole character", path)
        elif isinstance(node, dict):
            for key, value in reversed(node.items()):
                bad = _bad_text(key)
                if bad:
                    return DocumentError(
                        f"the key {json.dumps(key)[:60]} in {path} is not valid Unicode (it "
                        f"holds the unpaired surrogate {bad}); rename it", path)
                stack.append((value, _key_path(path, key)))
        elif isinstance(node, list):
            stack.extend((v, f"{path}[{i}]") for i, v in reversed(list(enumerate(node))))
    return None


def read_document(body: bytes | str, *, toml: bool = False, where: str = "body",
                  name: str = "the body") -> Any:
    """Parse a request document strictly, whatever the content type it came with.

    Parameters
    ----------
    body : bytes or str
        The raw body (UTF-8, UTF-16 or UTF-32 with or without BOM, as JSON allows) or text.
    toml : bool
        Also read TOML: text that does not start with ``{`` or ``[`` is read as TOML.
    where : str
        The document's root in the paths of the messages.
    name : str
        What the document is, in the messages about the whole (``the lesson file``).

    Returns
    -------
    object
        The parsed document: dicts, lists, text, finite floats, ints of at most
        :data:`MAX_DIGITS` digits, booleans and ``None`` only.

    Raises
    ------
    DocumentError
        Not UTF-8, not JSON (or TOML), or holding a non-finite or over-long number, a
        date or time, or an unpaired surrogate; the message names the path.
    """
    text = _decode(body).lstrip("\ufeff \t\r\n")
    if not text:
        raise DocumentError(f"{name} is empty; send the document's text")
    if not toml or text[:1] in ("{", "["):
        try:
            doc = _parse_json(text)
        except json.JSONDecodeError as exc:
            raise DocumentError(f"{name} is not valid JSON: {exc.msg} at line "
                                f"{exc.lineno}, column {exc.colno}") from None
        except RecursionError:
            raise DocumentError(f"{name} is nested too deeply; flatten it") from None
    else:
        try:
            doc = _parse_toml(text)
        except tomllib.TOMLDecodeError as exc:
            raise DocumentError(f"{name} is neither JSON (it would start with {{) nor "
                                f"valid TOML: {exc}") from None
    problem = _problem(doc, where)
    if problem is not None:
        raise problem
    return doc


def json_body_problem(body: bytes) -> str | None:
    """Why ``body`` is not an acceptable JSON body, or ``None``.

    The rules of :func:`read_document`, but malformed JSON is left to the parser of the
    route (which answers it with its own 422). The walk uses an explicit stack, so any
    nesting the depth check let through is safe.

    Parameters
    ----------
    body : bytes
        The raw request body.

    Returns
    -------
    str or None
        A message naming the JSON path and what to send instead.
    """
    try:
        text = _decode(body)
    except DocumentError as exc:
        return str(exc).replace("the body", "the JSON body", 1)
    try:
        doc = _parse_json(text)
    except ValueError:  # malformed: the route's parser says so
        return None
    problem = _problem(doc, "body")
    return None if problem is None else str(problem)
