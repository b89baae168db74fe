"""Large files in blocks: a numeric CSV read with memory that holds the numbers, not the text.

A file larger than :data:`STREAM_FROM_BYTES` is not read whole: its head (the first
:data:`HEAD_BYTES`, cut at a line break) goes through the usual reader, which works out the
encoding, delimiter, decimal mark, preamble, header, unit row and columns and checks those
lines; the rest is parsed in blocks of :data:`BLOCK_BYTES` by numpy's C reader straight into
one preallocated ``(rows, columns)`` float64 array. A block the C reader refuses (empty or NA
cells, quotes, ragged or over-long lines) is read by the cell-by-cell path of the usual
reader, whose messages name the line and column. What is kept per row is the numbers and the
line number, about ``8 * (columns + 1)`` bytes, against about 280 bytes per row of three
columns for the text, its lines and their strings.

A file is read in blocks only when every cell after the head is a number or empty / NA and
every line after the head is a data row (no comment, blank or delimiter-only lines inside the
data, no text or date-time cells). :class:`NotStreamable` says which line is not; the caller
(:func:`core.csvio.load.read_table`) then reads the file whole when it is within the size
the whole-text reader allows, and refuses it in words otherwise. The memory the numbers need
is checked against what the machine has before they are read (:func:`read_streamed`).
"""

from __future__ import annotations

import io
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..memory import available_memory
from .columns import convert
from .dialect import check_lines
from .errors import CSVError
from .options import CsvOptions
from .source import CSVText
from .table import CSVLayout, Table, check_rows, read_table_whole

__all__ = ["BLOCK_BYTES", "HEAD_BYTES", "STREAM_FROM_BYTES", "MemoryRefusal", "NotStreamable",
           "StreamedTable", "bytes_per_row", "read_streamed", "refusal"]

#: Files larger than this (bytes) are read in blocks.
STREAM_FROM_BYTES = 8 * 2**20
#: Bytes of the head read by the usual reader (layout, header, units, preamble).
HEAD_BYTES = 2**20
#: Bytes of one block of the rest.
BLOCK_BYTES = 8 * 2**20
#: Fewest data rows the head must hold (the usual reader looks at 64 lines for its layout).
HEAD_ROWS = 64
_OK_ENCODINGS = frozenset({"utf-8", "utf8", "utf-8-sig", "ascii", "us-ascii", "latin-1",
                           "latin1", "iso-8859-1", "cp1252"})


class NotStreamable(Exception):  # noqa: N818 - a condition, not a failure of the caller
    """The file cannot be read in blocks; ``reason`` says why in words (what, which line)."""

    def __init__(self, reason: str, line: int | None = None) -> None:
        super().__init__(reason)
        self.reason = reason
        self.line = line


class MemoryRefusal(CSVError):
    """The numbers of a file would not fit in the memory available (the sizes in words)."""


def bytes_per_row(width: int) -> int:
    """Bytes a row of ``width`` columns takes at the reader's peak: the table's values and
    line number, the columns taken out of it and the recording's arrays (float64 each)."""
    return 8 * (2 * width + 4)


