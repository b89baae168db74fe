"""The table of a CSV: comments, preamble, header, unit row, columns and data lines."""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from .dialect import check_lines, detect_format, field_counts, split_cells
from .errors import CSVError
from .names import ColumnInfo, norm_unit, parse_column_name
from .numbers import is_num, is_strict_num
from .options import MAX_BYTES, MAX_ROWS, CsvOptions
from .source import Source, decode_text, load_bytes

__all__ = ["CSVLayout", "Table", "check_rows", "lines_text", "read_table_whole"]


@dataclass(frozen=True)
class CSVLayout:
    """What :func:`inspect_csv` (and :func:`read_csv`) worked out about a CSV.

    Attributes
    ----------
    source : str
        File path, ``"<text>"`` or ``"<bytes>"``.
    encoding : str
        Encoding used to decode the bytes.
    delimiter : str
        ``","``, ``";"``, ``"\\t"``, ``"|"`` or ``"whitespace"``.
    decimal : str
        ``"."`` or ``","``.
    header : bool
        Whether the first row holds column names.
    columns : tuple of ColumnInfo
    n_rows : int
        Number of data rows.
    first_data_line : int
        1-based line of the first data row.
    notes : tuple of str
        What was skipped or interpreted (comment lines, encoding fallback, unit row).
    """

    source: str
    encoding: str
    delimiter: str
    decimal: str
    header: bool
    columns: tuple[ColumnInfo, ...]
    n_rows: int
    first_data_line: int
    notes: tuple[str, ...]


class Table:
    """Data rows of a CSV: kept as text lines, split / converted only when needed."""

    def __init__(self, layout: CSVLayout, data: list[str], lines: np.ndarray,
                 rows: list[list[str]] | None, quoted: bool) -> None:
        self.layout = layout
        self.data = data  # text of each data line
        self.lines = lines  # 1-based line number of each data line
        self._rows = rows
        self._quoted = quoted
        self._matrix: np.ndarray | Literal[False] | None = False  # False: not tried yet
        #: 1-based line the table starts at (its header, or its first data row)
        self.first_line = int(lines[0]) if len(lines) else 0

    @property
    def rows(self) -> list[list[str]]:
        """Every data line split into stripped cells."""
        if self._rows is None:
            self._rows = split_cells(self.data, self.layout.delimiter)
        return self._rows

    def cell(self, i: int, j: int) -> str:
        """Cell ``j`` of data row ``i`` (stripped), without splitting every line."""
        if self._rows is not None:
            return self._rows[i][j]
        return split_cells([self.data[i]], self.layout.delimiter)[0][j]

    def column(self, j: int) -> list[str]:
        return [r[j] for r in self.rows]

    def matrix(self) -> np.ndarray | None:
        """All cells as floats in one numpy parse, or None when any cell needs care.

        The fast path for clean numeric tables; anything unusual (empty or NA cells, text,
        quotes, mixed decimal marks) returns None and the cell-by-cell path handles it and
        reports problems with their line and column.
        """
        if self._matrix is not False:
            return self._matrix
        self._matrix = None
        lay = self.layout
        if self._quoted or not self.data:
            return None
        lines: Iterable[str] = self.data
        if lay.decimal == ",":
            if any("." in ln for ln in self.data):
                return None
            lines = (ln.replace(",", ".") for ln in self.data)
        # numpy's C reader, line by line: no joined copy of the text and no Python string per
        # cell (those took about 270 bytes per row of three columns, the reader's peak, and
        # three times as long); it parses numbers as float() does and refuses more (e.g.
        # "1_000"), and any line it refuses sends the table to the cell-by-cell path. No
        # warnings filter is touched (fits in other threads must keep their own).
        try:
            arr = np.loadtxt(lines, dtype=np.float64, comments=None, quotechar=None, ndmin=2,
                             delimiter=None if lay.delimiter == "whitespace" else lay.delimiter)
        except ValueError:
            return None
        width = len(lay.columns)
        if arr.size != len(self.data) * width:
            return None
        self._matrix = arr.reshape(len(self.data), width)
        return self._matrix


