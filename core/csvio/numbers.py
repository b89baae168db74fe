"""Numbers in cells: NA tokens, decimal commas, printed resolution."""

from __future__ import annotations

import re
from collections.abc import Iterable

__all__ = ["DECIMAL_COMMA", "NA_TOKENS", "decimals", "is_num", "is_strict_num"]

NA_TOKENS = frozenset({"", "nan", "na", "n/a", "null", "none", "-nan", "+nan", "#n/a"})

DECIMAL_COMMA = re.compile(r"^[+-]?(\d+,\d*|,\d+)([eE][+-]?\d+)?$")


def is_num(cell: str, decimal: str) -> bool:
    c = cell.strip()
    if c.lower() in NA_TOKENS:
        return True
    if decimal == ",":
        if "." in c:
            return False
        c = c.replace(",", ".")
    try:
        float(c)
    except ValueError:
        return False
    return "_" not in c


def is_strict_num(cell: str, decimal: str) -> bool:
    """A real number (not empty, not an NA token)."""
    c = cell.strip()
    return bool(c) and c.lower() not in NA_TOKENS and is_num(c, decimal)



def decimals(cells: Iterable[str]) -> int:
    best = 0
    for c in cells:
        c = c.strip().lower().replace(",", ".")
        if "e" in c:
            return 0
        if "." in c:
            best = max(best, len(c) - c.index(".") - 1)
    return best