class StreamedTable(Table):
    """The table of a file read in blocks: the numbers, not the text.

    ``matrix()`` is always there; the text of a row (for messages and the printed
    resolution of the time stamps) is read back from the file when asked, one block at a
    time (:meth:`cell`).
    """

    def __init__(self, layout: CSVLayout, matrix: np.ndarray, lines: np.ndarray,
                 head: Table, path: Path, blocks: list[tuple[int, int, int, int]]) -> None:
        super().__init__(layout, _Rows(len(matrix)), lines, None, False)  # type: ignore[arg-type]
        self._matrix = matrix
        self._head = head
        self._path = path
        self._blocks = blocks  # (first row, byte offset, bytes, first line) of each later block
        self.first_line = head.first_line
        self._cached: tuple[int, list[str]] | None = None

    def matrix(self) -> np.ndarray:
        assert isinstance(self._matrix, np.ndarray)
        return self._matrix

    @property
    def rows(self) -> list[list[str]]:
        raise NotImplementedError("a streamed table keeps no text rows")  # pragma: no cover

    def column(self, j: int) -> list[str]:
        raise NotImplementedError("a streamed table keeps no text rows")  # pragma: no cover

    def cell(self, i: int, j: int) -> str:
        """Cell ``j`` of data row ``i`` as written (stripped), read back from the file."""
        n_head = len(self._head.data)
        if i < n_head:
            return self._head.cell(i, j)
        starts = [b[0] for b in self._blocks]
        k = int(np.searchsorted(starts, i, side="right")) - 1
        _, offset, size, line0 = self._blocks[k]
        if self._cached is None or self._cached[0] != k:
            with open(self._path, "rb") as fh:
                fh.seek(offset)
                text = fh.read(size).decode(_codec(self.layout), errors="replace")
            self._cached = (k, text.replace("\r\n", "\n").split("\n"))
        line = self._cached[1][int(self.lines[i]) - line0]
        return Table(self.layout, [line], self.lines[i:i + 1], None, '"' in line).cell(0, j)


class _Rows:
    """Stands for the text lines of a streamed table: only their number is known."""

    def __init__(self, n: int) -> None:
        self._n = n

    def __len__(self) -> int:
        return self._n

    def __bool__(self) -> bool:
        return self._n > 0


def _count_lines(path: Path) -> int:
    """Line breaks in the file (an upper bound on its rows), counted in blocks."""
    n = 0
    with open(path, "rb") as fh:
        while block := fh.read(BLOCK_BYTES):
            n += block.count(b"\n")
    return n + 1


def read_streamed(path: Path, size: int, opts: CsvOptions, min_columns: int,
                  memory: int | None = None) -> StreamedTable:
    """The table of the file ``path`` (``size`` bytes) read in blocks.

    Parameters
    ----------
    path : Path
        A regular file of more than :data:`HEAD_BYTES` bytes.
    size : int
        Its size in bytes.
    opts : CsvOptions
        Reading options (``max_rows`` caps the rows; ``max_bytes`` was checked).
    min_columns : int
        Fewest columns of the table.
    memory : int, optional
        Bytes the numbers may take; default what the machine has available
        (:func:`core.memory.available_memory`).

    Returns
    -------
    StreamedTable

    Raises
    ------
    NotStreamable
        The file holds something only the whole-text reader reads (the reason in words).
    CSVError
        A problem of the file itself (ragged or over-long line, unclosed quote, binary
        content), or the numbers would not fit in ``memory``.
    """
    label = str(path)
    head, cut, head_lines, trailing_blank = _read_head(path, opts, min_columns)
    lay = head.layout
    width = len(lay.columns)
    head_values = _values(head, head.lines)
    n_max = _count_lines(path)
    if opts.max_rows is not None:
        n_max = min(n_max, opts.max_rows + 1)
    need = n_max * bytes_per_row(width)
    allowed = available_memory() if memory is None else memory
    if allowed is not None and need > allowed:
        raise MemoryRefusal(
            f"{label} holds about {n_max:,} rows of {width} columns; reading it needs about "
            f"{_size(need)} of memory ({bytes_per_row(width)} bytes per row) and "
            f"{_size(allowed)} are available; cut the recording into parts or decimate it "
            "first", source=label)
    out = np.empty((n_max, width))
    lines = np.empty(n_max, dtype=np.int64)
    n = len(head.data)
    out[:n] = head_values
    lines[:n] = head.lines
    blocks: list[tuple[int, int, int, int]] = []
    offset, line0 = cut, head_lines + 1  # byte and 1-based line of the next block
    with open(path, "rb") as fh:
        fh.seek(offset)
        rest = b""
        while True:
            chunk = fh.read(BLOCK_BYTES)
            data = rest + chunk
            if not chunk:
                block, rest = data, b""
            else:
                end = data.rfind(b"\n") + 1
                if end == 0:
                    rest = data
                    continue
                block, rest = data[:end], data[end:]
            if not block:
                break
            k = block.count(b"\n") + (not block.endswith(b"\n"))
            if trailing_blank is not None and block.strip():
                raise NotStreamable(f"line {trailing_blank} is blank inside the data",
                                    trailing_blank)
            vals, rel, blank_from = _block(block, lay, line0, head, opts, label)
            if blank_from is not None:
                trailing_blank = blank_from
            m = len(vals)
            if n + m > n_max:
                stop = int(line0 + rel[n_max - n]) if n_max - n < m else line0
                raise CSVError(
                    f"{label} has more than max_rows={opts.max_rows:,} rows (stopped at line "
                    f"{stop}); pass a larger max_rows= to read it anyway, or cut / decimate "
                    "the recording", source=label, line=stop)
            blocks.append((n, offset, len(block), line0))
            out[n:n + m] = vals
            lines[n:n + m] = line0 + rel
            n += m
            offset += len(block)
            line0 += k
            if not chunk:
                break
    if opts.max_rows is not None and n > opts.max_rows:
        raise CSVError(
            f"{label} has {n:,} data rows, more than max_rows={opts.max_rows:,}; pass a "
            "larger max_rows= to read it anyway, or cut / decimate the recording",
            source=label)
    layout = replace(lay, n_rows=n)
    return StreamedTable(layout, out[:n], lines[:n], head, path, blocks)