def read_table_whole(source: Source, opts: CsvOptions, min_columns: int = 2
                     ) -> tuple[Table, str]:
    """The table of ``source`` read as one text, and the file stem.

    Parameters
    ----------
    source : path, str, bytes, open file or CSVText
        As for :func:`~core.csvio.read_csv`.
    opts : CsvOptions
        Its ``delimiter``, ``decimal``, ``header``, ``skiprows``, ``encoding``,
        ``max_bytes`` and ``max_rows`` are used.
    min_columns : int
        Fewest columns the table must have (1 for input-only signals).

    Returns
    -------
    table : Table
    stem : str
        The file stem (``"recording"`` for content), the recordings' default name.
    """
    max_bytes = MAX_BYTES if opts.max_bytes is None else opts.max_bytes
    max_rows = MAX_ROWS if opts.max_rows is None else opts.max_rows
    opts = replace(opts, max_bytes=max_bytes, max_rows=max_rows)
    raw, label, stem = load_bytes(source, max_bytes)
    text, enc, notes = decode_text(raw, opts.encoding, label)
    content, linenos, delimiter = _content_lines(text, label, opts, notes)
    d, dec = detect_format(content[:60], delimiter, opts.decimal, label, linenos[0], min_columns)
    quoted = '"' in text
    content, linenos = _without_empty(content, linenos, d, label, notes)
    rows, content, linenos = _head(content, linenos, d, opts.skiprows, notes)
    has_header, start, names, cols = _columns(rows, linenos, dec, opts.header, notes)
    data = content[start:]
    data_lines = np.asarray(linenos[start:], dtype=np.int64)
    data_rows = check_rows(data, data_lines, linenos, names, len(cols), d, quoted, has_header,
                           label, max_rows)
    layout = CSVLayout(
        source=label, encoding=enc, delimiter=d, decimal=dec, header=has_header,
        columns=tuple(cols), n_rows=len(data),
        first_data_line=int(data_lines[0]) if data else 0, notes=tuple(notes),
    )
    table = Table(layout, data, data_lines, data_rows, quoted)
    table.first_line = linenos[0]
    return table, stem


def _content_lines(text: str, label: str, opts: CsvOptions,
                   notes: list[str]) -> tuple[list[str], list[int], str | None]:
    """The lines that hold the table (after ``skiprows``, without comments and blank
    lines), their 1-based line numbers, and the delimiter (an Excel ``sep=`` line sets it)."""
    delimiter, skiprows = opts.delimiter, opts.skiprows
    max_rows = MAX_ROWS if opts.max_rows is None else opts.max_rows
    all_lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    body = all_lines[skiprows:]
    del all_lines
    # one pass, without a stripped copy of every line (a second string per row)
    keep: list[int] = []
    blank: list[int] = []
    n_comment = 0
    for i, ln in enumerate(body):
        st = ln.strip()
        if not st:
            blank.append(i)
        elif st[0] == "#":
            n_comment += 1
        else:
            keep.append(i)
    first = body[keep[0]].strip() if keep else ""
    if keep and delimiter is None and re.fullmatch(r"sep=.", first):
        delimiter = first[4]  # Excel's "sep=;" first line
        notes.append(f"line {keep[0] + skiprows + 1} {first!r} sets the delimiter")
        keep = keep[1:]
    if len(keep) > max_rows + 2:
        stop = keep[max_rows + 2] + skiprows + 1
        raise CSVError(
            f"{label} has more than max_rows={max_rows:,} rows (stopped at line {stop}); "
            "pass a larger max_rows= to read it anyway, or cut / decimate the recording",
            source=label, line=stop,
        )
    content = [body[i] for i in keep]
    linenos = [i + skiprows + 1 for i in keep]
    check_lines(content, linenos, label)
    blank_inside = [b + skiprows + 1 for b in blank if keep[0] < b < keep[-1]] if keep else []
    if skiprows:
        notes.append(f"skipped the first {skiprows} line(s) (skiprows={skiprows})")
    if n_comment:
        notes.append(f"skipped {n_comment} comment line(s) starting with '#'")
    if not content:
        what = "only blank lines" if n_comment == 0 else "only comment and blank lines"
        raise CSVError(
            f"{label} is empty: it holds {what}, no header and no data; export the "
            "recording again", source=label,
        )
    if blank_inside:
        notes.append(f"ignored {len(blank_inside)} blank line(s) inside the data "
                     f"(line(s) {lines_text(blank_inside)})")
    return content, linenos, delimiter


def _without_empty(content: list[str], linenos: list[int], d: str, label: str,
                   notes: list[str]) -> tuple[list[str], list[int]]:
    """Without the lines holding only delimiters, and without the empty last column a
    delimiter at the end of every line makes."""
    strip_chars = " \t" if d == "whitespace" else " \t" + d
    empty = [i for i, ln in enumerate(content) if not ln.strip(strip_chars)]
    if empty:  # lines holding only delimiters (",,,")
        notes.append(f"ignored {len(empty)} line(s) holding only delimiters (line(s) "
                     f"{lines_text([linenos[i] for i in empty])})")
        drop = set(empty)
        content = [c for i, c in enumerate(content) if i not in drop]
        linenos = [n for i, n in enumerate(linenos) if i not in drop]
        if not content:
            raise CSVError(f"{label} holds only delimiters, no data; export the recording "
                           "again", source=label)
    # a delimiter at the end of every data line makes an empty last column
    if d != "whitespace" and len(content) > 1 and all(
        ln.rstrip().endswith(d) for ln in content[1:]
    ):
        h0, h1 = split_cells(content[:2], d)
        if h0[-1] == "" or len(h0) == len(h1) - 1:
            content = [ln.rstrip()[:-1] if len(r) == len(h1) else ln
                       for ln, r in zip(content, [h0] + [h1] * (len(content) - 1), strict=True)]
            notes.append(f"ignored the empty last column (every line ends with {d!r})")
    return content, linenos


