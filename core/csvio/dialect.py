"""Splitting lines into cells: delimiter and decimal-mark sniffing, line checks."""

from __future__ import annotations

import csv
from collections.abc import Sequence

import numpy as np

from .errors import CSVError
from .numbers import is_num, is_strict_num

__all__ = ["MAX_LINE_CHARS", "check_lines", "detect_format", "field_counts", "split_cells"]

#: Longest accepted line (characters); a recording row is a few numbers.
MAX_LINE_CHARS = 100_000


def split_cells(lines: Sequence[str], delimiter: str) -> list[list[str]]:
    if delimiter == "whitespace":
        return [ln.split() for ln in lines]
    try:
        return [[c.strip() for c in row] for row in csv.reader(lines, delimiter=delimiter)]
    except csv.Error as exc:  # defensive: lines are length-checked and quotes balanced
        raise CSVError(f"the CSV cannot be split into cells: {exc}") from None


_DELIMS = (",", ";", "\t", "|", "whitespace")
_DELIM_ALIASES = {
    "whitespace": "whitespace", " ": "whitespace", "space": "whitespace", "\\s+": "whitespace",
    "tab": "\t", "\\t": "\t", "\t": "\t", ",": ",", ";": ";", "|": "|",
}


def detect_format(
    sample: list[str], delimiter: str | None, decimal: str | None, label: str, line0: int,
    min_columns: int = 2,
) -> tuple[str, str]:
    """Choose delimiter and decimal mark from the first content lines.

    With ``min_columns=1`` (input-only signals) a table of one column is accepted.
    """
    if delimiter is not None:
        if delimiter not in _DELIM_ALIASES:
            raise CSVError(
                f"delimiter={delimiter!r} is not supported; use ',', ';', '\\t', '|' or "
                "'whitespace' (or None to detect it)", source=label
            )
        delims: tuple[str, ...] = (_DELIM_ALIASES[delimiter],)
    else:
        sniffed = None
        try:
            head = "\n".join(ln[:2000] for ln in sample[:20])  # bounded sniffing cost
            sniffed = csv.Sniffer().sniff(head, delimiters=",;\t|").delimiter
        except csv.Error:
            pass
        delims = ((sniffed,) if sniffed else ()) + tuple(d for d in _DELIMS if d != sniffed)
    if decimal not in (None, ".", ","):
        raise CSVError(f"decimal={decimal!r} must be '.' or ',' (or None to detect it)",
                       source=label)
    best: tuple[tuple[float, ...], str, str] | None = None
    body = sample[2:] if len(sample) > 4 else sample
    for rank, d in enumerate(delims):
        rows = split_cells(sample, d)
        body_rows = split_cells(body, d)
        widths = [len(r) for r in body_rows]
        width = max(set(widths), key=widths.count) if widths else 0
        share = widths.count(width) / len(widths) if widths else 0.0
        cells = [c for r in body_rows for c in r]
        for dec in ((decimal,) if decimal else (".", ",")):
            if d == "," and dec == "," or not cells:
                continue
            frac = sum(is_num(c, dec) for c in cells) / len(cells)
            strict = sum(is_strict_num(c, dec) for c in cells) / len(cells)
            head_ok = 1.0 if rows and len(rows[0]) == width else 0.0
            score = (float(width >= 2), float(share >= 0.9), round(frac, 3), strict, head_ok,
                     -rank, 0.0 if dec == "," else 1.0)
            if best is None or score > best[0]:
                best = (score, d, dec)
    if best is not None and best[0][0] == 0.0 and min_columns <= 1:
        return best[1], best[2]
    if best is None or best[0][0] == 0.0:
        if delimiter == "," and decimal == ",":
            raise CSVError("decimal=',' needs a delimiter other than ','", source=label)
        first = sample[0] if sample else ""
        tried = repr(delims[0]) if delimiter is not None else "',', ';', tab, '|', whitespace"
        raise CSVError(
            f"{label}: line {line0} ({first[:60]!r}) has a single column with the delimiter(s) "
            f"{tried}; a recording needs at least an input and an output column; "
            + ("check delimiter=" if delimiter is not None else
               "pass delimiter= if yours is unusual"),
            source=label, line=line0,
        )
    return best[1], best[2]


def check_lines(content: Sequence[str], linenos: Sequence[int], label: str) -> None:
    """Reject over-long lines and unclosed quotes before any splitting (bounded work)."""
    if not content:
        return
    lengths = np.fromiter(map(len, content), dtype=np.int64, count=len(content))
    if lengths.max() > MAX_LINE_CHARS:
        i = int(np.argmax(lengths > MAX_LINE_CHARS))
        raise CSVError(
            f"{label}: line {linenos[i]} is {int(lengths[i]):,} characters long, more than "
            f"{MAX_LINE_CHARS:,}; a recording has one sample per line (are the line breaks "
            "missing, or is this not a CSV recording?)", source=label, line=linenos[i],
        )
    for ln, n in zip(content, linenos, strict=True):
        if ln.count('"') % 2:
            raise CSVError(
                f'{label}: line {n} has an unclosed quote (an odd number of \'"\'); close '
                "the quoted cell on the same line or remove the quote", source=label, line=n,
            )


def field_counts(data: list[str], d: str) -> np.ndarray:
    """Number of ``d``-separated fields on each line (vectorised over the bytes)."""
    if not data:
        return np.zeros(0, dtype=np.int64)
    b = np.frombuffer("\n".join(data).encode("utf-8", "surrogatepass"), dtype=np.uint8)
    nl = np.flatnonzero(b == 10)
    line_of_delim = np.searchsorted(nl, np.flatnonzero(b == ord(d)))
    return np.bincount(line_of_delim, minlength=len(data)).astype(np.int64) + 1