def _codec(lay: CSVLayout) -> str:
    """The codec of the file's blocks (its head's; ``utf-8`` for ``"str"``)."""
    return lay.encoding if lay.encoding.lower() in _OK_ENCODINGS else "utf-8"


def _read_head(path: Path, opts: CsvOptions, min_columns: int
               ) -> tuple[Table, int, int, int | None]:
    """The head of the file read by the usual reader: ``(table, bytes, lines, first line of
    the blank lines that end it or None)``; NotStreamable when it cannot start the blocks."""
    label = str(path)
    if opts.encoding is not None and opts.encoding.lower() not in _OK_ENCODINGS:
        raise NotStreamable(f"encoding={opts.encoding!r} is read whole")
    with open(path, "rb") as fh:
        head_bytes = fh.read(HEAD_BYTES)
    if head_bytes[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise NotStreamable("it is UTF-16 text (two bytes per character)", 1)
    cut = head_bytes.rfind(b"\n") + 1
    if cut == 0:
        raise NotStreamable("its first line is longer than the head read to find the layout",
                            1)
    head_bytes = head_bytes[:cut]
    if b"\r" in head_bytes and head_bytes.count(b"\r") != head_bytes.count(b"\r\n"):
        raise NotStreamable("its lines end with a bare carriage return", 1)
    head_lines = head_bytes.count(b"\n")
    tail = head_bytes[len(head_bytes.rstrip()):].count(b"\n")
    # the head through the usual reader: layout, header, units, preamble, checks, notes
    head_opts = replace(opts, max_bytes=len(head_bytes) + 1, max_rows=max(len(head_bytes), 1))
    head, _ = read_table_whole(CSVText(head_bytes, label), head_opts, min_columns)
    lay = head.layout
    if lay.n_rows < HEAD_ROWS:
        raise NotStreamable(f"its first {HEAD_BYTES:,} bytes hold fewer than {HEAD_ROWS} "
                            "data rows", head_lines)
    if any(n.startswith("ignored the empty last column") for n in lay.notes):
        raise NotStreamable("every line ends with a delimiter", head_lines)
    return head, cut, head_lines, head_lines - tail + 2 if tail > 1 else None


def _values(table: Table, lines: np.ndarray) -> np.ndarray:
    """Every column of ``table`` as float64 (NA cells NaN); a text cell is NotStreamable."""
    m = table.matrix()
    if m is not None:
        return m
    cols = []
    for c in table.layout.columns:
        arr = convert(table, c, strict=False, role="extra")
        if arr is None:
            try:
                convert(table, c, strict=True, role="value")
            except CSVError as exc:
                raise NotStreamable(
                    f"column {c.label()} holds text ({_where(exc)}); only numbers are read in "
                    "blocks", exc.line) from None
            raise NotStreamable(f"column {c.label()} holds text", None)  # pragma: no cover
        cols.append(arr)
    return np.column_stack(cols) if cols else np.empty((len(lines), 0))


def _where(exc: CSVError) -> str:
    return f"line {exc.line}" if exc.line is not None else "a cell"


def _block(block: bytes, lay: CSVLayout, line0: int, head: Table, opts: CsvOptions,
           label: str) -> tuple[np.ndarray, np.ndarray, int | None]:
    """The values of one block of whole lines starting at line ``line0``: ``(values, line
    offsets from line0, first line of the blank lines that end the block or None)``."""
    width = len(lay.columns)
    k = block.count(b"\n") + (not block.endswith(b"\n"))
    fast: bytes | None = block
    if lay.decimal == ",":
        fast = None if b"." in block else block.replace(b",", b".")
    if fast is not None and b'"' not in block and b"#" not in block:
        try:
            arr = np.loadtxt(io.BytesIO(fast), dtype=np.float64, comments=None, quotechar=None,
                             ndmin=2, encoding="latin-1",
                             delimiter=None if lay.delimiter == "whitespace" else lay.delimiter)
        except ValueError:
            arr = None
        if arr is not None and arr.shape == (k, width):
            return arr, np.arange(k, dtype=np.int64), None
    # the cell-by-cell path of the usual reader, with its messages
    try:
        text = block.decode(_codec(lay))
    except UnicodeDecodeError as exc:
        line = line0 + block.count(b"\n", 0, exc.start)
        raise NotStreamable(f"line {line} is not valid {lay.encoding} text", line) from None
    raw = text.replace("\r\n", "\n").split("\n")
    if raw and raw[-1] == "":
        raw.pop()
    data: list[str] = []
    rel: list[int] = []
    blank_from: int | None = None
    strip_chars = " \t" if lay.delimiter == "whitespace" else " \t" + lay.delimiter
    for i, ln in enumerate(raw):
        st = ln.strip()
        if not st:
            if blank_from is None:
                blank_from = line0 + i
            continue
        if blank_from is not None:
            raise NotStreamable(f"line {blank_from} is blank inside the data", blank_from)
        if st[0] == "#":
            raise NotStreamable(f"line {line0 + i} is a comment inside the data", line0 + i)
        if not st.strip(strip_chars):
            raise NotStreamable(f"line {line0 + i} holds only delimiters", line0 + i)
        data.append(ln)
        rel.append(i)
    if not data:
        return np.empty((0, width)), np.zeros(0, dtype=np.int64), blank_from
    nums = np.asarray(rel, dtype=np.int64)
    linenos = [int(line0 + r) for r in rel]
    check_lines(data, linenos, label)
    quoted = any('"' in ln for ln in data)
    rows = check_rows(data, line0 + nums, [head.first_line], [c.raw for c in lay.columns], width,
                      lay.delimiter, quoted, lay.header, label, None)
    table = Table(lay, data, line0 + nums, rows, quoted)
    return _values(table, line0 + nums), nums, blank_from


def _size(b: float) -> str:
    return f"{b / 1e9:.1f} GB" if b >= 1e9 else f"{b / 1e6:.0f} MB"


def refusal(label: str, size: int, limit: int, why: NotStreamable) -> CSVError:
    """The error for a file too large to read whole that cannot be read in blocks."""
    return CSVError(
        f"{label} is {size:,} bytes, more than the {limit:,} bytes read whole; a larger file "
        f"is read in blocks, which needs a number (or an empty / NA cell) in every cell and "
        f"one data row on every line after the header, but {why.reason}; remove or fix those "
        "lines and columns (or cut the recording into parts), or pass a larger max_bytes= "
        "to read it whole",
        source=label, line=why.line)

