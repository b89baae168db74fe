"""What a JSON request body may hold: finite numbers and valid Unicode only.

Python's :mod:`json` accepts ``NaN``, ``Infinity`` and ``-Infinity``, turns ``1e400`` into
``inf`` and keeps a lone surrogate (``"\\ud800"``) in a key or a string; each of them fails
later, deep in the work or when the answer is encoded. :func:`json_body_problem` finds the
first one, with its JSON path (``body.signal.amplitude``), before the body reaches a route.
"""

from __future__ import annotations

import json
import math
import re
from typing import Any

__all__ = ["json_body_problem"]

_SURROGATE = re.compile("[\ud800-\udfff]")


class _NonFinite:
    """Stands for a number literal that is not a finite float (``NaN``, ``1e400``)."""

    __slots__ = ("text",)

    def __init__(self, text: str) -> None:
        self.text = text


def _number(text: str) -> float | _NonFinite:
    v = float(text)
    return v if math.isfinite(v) else _NonFinite(text)


def _key_path(path: str, key: str) -> str:
    if key.isidentifier():
        return f"{path}.{key}"
    return f"{path}[{json.dumps(key)}]"


def _bad_text(s: str) -> str | None:
    m = _SURROGATE.search(s)
    return None if m is None else json.dumps(m.group())


def json_body_problem(body: bytes) -> str | None:
    """Why ``body`` is not an acceptable JSON body, or ``None``.

    Only the two rules of this module are checked; malformed JSON is left to the parser of
    the route (which answers it with its own 422). The walk uses an explicit stack, so any
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
        text = body.decode(json.detect_encoding(body))
    except UnicodeDecodeError as exc:
        line = body.count(b"\n", 0, exc.start) + 1
        return (f"the JSON body is not valid UTF-8 at byte {exc.start} (line {line}); "
                "send the text encoded as UTF-8")
    try:
        doc = json.loads(text, parse_float=_number, parse_constant=_NonFinite)
    except ValueError as exc:
        if isinstance(exc, json.JSONDecodeError):
            return None  # malformed: the route's parser says so
        return f"the JSON body holds a number that cannot be read ({exc}); send shorter numbers"
    stack: list[tuple[Any, str]] = [(doc, "body")]
    while stack:
        node, path = stack.pop()
        if isinstance(node, _NonFinite):
            return (f"{path} is {node.text}, which is not a finite number; JSON numbers must "
                    "be finite: send an ordinary number (or leave the field out)")
        if isinstance(node, str):
            bad = _bad_text(node)
            if bad:
                return (f"{path} holds the unpaired surrogate {bad}, which is not valid "
                        "Unicode; remove it or send the whole character")
        elif isinstance(node, dict):
            for key, value in reversed(node.items()):
                bad = _bad_text(key)
                if bad:
                    return (f"the key {json.dumps(key)[:60]} in {path} is not valid "
                            f"Unicode (it holds the unpaired surrogate {bad}); rename it")
                stack.append((value, _key_path(path, key)))
        elif isinstance(node, list):
            stack.extend((v, f"{path}[{i}]") for i, v in reversed(list(enumerate(node))))
    return None