def _head(content: list[str], linenos: list[int], d: str, skiprows: int,
          notes: list[str]) -> tuple[list[list[str]], list[str], list[int]]:
    """The first rows split into cells (enough to find the header and units), after an
    instrument preamble (leading lines whose field count differs) when ``skiprows`` is 0."""
    rows = split_cells(content[:64], d)  # the head: enough to find preamble, header, units
    if d == "whitespace" and len(rows) > 1 and len(rows[0]) != len(rows[1]):
        wide = [c.strip() for c in re.split(r"\s{2,}|\t", content[0].strip())]
        if len(wide) == len(rows[1]):
            rows[0] = wide  # names with single spaces inside, e.g. "t [s]   u [V]"
    if skiprows == 0 and len(rows) > 3:
        # an instrument preamble: leading lines whose field count differs from the table's
        width = len(rows[min(len(rows) - 1, 2)])
        head = 0
        while head < min(len(rows) - 2, 20) and len(rows[head]) != width:
            head += 1
        if 0 < head and all(len(r) == width for r in rows[head:head + 3]):
            shown = "; ".join(repr(c[:40]) for c in content[:head][:3])
            notes.append(
                f"skipped {head} preamble line(s) before line {linenos[head]} whose field "
                f"count differs from the table ({shown}); pass skiprows= to choose yourself"
            )
            rows, content, linenos = rows[head:], content[head:], linenos[head:]
    return rows, content, linenos


def _columns(rows: list[list[str]], linenos: list[int], dec: str, header: bool | None,
             notes: list[str]) -> tuple[bool, int, list[str], list[ColumnInfo]]:
    """Whether there is a header, the index of the first data row, the names and the
    columns (units from the names or a unit row)."""
    first = rows[0]
    if header is None:
        has_header = not all(is_num(c, dec) for c in first)
    else:
        has_header = bool(header)
    start = 1 if has_header else 0
    names = first if has_header else [f"column {j}" for j in range(len(first))]
    unit_row: list[str] | None = None
    if has_header and len(rows) > 1:
        cand = rows[1]
        if (len(cand) == len(names) and any(c for c in cand)
                and not any(is_strict_num(c, dec) for c in cand)
                and (len(rows) == 2 or all(is_num(c, dec) for c in rows[2]))):
            unit_row = cand
            start = 2
            notes.append(f"read units from line {linenos[1]}: {', '.join(cand)}")
    cols = []
    seen: dict[str, int] = {}
    for j, nm in enumerate(names):
        nm = nm.strip() or f"column {j}"
        base, unit = parse_column_name(nm)
        if unit_row is not None and not unit and unit_row[j].strip():
            unit = norm_unit(unit_row[j].strip().strip("()[]{}"))
        if base.lower() in seen:
            notes.append(f"column {j} ({nm!r}) has the same name as column "
                         f"{seen[base.lower()]}; pick it by index")
        seen.setdefault(base.lower(), j)
        cols.append(ColumnInfo(j, nm, base, unit))
    return has_header, start, names, cols


def check_rows(data: list[str], data_lines: np.ndarray, linenos: Sequence[int],
               names: list[str], width: int, d: str, quoted: bool, has_header: bool, label: str,
               max_rows: int | None) -> list[list[str]] | None:
    """Refuse a header without data, too many rows and ragged rows; the split rows when
    they had to be split to count their fields (quotes, whitespace), else None."""
    if not data and has_header:
        raise CSVError(
            f"{label} has only a header (line {linenos[0]}: {', '.join(names)}) and no "
            "data rows after the header; export the recording again with its samples",
            source=label, line=linenos[0],
        )
    if max_rows is not None and len(data) > max_rows:
        raise CSVError(
            f"{label} has {len(data):,} data rows, more than max_rows={max_rows:,}; "
            "pass a larger max_rows= to read it anyway, or cut / decimate the recording",
            source=label,
        )
    data_rows: list[list[str]] | None = None
    if quoted or d == "whitespace":
        data_rows = split_cells(data, d)
        counts = np.fromiter((len(r) for r in data_rows), dtype=np.int64, count=len(data))
    else:
        counts = field_counts(data, d)
    ragged = np.flatnonzero(counts != width)
    if ragged.size:
        i = int(ragged[0])
        ln = int(data_lines[i])
        ref = f"the header (line {linenos[0]})" if has_header else f"line {linenos[0]}"
        fix = (
            "if the recording was cut off, delete the incomplete line"
            if i == len(data) - 1 else
            "fix or delete that line; if the file starts with a preamble, pass skiprows="
        )
        raise CSVError(
            f"{label}: line {ln} has {int(counts[i])} field(s) but {ref} has {width} "
            f"(delimiter {'whitespace' if d == 'whitespace' else repr(d)}); {fix}",
            source=label, line=ln,
        )
    return data_rows


def lines_text(lines: Sequence[int], limit: int = 10) -> str:
    shown = ", ".join(str(int(x)) for x in lines[:limit])
    more = len(lines) - limit
    return shown + (f" and {more} more" if more > 0 else "")
