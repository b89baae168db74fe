"""Column options of a CSV reading, shared by the command line and the explorer."""

from __future__ import annotations

__all__ = ["column_spec"]


def column_spec(col: str | int | None) -> int | str | None:
    """A column option as :func:`core.csvio.read_csv` wants it: a 0-based index when it is
    all digits, else the name; ``None`` (or ``""``) lets the reader choose."""
    if col is None or col == "":
        return None
    return int(col) if isinstance(col, int) or str(col).isdigit() else str(col)
