"""Session codes masked in log records (a code is the key to a student's session).

Codes reach the log inside request paths (``/api/sessions/<code>/...`` in the access log and
in the record of an unhandled error) and in messages. :func:`redact` masks the path segment
after ``/sessions/``, whatever form the code was typed in, and any code-shaped word
(``abcd-efgh-jkmn-pqrs``); :class:`RedactCodes` applies it to every record, traceback
included, of the handlers it is attached to. No web imports.
"""

from __future__ import annotations

import logging
import re

from app.services.codes import CODE_ALPHABET

__all__ = ["MASK", "RedactCodes", "redact"]

#: What a masked code reads as.
MASK = "<code>"

_IN_PATH = re.compile(r"(/sessions/)[^/\s?#\"']+", re.IGNORECASE)
_GROUP = f"[{CODE_ALPHABET}]{{4}}"
_SHAPED = re.compile(rf"(?<![0-9a-z]){_GROUP}(?:[- ]?{_GROUP}){{3}}(?![0-9a-z])", re.IGNORECASE)


def redact(text: str) -> str:
    """``text`` with every session code replaced by :data:`MASK`."""
    return _SHAPED.sub(MASK, _IN_PATH.sub(r"\1" + MASK, text))


class RedactCodes(logging.Filter):
    """A logging filter that masks session codes in the message and the traceback."""

    def filter(self, record: logging.LogRecord) -> bool:
        """Rewrite ``record`` in place with its codes masked; never drops it.

        The message and each argument are masked separately, so formatters that read the
        arguments themselves (uvicorn's access log) still find them in place.
        """
        if isinstance(record.msg, str):
            record.msg = redact(record.msg)
        if isinstance(record.args, tuple):
            record.args = tuple(_masked(a) for a in record.args)
        elif isinstance(record.args, dict):
            record.args = {k: _masked(v) for k, v in record.args.items()}
        if record.exc_info and not record.exc_text:
            record.exc_text = logging.Formatter().formatException(record.exc_info)
        if record.exc_text:
            record.exc_text = redact(record.exc_text)
        return True


def _masked(value: object) -> object:
    """``value``, or its text with the codes masked when it has any (numbers stay)."""
    if isinstance(value, int | float):
        return value
    text = str(value)
    masked = redact(text)
    return value if masked == text else masked
