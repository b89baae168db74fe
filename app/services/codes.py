"""Session codes: their alphabet and form, made and normalised (no web imports).

A code is the key to a student's session (:mod:`app.services.session.sessions` makes them);
the log filter that masks them (:mod:`app.services.guard.redaction`) reads their form here,
so the guard imports nothing of the sessions.
"""

from __future__ import annotations

import secrets

__all__ = ["CODE_ALPHABET", "CODE_LENGTH", "new_code", "normalise_code"]


#: Characters of a session code (no look-alikes: no 0/o, 1/l/i).
CODE_ALPHABET = "abcdefghjkmnpqrstuvwxyz23456789"
#: Characters per code: 16 of 31 symbols = 79 random bits.
CODE_LENGTH = 16


def new_code() -> str:
    """A fresh random session code, ``xxxx-xxxx-xxxx-xxxx`` (79 bits from :mod:`secrets`)."""
    raw = "".join(secrets.choice(CODE_ALPHABET) for _ in range(CODE_LENGTH))
    return "-".join(raw[i:i + 4] for i in range(0, CODE_LENGTH, 4))


def normalise_code(code: str) -> str:
    """The canonical ``xxxx-xxxx-xxxx-xxxx`` form of a typed code; ``KeyError`` if it cannot
    be one (case, spaces and dashes do not matter)."""
    c = "".join(ch for ch in str(code)[:64].lower() if ch not in " -_\t")
    if len(c) != CODE_LENGTH or any(ch not in CODE_ALPHABET for ch in c):
        raise KeyError(code)
    return "-".join(c[i:i + 4] for i in range(0, CODE_LENGTH, 4))
