"""Checks of the inputs of the file-based runs (``hyst`` commands and ``hyst batch``).

A wrong input (a missing file, a bad ``T0:T1`` window) is a :class:`CommandError` (a
:class:`~core.exceptions.ParameterError`), which :func:`app.cli.main` turns into
``hyst <command>: error: <message>`` and exit code 2, and a batch into the recording's error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core.exceptions import ParameterError

__all__ = ["CommandError", "existing_file", "parse_window"]


class CommandError(ParameterError):
    """A command-line input is wrong (missing file, bad column, ...); the message says how."""


def existing_file(path: str | Path, what: str) -> Path:
    p = Path(path)
    if not p.exists():
        raise CommandError(f"{what} not found: {p} (check the path)")
    if p.is_dir():
        raise CommandError(f"{what} {p} is a directory; give a file")
    return p


def parse_window(text: str, what: str) -> tuple[float, float]:
    """Parse ``"T0:T1"`` (either side may be empty) into ``(t0, t1)``.

    Raises
    ------
    CommandError
        Naming the option and the expected form.
    """
    parts = text.split(":")
    if len(parts) != 2:
        raise CommandError(f"--{what} {text!r}: expected T0:T1 in seconds, e.g. 0:8 or 8:")
    try:
        t0 = float(parts[0]) if parts[0].strip() else -np.inf
        t1 = float(parts[1]) if parts[1].strip() else np.inf
    except ValueError:
        raise CommandError(f"--{what} {text!r}: T0 and T1 must be numbers, e.g. 0:8") from None
    if not t0 < t1:
        raise CommandError(f"--{what} {text!r}: T0 must be smaller than T1")
    return t0, t1
