"""Robust reading of measured recordings from CSV text (DAQ exports, scope dumps).

:func:`read_csv` turns a file, a string or bytes into :class:`~core.recordings.Recording`
objects. It works out the layout by itself and says what it did:

* **Encoding**: UTF-8 (with or without BOM), UTF-16 with BOM, otherwise Latin-1 (noted).
  NUL or other control bytes mean a binary file and are an error.
* **Delimiter**: comma, semicolon, tab, ``|`` or runs of whitespace, chosen with
  :class:`csv.Sniffer` and checked by splitting the first lines with every candidate: the
  delimiter that gives a constant number (>= 2) of numeric fields wins. An Excel
  ``sep=;`` first line sets it.
* **Decimal comma** (``1,5;2,7``) is detected when the delimiter is not a comma, or forced
  with ``decimal=","``; a ``.`` in a decimal-comma file is then an error, not a number.
* **Header**: present when the first row holds a non-numeric cell (or forced with
  ``header=True/False``). An optional second row holding only units (``(s),(V)``, as
  PicoScope writes) is read as units. Lines starting with ``#`` are comments; leading
  instrument-preamble lines whose field count differs from the table are skipped (noted),
  or skip them yourself with ``skiprows=``. Blank lines and lines of bare delimiters are
  ignored (noted when inside the data), as is an empty last column from a trailing
  delimiter.
* **Units** come from column names: ``t_s``, ``u_V``, ``y_um``, ``velocity_in_per_s``
  (underscore + a known unit), ``t [s]``, ``Force (kN)``, ``u/V`` (any unit). Time in
  ``ms``, ``µs``, ``ns``, ``min`` or ``h`` is converted to seconds (noted); ISO date-times
  (``2024-03-01 12:00:00.125``) become seconds since the first stamp (noted).
* **Columns** are picked by name (case- and unit-insensitive: ``"force"`` matches
  ``Force (kN)``) or 0-based index. Defaults: a column named ``t``/``time`` is the time;
  one named ``run``/``record``/``loop``/``trial`` splits the file into several
  recordings; a sample-index column (``k``, ``index``, ``sample``) means "no time axis";
  input and output are the columns named ``u``/``u_*``/``input`` and
  ``y``/``y_*``/``output``, otherwise the next unused columns in file order. Without such
  names the first three columns are time, input, output, and the first one must strictly
  increase (else ``CSVError`` asks for ``time=`` or ``time=False``); with two columns they
  are input and output without time (sample index, or ``k / fs`` with ``fs=``). Every other
  column is kept in ``Recording.extra`` (as text when it is not numeric).

**Input-only files** (a signal to simulate, no output column) are read by
:func:`read_input` into an :class:`InputSignal`: the same encoding, delimiter, header,
unit, time and cell checks with the same messages, a one-column file is accepted (that
column is the input), no column is taken as the output (a column named ``y`` is kept as
an other column, never picked as the input while another is free), and a constant input
or a single sample is allowed.

**Text or path, never guessed from the content**: :func:`read_csv_text`,
:func:`inspect_csv_text` and :func:`read_input_text` read content (``str`` or ``bytes``, e.g.
an HTTP request body) and never touch the file system, whatever the content looks like;
pass a :class:`pathlib.Path` (or any ``os.PathLike``) to :func:`read_csv` & co. to read a
file. A plain ``str`` given to :func:`read_csv` is still read as a path when it holds no
line break (the command line's convenience); code that handles untrusted content must use
the ``*_text`` readers. Lines longer than :data:`MAX_LINE_CHARS` and unclosed quotes are
errors naming the line (a recording row is a few numbers).

Problems raise :class:`CSVError` (a :class:`~core.exceptions.ParameterError`, hence a
``ValueError``) whose message says what is wrong, where (line, column) and what to do.
Rows whose input or output is NaN/inf/empty are removed by default and every removal is
listed with its line numbers in ``Recording.cleaning``; nothing is dropped silently.
Uneven time stamps are an error unless you ask for ``resample=True`` (linear
interpolation onto a uniform grid, noted) or ``uneven="keep"``.
"""

from __future__ import annotations

import csv
import math
import os
import re
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from datetime import datetime
from pathlib import Path
from typing import IO, Any, Literal

import numpy as np

from .exceptions import ParameterError
from .recordings import Recording

__all__ = [
    "CSVError",
    "CSVLayout",
    "CSVText",
    "ColumnInfo",
    "InputSignal",
    "UnevenTimeError",
    "inspect_csv",
    "inspect_csv_text",
    "parse_column_name",
    "read_csv",
    "read_csv_text",
    "read_csvs",
    "read_input",
    "read_input_text",
    "read_recording",
]

#: Default size limit of one CSV (bytes).
MAX_BYTES = 64 * 2**20
#: Default limit on the number of data rows of one CSV.
MAX_ROWS = 2_000_000
#: Default smallest number of samples per recording.
MIN_SAMPLES = 10
#: Longest accepted line (characters); a recording row is a few numbers.
MAX_LINE_CHARS = 100_000

ColumnSpec = int | str | None | Literal[False]


@dataclass(frozen=True)
class CSVText:
    """CSV content that is read as content, never as a file name (e.g. an upload).

    Parameters
    ----------
    content : str or bytes
        The CSV text, or its bytes (the encoding is then detected as for a file).
    name : str
        Label used in messages, ``"<text>"`` by default.
    """

    content: str | bytes
    name: str = "<text>"


Source = str | os.PathLike[str] | bytes | bytearray | IO[str] | IO[bytes] | CSVText


class CSVError(ParameterError):
    """A CSV recording cannot be read as asked; the message says what, where and what to do.

    Attributes
    ----------
    source : str
        File path, ``"<text>"`` or ``"<bytes>"``.
    line : int or None
        1-based line of the problem in the file, when there is one.
    column : str or None
        Column name (or ``"column 3"``) of the problem, when there is one.
    column_index : int or None
        0-based index of that column, when known.
    """

    def __init__(
        self, message: str, *, source: str = "", line: int | None = None,
        column: str | None = None, column_index: int | None = None,
    ) -> None:
        super().__init__(message)
        self.source = source
        self.line = line
        self.column = column
        self.column_index = column_index


class UnevenTimeError(CSVError):
    """The time stamps of a recording are unevenly spaced and no choice was made.

    Raised by :func:`read_csv` (and :func:`read_input`) without ``resample`` when
    ``uneven="error"``; a caller that offers the choice (resample or keep) reads the
    spacing from the attributes instead of the message.

    Attributes
    ----------
    spacing_min, spacing_max, spacing_mean, spacing_median : float
        Smallest, largest, mean and median spacing of the time stamps, in s (the median
        is the spacing ``resample=True`` interpolates onto).
    """

    def __init__(self, message: str, *, spacing: tuple[float, float, float, float],
                 **kwargs: Any) -> None:
        super().__init__(message, **kwargs)
        self.spacing_min, self.spacing_max, self.spacing_mean, self.spacing_median = (
            float(x) for x in spacing)


# --------------------------------------------------------------------------- names/units
_UNIT_TOKENS = frozenset(
    """s sec ms us µs ns min h Hz kHz V mV uV µV kV A mA uA µA m mm um µm nm cm in ft mil
    N kN mN uN µN lb lbf kip kips Pa kPa MPa GPa psi bar T mT uT µT G Am Apm Wb W mW
    kW J rad deg g kg degC K C F pF nF uF µF Ohm ohm percent pct rpm""".split()
)
_UNIT_NORMALISE = {
    "us": "µs", "uV": "µV", "uA": "µA", "um": "µm", "uN": "µN", "uT": "µT", "uF": "µF",
    "sec": "s", "Am": "A/m", "Apm": "A/m", "ohm": "Ohm", "percent": "%", "pct": "%", "kips": "kip",
}
_TIME_SCALE = {
    "s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0,
    "ms": 1e-3, "msec": 1e-3, "us": 1e-6, "µs": 1e-6, "μs": 1e-6, "ns": 1e-9,
    "min": 60.0, "h": 3600.0,
}
_TIME_NAMES = frozenset({"t", "time", "times", "timestamp", "time_stamp", "zeit", "temps"})
_RUN_NAMES = frozenset(
    {"run", "run_id", "runid", "record", "recording", "loop", "trial", "experiment", "rep"}
)
_INDEX_NAMES = frozenset({"k", "idx", "index", "sample", "samples", "sample_index", "#", "no",
                          "nr"})
_INPUT_NAMES = frozenset({"u", "input", "in"})
_OUTPUT_NAMES = frozenset({"y", "output", "out"})
_NA_TOKENS = frozenset({"", "nan", "na", "n/a", "null", "none", "-nan", "+nan", "#n/a"})
_BRACKET = re.compile(r"^(.*?)\s*[\[(\{]\s*([^\])\}]*?)\s*[\])\}]\s*$")
_SLASH = re.compile(r"^(.*?\S)\s*/\s*([^/\s]{1,12})$")
_DECIMAL_COMMA = re.compile(r"^[+-]?(\d+,\d*|,\d+)([eE][+-]?\d+)?$")


def _norm_unit(unit: str) -> str:
    unit = unit.strip()
    unit = _UNIT_NORMALISE.get(unit, unit)
    return unit


def parse_column_name(raw: str) -> tuple[str, str]:
    """Split a column header into ``(name, unit)``.

    Recognised forms: ``"t [s]"``, ``"Force (kN)"``, ``"u/V"`` (any unit), and
    ``"t_s"``, ``"y_um"``, ``"u_disp_in"``, ``"velocity_in_per_s"`` (an underscore suffix
    that is a known unit, so ``"u_disp"`` stays a name). ``um``/``us``/... become
    ``µm``/``µs``/..., ``Am`` becomes ``A/m``.

    Parameters
    ----------
    raw : str
        The header cell.

    Returns
    -------
    name : str
        The name without the unit (stripped; the raw text when nothing matched).
    unit : str
        The unit, ``""`` when none was found.

    Examples
    --------
    >>> parse_column_name("y_um"), parse_column_name("Force (kN)")
    (('y', 'µm'), ('Force', 'kN'))
    """
    s = raw.strip()
    m = _BRACKET.match(s)
    if m and m.group(1):
        return m.group(1).strip(), _norm_unit(m.group(2))
    m = _SLASH.match(s)
    if m and "_" not in m.group(2):
        return m.group(1).strip(), _norm_unit(m.group(2))
    parts = s.split("_")
    if len(parts) >= 4 and parts[-2] == "per" and parts[-3] in _UNIT_TOKENS \
            and parts[-1] in _UNIT_TOKENS:
        a, b = _norm_unit(parts[-3]), _norm_unit(parts[-1])
        return "_".join(parts[:-3]), f"{a}/{b}"
    if len(parts) >= 2 and parts[-1] in _UNIT_TOKENS and parts[0]:
        return "_".join(parts[:-1]), _norm_unit(parts[-1])
    return s, ""


@dataclass(frozen=True)
class ColumnInfo:
    """One column of a CSV.

    Attributes
    ----------
    index : int
        0-based position.
    raw : str
        The header cell as written (``"column 3"`` without a header).
    name : str
        Name without the unit.
    unit : str
        Unit (``""`` if unknown).
    """

    index: int
    raw: str
    name: str
    unit: str

    @property
    def key(self) -> str:
        """Lower-case name used for matching."""
        return self.name.lower()

    def label(self) -> str:
        """``'u_V' (column 1)`` for messages (``column 1`` without a header)."""
        if self.raw == f"column {self.index}":
            return self.raw
        return f"{self.raw!r} (column {self.index})"


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


class _Table:
    """Data rows of a CSV: kept as text lines, split / converted only when needed."""

    def __init__(self, layout: CSVLayout, data: list[str], lines: np.ndarray,
                 rows: list[list[str]] | None, quoted: bool) -> None:
        self.layout = layout
        self.data = data  # text of each data line
        self.lines = lines  # 1-based line number of each data line
        self._rows = rows
        self._quoted = quoted
        self._matrix: np.ndarray | None | bool = False  # False: not tried yet

    @property
    def rows(self) -> list[list[str]]:
        """Every data line split into stripped cells."""
        if self._rows is None:
            self._rows = _split(self.data, self.layout.delimiter)
        return self._rows

    def cell(self, i: int, j: int) -> str:
        """Cell ``j`` of data row ``i`` (stripped), without splitting every line."""
        if self._rows is not None:
            return self._rows[i][j]
        return _split([self.data[i]], self.layout.delimiter)[0][j]

    def column(self, j: int) -> list[str]:
        return [r[j] for r in self.rows]

    def matrix(self) -> np.ndarray | None:
        """All cells as floats in one numpy parse, or None when any cell needs care.

        The fast path for clean numeric tables; anything unusual (empty or NA cells, text,
        quotes, mixed decimal marks) returns None and the cell-by-cell path handles it and
        reports problems with their line and column.
        """
        if self._matrix is not False:
            return self._matrix  # type: ignore[return-value]
        self._matrix = None
        lay = self.layout
        if self._quoted or not self.data:
            return None
        block = "\n".join(self.data)
        if lay.decimal == ",":
            if "." in block:
                return None
            block = block.replace(",", ".")
        if lay.delimiter == "whitespace":
            sep = " "
        else:
            sep = ","
            if lay.delimiter != ",":
                block = block.replace(lay.delimiter, ",")
            block = block.replace("\n", ",")
        if "_" in block or "x" in block or "X" in block:
            return None  # "1_000", "0x1f": let float() decide, cell by cell
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                arr = np.fromstring(block, sep=sep)
        except (ValueError, DeprecationWarning):
            return None
        width = len(lay.columns)
        if arr.size != len(self.data) * width:
            return None
        self._matrix = arr.reshape(len(self.data), width)
        return self._matrix


# --------------------------------------------------------------------------- bytes → text
def _load_bytes(source: Source, max_bytes: int) -> tuple[bytes | str, str, str]:
    """Return ``(content, label, stem)``."""
    too_big = (
        "{label} is {size:,} bytes, more than max_bytes={mb:,}; pass a larger max_bytes= to "
        "read it anyway, or cut / decimate the recording first"
    )
    if isinstance(source, CSVText):
        content = source.content
        if not isinstance(content, (str, bytes, bytearray)):
            raise CSVError(f"CSV content must be str or bytes, not {type(content).__name__}")
        if len(content) > max_bytes:
            raise CSVError(too_big.format(label=source.name, size=len(content), mb=max_bytes),
                           source=source.name)
        data = content if isinstance(content, str) else bytes(content)
        return data, source.name, "recording"
    if isinstance(source, (bytes, bytearray)):
        label = "<bytes>"
        if len(source) > max_bytes:
            raise CSVError(too_big.format(label=label, size=len(source), mb=max_bytes),
                           source=label)
        return bytes(source), label, "recording"
    if hasattr(source, "read"):
        label = str(getattr(source, "name", "<stream>"))
        data = source.read(max_bytes + 1)  # type: ignore[union-attr]
        if len(data) > max_bytes:
            raise CSVError(f"{label} is more than max_bytes={max_bytes:,} bytes; pass a "
                           "larger max_bytes= to read it anyway", source=label)
        return data, label, Path(label).stem if label != "<stream>" else "recording"
    if isinstance(source, str) and ("\n" in source or "\r" in source):
        label = "<text>"
        if len(source) > max_bytes:
            raise CSVError(too_big.format(label=label, size=len(source), mb=max_bytes),
                           source=label)
        return source, label, "recording"
    if not isinstance(source, (str, os.PathLike)):
        raise CSVError(
            f"cannot read a CSV from a {type(source).__name__}; pass a path, the CSV text "
            "(a str with newlines), bytes, or an open file"
        )
    path = Path(source)
    label = str(path)
    if not path.is_file():
        hint = (
            "; to parse CSV text pass a string that contains newlines"
            if isinstance(source, str) else ""
        )
        raise CSVError(f"{label}: no such file{hint}", source=label)
    size = path.stat().st_size
    if size > max_bytes:
        raise CSVError(too_big.format(label=label, size=size, mb=max_bytes), source=label)
    return path.read_bytes(), label, path.stem


def _line_of_offset(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def _decode_utf16(data: bytes, label: str) -> str:
    """``data`` (UTF-16 with its BOM) as text; a lone surrogate or a cut-off last character
    is a :class:`CSVError` naming its line."""
    try:
        return data.decode("utf-16")
    except UnicodeDecodeError as exc:
        start = exc.start  # a byte offset into data, the BOM included
        before = data[:start - (start % 2)].decode("utf-16", errors="replace")
        line = before.count("\n") + 1
        what = ("an unpaired surrogate" if "surrogate" in exc.reason
                else "a character cut off at the end of the file")
        raise CSVError(
            f"{label} is not valid UTF-16: {what} at byte {start} (line {line}); save the "
            "recording again as UTF-8 or UTF-16 text",
            source=label, line=line,
        ) from exc


def _decode(data: bytes | str, encoding: str | None, label: str) -> tuple[str, str, list[str]]:
    """Return ``(text, encoding, notes)``; reject binary content."""
    notes: list[str] = []
    if isinstance(data, str):
        text, enc = data, "str"
    else:
        if len(data) == 0:
            raise CSVError(
                f"{label}: the file is empty (0 bytes); export the recording again",
                source=label,
            )
        if encoding is not None:
            try:
                text, enc = data.decode(encoding), encoding
            except (UnicodeDecodeError, LookupError) as exc:
                raise CSVError(
                    f"{label} cannot be decoded as {encoding}: {exc}; leave encoding=None "
                    "to detect it", source=label
                ) from exc
        elif data[:2] in (b"\xff\xfe", b"\xfe\xff"):
            text, enc = _decode_utf16(data, label), "utf-16"
        else:
            nul = data.find(b"\x00")
            if nul >= 0:
                line = _line_of_offset(data, nul)
                raise CSVError(
                    f"{label} is not a text CSV: NUL byte at byte offset {nul} (line {line}); "
                    "it looks like a binary file (e.g. a .tdms/.mat/.xlsx); export the "
                    "recording as CSV text",
                    source=label, line=line,
                )
            try:
                text, enc = data.decode("utf-8-sig"), "utf-8"
            except UnicodeDecodeError as exc:
                line = _line_of_offset(data, exc.start)
                text, enc = data.decode("latin-1"), "latin-1"
                notes.append(
                    f"decoded as Latin-1: not valid UTF-8 at byte {exc.start} (line {line})"
                )
    text = text.lstrip("\ufeff")
    if isinstance(data, bytes) and enc in ("utf-8", "latin-1"):
        # control bytes < 0x80 are the same characters in UTF-8 and Latin-1: check the bytes
        b = np.frombuffer(data, dtype=np.uint8)
        bad = np.flatnonzero(((b < 32) & ((b < 9) | (b > 13))) | (b == 127))
        pos = int(bad[0]) if bad.size else -1
        ctrl_char = chr(data[pos]) if bad.size else ""
        line = _line_of_offset(data, pos) if bad.size else 0
    else:
        m = re.search(r"[\x00-\x08\x0e-\x1f\x7f]", text)
        ctrl_char = m.group() if m else ""
        line = text.count("\n", 0, m.start()) + 1 if m else 0
    if ctrl_char:
        raise CSVError(
            f"{label} is not a text CSV: control character {ctrl_char!r} on line {line}; "
            "it looks like binary data; export the recording as CSV text",
            source=label, line=line,
        )
    return text, enc, notes


# --------------------------------------------------------------------------- tokenising
def _is_num(cell: str, decimal: str) -> bool:
    c = cell.strip()
    if c.lower() in _NA_TOKENS:
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


def _is_strict_num(cell: str, decimal: str) -> bool:
    """A real number (not empty, not an NA token)."""
    c = cell.strip()
    return bool(c) and c.lower() not in _NA_TOKENS and _is_num(c, decimal)


def _split(lines: Sequence[str], delimiter: str) -> list[list[str]]:
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


def _detect_format(
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
        rows = _split(sample, d)
        body_rows = _split(body, d)
        widths = [len(r) for r in body_rows]
        width = max(set(widths), key=widths.count) if widths else 0
        share = widths.count(width) / len(widths) if widths else 0.0
        cells = [c for r in body_rows for c in r]
        for dec in ((decimal,) if decimal else (".", ",")):
            if d == "," and dec == "," or not cells:
                continue
            frac = sum(_is_num(c, dec) for c in cells) / len(cells)
            strict = sum(_is_strict_num(c, dec) for c in cells) / len(cells)
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


def _table(
    source: Source,
    *,
    delimiter: str | None,
    decimal: str | None,
    header: bool | None,
    skiprows: int,
    encoding: str | None,
    max_bytes: int,
    max_rows: int,
    min_columns: int = 2,
) -> tuple[_Table, str]:
    raw, label, stem = _load_bytes(source, max_bytes)
    text, enc, notes = _decode(raw, encoding, label)
    all_lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    body = all_lines[skiprows:]
    stripped = [ln.strip() for ln in body]
    keep = [i for i, st in enumerate(stripped) if st and st[0] != "#"]
    n_comment = sum(1 for st in stripped if st[:1] == "#")
    if keep and delimiter is None and re.fullmatch(r"sep=.", stripped[keep[0]]):
        delimiter = stripped[keep[0]][4]  # Excel's "sep=;" first line
        notes.append(f"line {keep[0] + skiprows + 1} {stripped[keep[0]]!r} sets the delimiter")
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
    _check_lines(content, linenos, label)
    blank_inside = (
        [keep[0] + k + skiprows + 1 for k, st in enumerate(stripped[keep[0]:keep[-1]]) if not st]
        if keep else []
    )
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
                     f"(line(s) {_lines_text(blank_inside)})")
    d, dec = _detect_format(content[:60], delimiter, decimal, label, linenos[0], min_columns)
    quoted = '"' in text
    strip_chars = " \t" if d == "whitespace" else " \t" + d
    empty = [i for i, ln in enumerate(content) if not ln.strip(strip_chars)]
    if empty:  # lines holding only delimiters (",,,")
        notes.append(f"ignored {len(empty)} line(s) holding only delimiters (line(s) "
                     f"{_lines_text([linenos[i] for i in empty])})")
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
        h0, h1 = _split(content[:2], d)
        if h0[-1] == "" or len(h0) == len(h1) - 1:
            content = [ln.rstrip()[:-1] if len(r) == len(h1) else ln
                       for ln, r in zip(content, [h0] + [h1] * (len(content) - 1), strict=True)]
            notes.append(f"ignored the empty last column (every line ends with {d!r})")
    rows = _split(content[:64], d)  # the head: enough to find preamble, header, units
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
    first = rows[0]
    if header is None:
        has_header = not all(_is_num(c, dec) for c in first)
    else:
        has_header = bool(header)
    start = 1 if has_header else 0
    names = first if has_header else [f"column {j}" for j in range(len(first))]
    unit_row: list[str] | None = None
    if has_header and len(rows) > 1:
        cand = rows[1]
        if (len(cand) == len(names) and any(c for c in cand)
                and not any(_is_strict_num(c, dec) for c in cand)
                and (len(rows) == 2 or all(_is_num(c, dec) for c in rows[2]))):
            unit_row = cand
            start = 2
            notes.append(f"read units from line {linenos[1]}: {', '.join(cand)}")
    cols = []
    seen: dict[str, int] = {}
    for j, nm in enumerate(names):
        nm = nm.strip() or f"column {j}"
        base, unit = parse_column_name(nm)
        if unit_row is not None and not unit and unit_row[j].strip():
            unit = _norm_unit(unit_row[j].strip().strip("()[]{}"))
        if base.lower() in seen:
            notes.append(f"column {j} ({nm!r}) has the same name as column "
                         f"{seen[base.lower()]}; pick it by index")
        seen.setdefault(base.lower(), j)
        cols.append(ColumnInfo(j, nm, base, unit))
    data = content[start:]
    data_lines = np.asarray(linenos[start:], dtype=np.int64)
    if not data and has_header:
        raise CSVError(
            f"{label} has only a header (line {linenos[0]}: {', '.join(names)}) and no "
            "data rows after the header; export the recording again with its samples",
            source=label, line=linenos[0],
        )
    if len(data) > max_rows:
        raise CSVError(
            f"{label} has {len(data):,} data rows, more than max_rows={max_rows:,}; "
            "pass a larger max_rows= to read it anyway, or cut / decimate the recording",
            source=label,
        )
    width = len(cols)
    data_rows: list[list[str]] | None = None
    if quoted or d == "whitespace":
        data_rows = _split(data, d)
        counts = np.fromiter((len(r) for r in data_rows), dtype=np.int64, count=len(data))
    else:
        counts = _field_counts(data, d)
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
    layout = CSVLayout(
        source=label, encoding=enc, delimiter=d, decimal=dec, header=has_header,
        columns=tuple(cols), n_rows=len(data),
        first_data_line=int(data_lines[0]) if data else 0, notes=tuple(notes),
    )
    return _Table(layout, data, data_lines, data_rows, quoted), stem


def _check_lines(content: Sequence[str], linenos: Sequence[int], label: str) -> None:
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


def _field_counts(data: list[str], d: str) -> np.ndarray:
    """Number of ``d``-separated fields on each line (vectorised over the bytes)."""
    if not data:
        return np.zeros(0, dtype=np.int64)
    b = np.frombuffer("\n".join(data).encode("utf-8", "surrogatepass"), dtype=np.uint8)
    nl = np.flatnonzero(b == 10)
    line_of_delim = np.searchsorted(nl, np.flatnonzero(b == ord(d)))
    return np.bincount(line_of_delim, minlength=len(data)).astype(np.int64) + 1


def inspect_csv(
    source: Source,
    *,
    delimiter: str | None = None,
    decimal: str | None = None,
    header: bool | None = None,
    skiprows: int = 0,
    encoding: str | None = None,
    max_bytes: int = MAX_BYTES,
    max_rows: int = MAX_ROWS,
    min_columns: int = 2,
) -> CSVLayout:
    """Work out the layout of a CSV without converting it (for previews and pickers).

    Parameters are those of :func:`read_csv`, and:

    min_columns : int
        Fewest columns the table must have: 2 for recordings (input and output, the
        default), 1 for input-only signals (see :func:`read_input`).

    Returns
    -------
    CSVLayout
        Delimiter, decimal mark, header, columns with units, number of rows.
    """
    return _table(
        source, delimiter=delimiter, decimal=decimal, header=header, skiprows=skiprows,
        encoding=encoding, max_bytes=max_bytes, max_rows=max_rows, min_columns=min_columns,
    )[0].layout


# --------------------------------------------------------------------------- columns
def _available(cols: Sequence[ColumnInfo]) -> str:
    return ", ".join(f"{c.index}: {c.raw!r}" for c in cols)


def _find(spec: int | str, role: str, cols: Sequence[ColumnInfo], label: str) -> ColumnInfo:
    if isinstance(spec, bool):
        raise CSVError(f"{role}={spec!r}: give a column name or 0-based index", source=label)
    if isinstance(spec, (int, np.integer)):
        j = int(spec)
        if not 0 <= j < len(cols):
            raise CSVError(
                f"{label}: {role}={j} is not a column index; the file has {len(cols)} "
                f"columns (0..{len(cols) - 1}): {_available(cols)}", source=label,
            )
        return cols[j]
    if not isinstance(spec, str):
        raise CSVError(f"{role}={spec!r} must be a column name or a 0-based index",
                       source=label)
    want = spec.strip().lower()
    hits = [c for c in cols if c.raw.strip().lower() == want]
    if not hits:
        key = parse_column_name(spec)[0].lower()
        hits = [c for c in cols if c.key == key]
    if not hits:
        raise CSVError(
            f"{label}: no column named {spec!r} for {role}; available columns: "
            f"{_available(cols)} (names match without case and unit, or give the index)",
            source=label, column=spec,
        )
    if len(hits) > 1:
        raise CSVError(
            f"{label}: {role}={spec!r} matches several columns ({_available(hits)}); "
            "pick one by its 0-based index", source=label, column=spec,
        )
    return hits[0]


def _by_name(cols: Iterable[ColumnInfo], names: frozenset[str],
             prefixes: tuple[str, ...] = ()) -> ColumnInfo | None:
    for c in cols:
        if c.key in names or any(c.key.startswith(p) for p in prefixes):
            return c
    return None


def _lines_text(lines: Sequence[int], limit: int = 10) -> str:
    shown = ", ".join(str(int(x)) for x in lines[:limit])
    more = len(lines) - limit
    return shown + (f" and {more} more" if more > 0 else "")


def _convert(
    table: _Table, col: ColumnInfo, *, strict: bool, role: str
) -> np.ndarray | None:
    """Column as float64 (NA tokens → NaN). Non-numeric: error if strict, else None."""
    dec = table.layout.decimal
    m = table.matrix()
    if m is not None:
        return np.array(m[:, col.index])
    cells = table.column(col.index)
    if dec == ",":
        # a "." in a decimal-comma file is an error, not a second decimal mark
        cells = [c.replace(",", ".") if "." not in c else "?" for c in cells]
    try:
        arr = np.asarray(cells, dtype=np.float64)
        if not any("_" in c for c in cells):
            return arr
    except ValueError:
        pass
    out = np.empty(len(cells))
    for i, c in enumerate(cells):
        s = c.strip()
        if s.lower() in _NA_TOKENS:
            out[i] = np.nan
            continue
        try:
            if "_" in s or s == "?":
                raise ValueError(s)
            out[i] = float(s)
        except ValueError:
            if not strict:
                return None
            line = int(table.lines[i])
            original = table.rows[i][col.index]
            hint = "fix or delete that row"
            if dec == "," and "." in original:
                hint = "the file uses decimal commas elsewhere; write it with a comma"
            elif dec == "." and _DECIMAL_COMMA.match(original.strip()):
                hint = "it looks like a decimal comma: pass decimal=','"
            elif i == 0 and not table.layout.header:
                hint = "if that line holds column names, pass header=True"
            raise CSVError(
                f"{table.layout.source}: line {line}, {role} column {col.label()}: "
                f"{original!r} is not a number; {hint}",
                source=table.layout.source, line=line, column=col.raw, column_index=col.index,
            ) from None
    return out


def _convert_time(table: _Table, col: ColumnInfo) -> tuple[np.ndarray, str | None]:
    """Time column as float64; ISO date-times become seconds since the first stamp."""
    arr = _convert(table, col, strict=False, role="time")
    if arr is not None:
        return arr, None
    stamps: list[datetime | None] = []
    for c in table.column(col.index):
        c = c.strip()
        if c.lower() in _NA_TOKENS:
            stamps.append(None)
            continue
        try:
            stamps.append(datetime.fromisoformat(c.replace(",", ".")))
        except ValueError:
            # not date-times either: report the first non-number
            return _convert(table, col, strict=True, role="time"), None  # type: ignore[return-value]
    valid = [s for s in stamps if s is not None]
    if not valid:
        return _convert(table, col, strict=True, role="time"), None  # type: ignore[return-value]
    t0 = valid[0]
    try:
        out = np.array([np.nan if s is None else (s - t0).total_seconds() for s in stamps])
    except TypeError as exc:  # naive and aware stamps mixed
        raise CSVError(
            f"{table.layout.source}: time column {col.label()} mixes date-times with and "
            f"without a time zone ({exc}); write them all the same way",
            source=table.layout.source, column=col.raw, column_index=col.index,
        ) from None
    return out, f"time column {col.raw!r} holds date-times; converted to seconds since {t0}"


def _choose_roles(
    table: _Table, *, time: ColumnSpec, input: ColumnSpec,  # noqa: A002 - role name
    output: ColumnSpec, run: ColumnSpec, with_output: bool,
) -> tuple[dict[str, ColumnInfo | None], list[str], bool]:
    """Pick the run, time, input (and output) columns; see the module docstring.

    Returns
    -------
    chosen : dict
        ``"run"``, ``"time"``, ``"input"`` (and ``"output"`` when ``with_output``) to the
        column, or None for run / time when there is none.
    notes : list of str
        How a missing time axis was interpreted.
    time_auto : bool
        Whether the time column was taken by position (it must then increase, else the
        error asks for ``time=``).
    """
    lay = table.layout
    label = lay.source
    cols = list(lay.columns)
    chosen: dict[str, ColumnInfo | None] = {}
    specs: list[tuple[str, ColumnSpec]] = [("run", run), ("time", time), ("input", input)]
    if with_output:
        specs.append(("output", output))
    for role, spec in specs:
        if spec is None or spec is False:
            chosen[role] = None
        else:
            chosen[role] = _find(spec, role, cols, label)
    taken: dict[int, str] = {}
    for role, c in chosen.items():
        if c is not None:
            taken.setdefault(c.index, role)
    for role, c in chosen.items():
        if c is not None and taken[c.index] != role:
            raise CSVError(
                f"{label}: {taken[c.index]} and {role} both refer to column {c.label()}; "
                "pick a different column for one of them", source=label, column=c.raw,
                column_index=c.index,
            )

    def free() -> list[ColumnInfo]:
        used = {c.index for c in chosen.values() if c is not None}
        return [c for c in cols if c.index not in used]

    if run is None and lay.header:
        chosen["run"] = _by_name(free(), _RUN_NAMES)
    index_col = _by_name(free(), _INDEX_NAMES) if lay.header else None
    if index_col is not None:
        # a sample index holds whole numbers that increase (within each run) and has no unit
        k = _convert(table, index_col, strict=False, role="index")
        if index_col.unit or k is None or not np.all(np.isfinite(k)) or np.any(k != np.round(k)):
            index_col = None
    notes_roles: list[str] = []
    time_auto = False
    want_output = with_output and output is None
    if time is None:
        named = _by_name(free(), _TIME_NAMES) if lay.header else None
        if named is not None:
            chosen["time"] = named
        elif index_col is not None:
            notes_roles.append(f"no time column: column {index_col.label()} is a sample index")
        else:
            cand = free()
            needed = 1 + (input is None) + want_output
            least = 2 + with_output - (input is not None) - (with_output and output is not None)
            io_named = lay.header and cand and _by_name(
                cand[:1], _INPUT_NAMES | _OUTPUT_NAMES, ("u_", "y_", "input_", "output_")
            )
            if not io_named and len(cand) >= max(needed, least):
                chosen["time"] = cand[0]
                time_auto = True
            else:
                notes_roles.append("no time column: the time axis is the sample index")
    roles = [("input", _INPUT_NAMES, ("u_", "input_"))]
    if with_output:
        roles.append(("output", _OUTPUT_NAMES, ("y_", "output_")))
    for role, names, prefixes in roles:
        if chosen[role] is None:
            pool = [c for c in free() if c is not index_col]
            hit = _by_name(pool, names, prefixes) if lay.header else None
            if hit is None:
                # never take a column that another role's name claims
                other = _OUTPUT_NAMES if role == "input" else _INPUT_NAMES
                opre = ("y_", "output_") if role == "input" else ("u_", "input_")
                pool2 = [c for c in pool if not (lay.header and _by_name([c], other, opre))]
                hit = pool2[0] if pool2 else (pool[0] if pool else None)
            if hit is None:
                need = ("a recording needs an input and an output column" if with_output
                        else "pick the input column with input=")
                raise CSVError(
                    f"{label}: no column left for the {role}; the file has {len(cols)} "
                    f"column(s): {_available(cols)}; {need}", source=label,
                )
            chosen[role] = hit
    return chosen, notes_roles, time_auto


def _time_scale(
    label: str, tcol: ColumnInfo | None, time_unit: str | None, dt_note: str | None
) -> tuple[float, str | None]:
    """Factor from the time column's unit to seconds, and the note saying so."""
    if time_unit is not None and (tcol is None or dt_note is not None):
        why = "there is no time column" if tcol is None else "the time column holds date-times"
        raise CSVError(f"{label}: time_unit={time_unit!r} was given but {why}; leave it out",
                       source=label)
    t_scale, t_unit_note = 1.0, dt_note
    if tcol is not None and dt_note is None:
        unit = (time_unit or tcol.unit or "s").strip()
        if unit not in _TIME_SCALE:
            raise CSVError(
                f"{label}: time column {tcol.label()} has unit {unit!r}, which is not a time "
                f"unit ({', '.join(sorted(set(_TIME_SCALE)))}); pass time_unit= or pick "
                "another column with time=", source=label, column=tcol.raw, column_index=tcol.index,
            )
        t_scale = _TIME_SCALE[unit]
        if t_scale != 1.0:
            t_unit_note = f"time converted from {unit} to s (×{t_scale:g})"
    return t_scale, t_unit_note


# --------------------------------------------------------------------------- reader
def read_csv(
    source: Source,
    *,
    time: ColumnSpec = None,
    input: ColumnSpec = None,  # noqa: A002 - mirrors the role name
    output: ColumnSpec = None,
    run: ColumnSpec = None,
    delimiter: str | None = None,
    decimal: str | None = None,
    header: bool | None = None,
    skiprows: int = 0,
    encoding: str | None = None,
    name: str | None = None,
    fs: float | None = None,
    time_unit: str | None = None,
    nan: Literal["drop", "error"] = "drop",
    max_dropped: float = 0.05,
    min_samples: int = MIN_SAMPLES,
    resample: bool | float = False,
    uneven: Literal["error", "keep"] = "error",
    citation: str = "",
    max_bytes: int = MAX_BYTES,
    max_rows: int = MAX_ROWS,
) -> list[Recording]:
    """Read one or several recordings from CSV text.

    Parameters
    ----------
    source : path, str, bytes or open file
        A path (``str`` without newline or ``os.PathLike``), the CSV text itself (a
        ``str`` containing a newline), its bytes, or a file object.
    time : int, str, False or None
        Time column (name or 0-based index); ``False`` for none (the time axis is then
        the sample index, or ``k / fs`` when ``fs`` is given); ``None`` to choose (see
        the module docstring). A chosen column must strictly increase within each run.
    input, output : int, str or None
        Input and output columns; ``None`` to choose. For a file without an output
        column (a signal to simulate) use :func:`read_input`; ``output=False`` raises
        ``CSVError`` saying so.
    run : int, str, False or None
        Column whose value identifies the run / record / loop: each distinct value becomes
        its own :class:`Recording` (in order of first appearance) with ``run`` set.
        ``None`` picks a column named ``run``/``record``/``loop``/``trial``/..., ``False``
        disables it.
    delimiter : {",", ";", "\\t", "|", "whitespace"}, optional
        Detected when omitted.
    decimal : {".", ","}, optional
        Decimal mark, detected when omitted (``","`` needs another delimiter).
    header : bool, optional
        Whether the first row holds column names; detected when omitted.
    skiprows : int
        Lines to skip before the header (instrument preambles; with 0, leading lines whose
        field count differs from the table are skipped and noted).
    encoding : str, optional
        Text encoding; detected when omitted.
    name : str, optional
        Recording name; the file stem by default (``" loop=3"`` is appended per run).
    fs : float, optional
        Sampling rate in Hz for files without a time column (``t = k / fs``); an error
        when a time column is in use (pass ``time=False`` to prefer ``fs``).
    time_unit : str, optional
        Unit of the time column when its name has none or the wrong one
        (``s``, ``ms``, ``us``/``µs``, ``ns``, ``min``, ``h``); times are stored in s.
    nan : {"drop", "error"}
        What to do with rows whose input or output is empty, NaN or inf: drop them and list
        their lines in ``Recording.cleaning`` (default), or raise.
    max_dropped : float
        Largest fraction of rows ``nan="drop"`` may remove before it raises instead.
    min_samples : int
        Fewest samples a recording may have after cleaning (default 10).
    resample : bool or float
        ``True``: recordings with uneven time stamps (or gaps left by dropped rows) are
        linearly interpolated onto a uniform grid at their median spacing; a float: every
        recording is resampled to that spacing in seconds. Both are noted in ``cleaning``.
    uneven : {"error", "keep"}
        Without ``resample``, uneven time stamps (any spacing more than 1 % plus the printed
        resolution away from the mean) raise ``CSVError`` (default) or are kept as
        measured (noted).
    citation : str
        Attribution stored in every returned recording.
    max_bytes, max_rows : int
        Size limits (default 64 MiB and 2 million rows, which keep the memory
        of the text parse below about 1 GB); larger files raise ``CSVError``.

    Returns
    -------
    list of Recording
        One per run (one when there is no run column).

    Raises
    ------
    CSVError
        The message names the problem, the line and column, and the fix: empty file,
        header only, binary content, non-numeric cells, ragged rows, unknown or twice
        picked columns, too few samples, constant input, non-increasing / duplicated /
        missing / uneven time stamps, too many NaN rows, size limits.

    Examples
    --------
    >>> recs = read_csv("t_s,u_V,y_um\\n" + "".join(
    ...     f"{k / 100},{(-1) ** (k // 5) * k},{k / 2}\\n" for k in range(20)))
    >>> recs[0].units["output"], recs[0].fs
    ('µm', 100.0)
    """
    if output is False:
        raise CSVError(
            "output=False: read_csv() reads recordings, which need an output column; read a "
            "file that holds only the input (and time) with read_input()"
        )
    _check_options(nan, uneven, max_dropped)
    table, stem = _table(
        source, delimiter=delimiter, decimal=decimal, header=header, skiprows=skiprows,
        encoding=encoding, max_bytes=max_bytes, max_rows=max_rows,
    )
    lay = table.layout
    label = lay.source
    cols = list(lay.columns)
    base_name = name or stem

    # ---- roles
    chosen, notes_roles, time_auto = _choose_roles(
        table, time=time, input=input, output=output, run=run, with_output=True
    )

    # ---- conversion
    tcol, ucol, ycol, rcol = chosen["time"], chosen["input"], chosen["output"], chosen["run"]
    assert ucol is not None and ycol is not None
    if fs is not None and tcol is not None:
        raise CSVError(
            f"{label}: fs={fs!r} was given but column {tcol.label()} is the time axis; pass "
            "time=False to build the time from fs instead, or leave fs out",
            source=label, column=tcol.raw, column_index=tcol.index,
        )
    t_all, dt_note = _convert_time(table, tcol) if tcol is not None else (None, None)
    u_all = _convert(table, ucol, strict=True, role="input")
    y_all = _convert(table, ycol, strict=True, role="output")
    assert u_all is not None and y_all is not None
    t_scale, t_unit_note = _time_scale(label, tcol, time_unit, dt_note)
    extras: dict[str, np.ndarray] = {}
    extra_units: dict[str, str] = {}
    extra_notes: list[str] = []
    used = {c.index for c in (tcol, ucol, ycol, rcol) if c is not None}
    for c in cols:
        if c.index in used:
            continue
        key = c.name if c.name not in extras else f"{c.name}_{c.index}"
        arr = _convert(table, c, strict=False, role="extra")
        if arr is None:
            extras[key] = np.asarray(table.column(c.index), dtype=str)
            extra_notes.append(f"column {c.label()} is not numeric; kept as text in extra")
        else:
            extras[key] = arr
        extra_units[key] = c.unit

    # ---- runs
    groups: list[tuple[str | None, np.ndarray]]
    n_rows = len(table.data)
    if rcol is not None:
        m = table.matrix()
        if m is not None:  # numeric run ids: group without splitting the lines
            _, first_i, inv = np.unique(m[:, rcol.index], return_index=True,
                                        return_inverse=True)
            groups = [(table.cell(int(first_i[g]), rcol.index), np.flatnonzero(inv == g))
                      for g in np.argsort(first_i)]
        else:
            order: dict[str, list[int]] = {}
            for i, v in enumerate(table.column(rcol.index)):
                order.setdefault(v, []).append(i)
            groups = [(k, np.asarray(v)) for k, v in order.items()]
    else:
        groups = [(None, np.arange(n_rows))]

    out = []
    for run_id_raw, idx in groups:
        run_id: str | int | None = run_id_raw
        if run_id_raw is not None:
            try:
                run_id = int(run_id_raw)
            except ValueError:
                run_id = run_id_raw
        rname = base_name if rcol is None else f"{base_name} {rcol.name}={run_id}"
        where = "" if rcol is None else f" (run {rcol.name}={run_id})"
        lines = table.lines[idx]
        notes = list(lay.notes) + notes_roles + extra_notes
        if t_unit_note:
            notes.append(t_unit_note)
        u, y = u_all[idx], y_all[idx]
        ex = {k: v[idx] for k, v in extras.items()}
        has_time = True
        if tcol is not None:
            assert t_all is not None
            t = t_all[idx] * t_scale
            t = _check_time(t, lines, tcol, table, idx, label, where, time_auto,
                            t_scale=t_scale, uneven=uneven, resample=resample, notes=notes)
        elif fs is not None:
            if not (isinstance(fs, (int, float)) and math.isfinite(fs) and fs > 0):
                raise CSVError(f"fs={fs!r} must be a sampling rate > 0 in Hz", source=label)
            t = np.arange(idx.size) / float(fs)
            notes.append(f"no time column: time axis built from fs = {fs:g} Hz")
        else:
            t = np.arange(idx.size, dtype=np.float64)
            has_time = False
        # ---- NaN / inf in input and output
        bad = ~(np.isfinite(u) & np.isfinite(y))
        if bad.any():
            first = int(np.flatnonzero(bad)[0])
            which = ucol if not np.isfinite(u[first]) else ycol
            cell = table.cell(int(idx[first]), which.index)
            if nan == "error":
                raise CSVError(
                    f"{label}: line {lines[first]}, column {which.label()}: {cell!r} is not a "
                    f"finite number{where} ({int(bad.sum())} such row(s)); fill in the value "
                    "or pass nan='drop' to remove those rows",
                    source=label, line=int(lines[first]), column=which.raw,
                    column_index=which.index,
                )
            frac = bad.sum() / bad.size
            if frac > max_dropped:
                raise CSVError(
                    f"{label}{where}: {int(bad.sum())} of {bad.size} rows ({100 * frac:.1f} %) "
                    f"have an empty/NaN/inf input {ucol.raw!r} or output {ycol.raw!r} (first "
                    f"at line {lines[first]}, column {which.raw!r}: {cell!r}); that is more "
                    f"than max_dropped={max_dropped:g}; check the export or raise max_dropped",
                    source=label, line=int(lines[first]), column=which.raw,
                    column_index=which.index,
                )
            bad_lines = [int(x) for x in lines[bad]]
            notes.append(
                f"removed {len(bad_lines)} row(s) with empty/NaN/inf input or output at "
                f"line(s) {_lines_text(bad_lines)}"
            )
            keep = ~bad
            t, u, y, lines = t[keep], u[keep], y[keep], lines[keep]
            ex = {k: v[keep] for k, v in ex.items()}
        for k, v in ex.items():
            if v.dtype.kind == "f" and not np.isfinite(v).all():
                nb = int((~np.isfinite(v)).sum())
                notes.append(f"extra channel {k!r} has {nb} empty/NaN/inf value(s) (kept)")
        if u.size < min_samples:
            span = f" (lines {lines[0]}..{lines[-1]})" if u.size else ""
            raise CSVError(
                f"{label}{where}: only {u.size} usable sample(s){span}, fewer than the "
                f"minimum of {min_samples}; a hysteresis fit needs a longer recording (or "
                "pass a lower min_samples=)",
                source=label,
            )
        if np.ptp(u) == 0:
            raise CSVError(
                f"{label}{where}: the input column {ucol.label()} is constant "
                f"({u[0]:g} {ucol.unit}) on all {u.size} samples: no excitation, nothing to "
                "identify; pick the excitation column with input= (available: "
                f"{_available(cols)})", source=label, column=ucol.raw, column_index=ucol.index,
            )
        columns = {"time": tcol.raw if tcol else "", "input": ucol.raw, "output": ycol.raw}
        if rcol is not None:
            columns["run"] = rcol.raw
        rec = Recording(
            t=t, u=u, y=y, name=rname,
            units={"time": "s" if has_time else "sample", "input": ucol.unit,
                   "output": ycol.unit},
            columns=columns, extra=ex, extra_units=extra_units, source=label, run=run_id,
            cleaning=tuple(notes), has_time=has_time, citation=citation, lines=lines,
        )
        if resample is not False and resample is not None:
            if not has_time:
                raise CSVError(
                    f"{label}: resample= needs a time axis, but no time column was found; "
                    "pass time= or fs=", source=label,
                )
            if resample is True:
                if not rec.is_uniform:
                    rec = rec.resampled()
            else:
                rec = rec.resampled(float(resample))
        elif has_time and not rec.is_uniform and bad.any():
            rec = _note(rec, "the removed rows leave gaps in the time axis; call "
                             ".resampled() or read with resample=True for a uniform grid")
        out.append(rec)
    return out


def _check_options(nan: str, uneven: str, max_dropped: float) -> None:
    if nan not in ("drop", "error"):
        raise CSVError(f"nan={nan!r} must be 'drop' or 'error'")
    if uneven not in ("error", "keep"):
        raise CSVError(f"uneven={uneven!r} must be 'error' or 'keep'")
    if not 0 <= max_dropped <= 1:
        raise CSVError(f"max_dropped={max_dropped!r} must be a fraction between 0 and 1")


def _note(rec: Recording, note: str) -> Recording:
    return replace(rec, cleaning=rec.cleaning + (note,))


def _decimals(cells: Iterable[str]) -> int:
    best = 0
    for c in cells:
        c = c.strip().lower().replace(",", ".")
        if "e" in c:
            return 0
        if "." in c:
            best = max(best, len(c) - c.index(".") - 1)
    return best


def _check_time(
    t: np.ndarray, lines: np.ndarray, tcol: ColumnInfo, table: _Table, idx: np.ndarray,
    label: str, where: str, auto: bool, *, t_scale: float, uneven: str,
    resample: bool | float, notes: list[str], roles: str = "input= and output=",
) -> np.ndarray:
    """Validate a time column: present, strictly increasing, evenly spaced."""
    miss = ~np.isfinite(t)
    if miss.any():
        ml = [int(x) for x in lines[miss]]
        raise CSVError(
            f"{label}: time stamp missing (empty/NaN/inf) in column {tcol.label()}{where} at "
            f"line(s) {_lines_text(ml)}; fill in the time stamps, or pass time=False (sample "
            "index) or fs= if the samples are evenly spaced",
            source=label, line=ml[0], column=tcol.raw, column_index=tcol.index,
        )
    d = np.diff(t)
    if (d <= 0).any():
        i = int(np.flatnonzero(d <= 0)[0])
        a, b = int(lines[i]), int(lines[i + 1])
        what = "duplicated" if d[i] == 0 else "decreasing"
        if auto:
            raise CSVError(
                f"{label}: column {tcol.label()} is not monotone increasing "
                f"({what} at line {b}: {t[i + 1]:g} after {t[i]:g} at line {a}), so it cannot "
                "be the time axis; pass time=<column> (name or index), or time=False if the "
                f"file has no time column, together with {roles}",
                source=label, line=b, column=tcol.raw, column_index=tcol.index,
            )
        step = (
            f"line {b} repeats t = {t[i + 1]:g} s of line {a}" if d[i] == 0 else
            f"line {b} has t = {t[i + 1]:g} s after t = {t[i]:g} s at line {a}"
        )
        raise CSVError(
            f"{label}: time stamps must strictly increase, but {step}{where} ({what} time "
            f"stamp in column {tcol.label()}); remove the duplicated/out-of-order rows or sort "
            "the file by time",
            source=label, line=b, column=tcol.raw, column_index=tcol.index,
        )
    if t.size >= 3:
        mean = (t[-1] - t[0]) / (t.size - 1)
        sample = [table.cell(int(i), tcol.index) for i in idx[:1000]]
        dec = _decimals(sample)
        res = 10.0 ** (-dec) * t_scale if dec else 0.0
        dev = np.abs(d - mean)
        if np.max(dev) > 0.01 * mean + res:
            j = int(np.argmax(d))
            k = int(np.argmin(d))
            msg = (
                f"time stamps in column {tcol.label()}{where} are uneven: spacing from "
                f"{d.min():.6g} s (line {int(lines[k + 1])}) to {d.max():.6g} s (line "
                f"{int(lines[j + 1])}), mean {mean:.6g} s"
            )
            if resample is False or resample is None:
                if uneven == "error":
                    raise UnevenTimeError(
                        f"{label}: {msg}; pass resample=True to interpolate linearly onto a "
                        "uniform grid (or resample=<dt in s>), or uneven='keep' if your model "
                        "does not depend on dt",
                        source=label, line=int(lines[j + 1]), column=tcol.raw,
                        column_index=tcol.index,
                        spacing=(d.min(), d.max(), mean, float(np.median(d))),
                    )
                notes.append(msg + "; kept as measured (uneven='keep')")
    return t


@dataclass(frozen=True, eq=False)
class InputSignal:
    """An input signal read by :func:`read_input` (a CSV without an output column).

    Attributes
    ----------
    t : ndarray of shape (N,)
        Sample times in seconds, strictly increasing; the sample index ``0, 1, ...`` when
        ``has_time`` is False.
    u : ndarray of shape (N,)
        Input samples (finite), in ``units["input"]``.
    name : str
        The file stem, or the ``name=`` given.
    units : mapping
        ``"time"`` (``"s"``, or ``"sample"`` without a time axis) and ``"input"`` (the
        unit of the input column, ``""`` when unknown).
    columns : mapping
        Column headers of the roles ``"time"`` (``""`` when none) and ``"input"``.
    values : tuple of ndarray of shape (N,)
        Every column of the file for the kept rows, in file order (aligned with
        ``layout.columns``), as written: float64 (NaN for empty / NA cells), or text for
        columns that are not numeric; the time column before any unit conversion.
    extra : mapping of str to ndarray of shape (N,)
        The columns other than time and input (float64 or text), keyed by name without
        unit like :attr:`Recording.extra <core.recordings.Recording.extra>`.
    extra_units : mapping of str to str
        Units of the ``extra`` columns.
    layout : CSVLayout
        Delimiter, decimal mark, header and columns of the file.
    source : str
        File path, ``"<text>"`` or ``"<bytes>"``.
    cleaning : tuple of str
        Everything done to the raw data (removed rows with their lines, unit conversions).
    has_time : bool
        Whether ``t`` is a time axis (from a time column or ``fs=``).
    lines : ndarray of int, shape (N,)
        1-based source line of each sample.
    """

    t: np.ndarray
    u: np.ndarray
    name: str
    units: dict[str, str]
    columns: dict[str, str]
    values: tuple[np.ndarray, ...]
    extra: dict[str, np.ndarray]
    extra_units: dict[str, str]
    layout: CSVLayout
    source: str
    cleaning: tuple[str, ...]
    has_time: bool
    lines: np.ndarray

    def __post_init__(self) -> None:
        for a in (self.t, self.u, self.lines, *self.values, *self.extra.values()):
            a.flags.writeable = False

    @property
    def n_samples(self) -> int:
        """Number of samples ``N``."""
        return int(self.u.size)

    @property
    def names(self) -> tuple[str, ...]:
        """Column headers as written, in file order (``"column 0"``, ... without a header)."""
        return tuple(c.raw for c in self.layout.columns)


def read_input(
    source: Source,
    *,
    time: ColumnSpec = None,
    input: ColumnSpec = None,  # noqa: A002 - mirrors the role name
    delimiter: str | None = None,
    decimal: str | None = None,
    header: bool | None = None,
    skiprows: int = 0,
    encoding: str | None = None,
    name: str | None = None,
    fs: float | None = None,
    time_unit: str | None = None,
    nan: Literal["drop", "error"] = "drop",
    max_dropped: float = 0.05,
    min_samples: int = 1,
    uneven: Literal["error", "keep"] = "error",
    max_bytes: int = MAX_BYTES,
    max_rows: int = MAX_ROWS,
) -> InputSignal:
    """Read an input signal (no output column) from CSV text, e.g. to simulate a model.

    The layout is worked out and checked exactly as by :func:`read_csv` (encoding,
    delimiter, decimal mark, header, unit row, preamble, ragged rows, non-numeric cells,
    time column), with the same :class:`CSVError` messages. The differences: no column
    is the output (all columns but time and input are kept in ``extra`` and ``values``),
    a file of one column is accepted (it is the input), there is no run column, and a
    constant input or a single sample is allowed.

    Parameters
    ----------
    source : path, str, bytes or open file
        As for :func:`read_csv`.
    time : int, str, False or None
        Time column (name or 0-based index), ``False`` for none, ``None`` to choose: a
        column named ``t``/``time``/..., else the first column when there are at least two
        and it is not named like an input or output (it must then strictly increase, else
        the error asks for ``time=``).
    input : int, str or None
        Input column; ``None`` picks the column named ``u``/``u_*``/``input``, else the
        first unused column not named like an output.
    delimiter, decimal, header, skiprows, encoding, name, fs, time_unit
        As for :func:`read_csv`.
    nan : {"drop", "error"}
        Rows whose input is empty, NaN or inf: removed and listed in ``cleaning``
        (default), or ``CSVError`` naming the first one's line and column.
    max_dropped : float
        Largest fraction of rows ``nan="drop"`` may remove before it raises instead.
    min_samples : int
        Fewest samples the signal may have after cleaning (default 1).
    uneven : {"error", "keep"}
        Uneven time stamps raise ``CSVError`` (default) or are kept as measured (noted).
    max_bytes, max_rows : int
        Size limits, as for :func:`read_csv`.

    Returns
    -------
    InputSignal
        Time in s (or the sample index), input, and every column as written.

    Raises
    ------
    CSVError
        The message names the problem, the line and column, and the fix (see
        :func:`read_csv`).

    Examples
    --------
    >>> sig = read_input("t_ms,u_V\\n0,0\\n1,2.5\\n2,-1\\n")
    >>> sig.t.tolist(), sig.u.tolist(), sig.units["input"]
    ([0.0, 0.001, 0.002], [0.0, 2.5, -1.0], 'V')
    """
    _check_options(nan, uneven, max_dropped)
    if isinstance(min_samples, bool) or not isinstance(min_samples, int) or min_samples < 1:
        raise CSVError(f"min_samples={min_samples!r} must be a whole number >= 1")
    table, stem = _table(
        source, delimiter=delimiter, decimal=decimal, header=header, skiprows=skiprows,
        encoding=encoding, max_bytes=max_bytes, max_rows=max_rows, min_columns=1,
    )
    lay = table.layout
    label = lay.source
    chosen, notes, time_auto = _choose_roles(
        table, time=time, input=input, output=None, run=False, with_output=False
    )
    tcol, ucol = chosen["time"], chosen["input"]
    assert ucol is not None
    if fs is not None and tcol is not None:
        raise CSVError(
            f"{label}: fs={fs!r} was given but column {tcol.label()} is the time axis; pass "
            "time=False to build the time from fs instead, or leave fs out",
            source=label, column=tcol.raw, column_index=tcol.index,
        )
    t_raw, dt_note = _convert_time(table, tcol) if tcol is not None else (None, None)
    u = _convert(table, ucol, strict=True, role="input")
    assert u is not None
    t_scale, t_unit_note = _time_scale(label, tcol, time_unit, dt_note)
    notes = list(lay.notes) + notes
    if t_unit_note:
        notes.append(t_unit_note)
    values: list[np.ndarray] = []
    extras: dict[str, np.ndarray] = {}
    extra_units: dict[str, str] = {}
    for c in lay.columns:
        if c is ucol:
            values.append(u)
            continue
        if c is tcol and dt_note is None:
            assert t_raw is not None
            values.append(t_raw)
            continue
        arr = _convert(table, c, strict=False, role="extra")
        if arr is None:
            arr = np.asarray(table.column(c.index), dtype=str)
            if c is not tcol:
                notes.append(f"column {c.label()} is not numeric; kept as text in extra")
        values.append(arr)
        if c is not tcol:
            key = c.name if c.name not in extras else f"{c.name}_{c.index}"
            extras[key] = arr
            extra_units[key] = c.unit
    lines = table.lines
    idx = np.arange(len(table.data))
    has_time = True
    if tcol is not None:
        assert t_raw is not None
        t = _check_time(t_raw * t_scale, lines, tcol, table, idx, label, "", time_auto,
                        t_scale=t_scale, uneven=uneven, resample=False, notes=notes,
                        roles="input=")
    elif fs is not None:
        if not (isinstance(fs, (int, float)) and math.isfinite(fs) and fs > 0):
            raise CSVError(f"fs={fs!r} must be a sampling rate > 0 in Hz", source=label)
        t = idx / float(fs)
        notes.append(f"no time column: time axis built from fs = {fs:g} Hz")
    else:
        t = idx.astype(np.float64)
        has_time = False
    bad = ~np.isfinite(u)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        cell = table.cell(first, ucol.index)
        line = int(lines[first])
        if nan == "error":
            raise CSVError(
                f"{label}: line {line}, input column {ucol.label()}: {cell!r} is not "
                f"a finite number ({int(bad.sum())} such row(s)); fill in the value or pass "
                "nan='drop' to remove those rows",
                source=label, line=line, column=ucol.raw, column_index=ucol.index,
            )
        frac = bad.sum() / bad.size
        if frac > max_dropped:
            raise CSVError(
                f"{label}: {int(bad.sum())} of {bad.size} rows ({100 * frac:.1f} %) have an "
                f"empty/NaN/inf input {ucol.raw!r} (first at line {line}: {cell!r}); "
                f"that is more than max_dropped={max_dropped:g}; check the export or raise "
                "max_dropped",
                source=label, line=line, column=ucol.raw, column_index=ucol.index,
            )
        notes.append(
            f"removed {int(bad.sum())} row(s) with empty/NaN/inf input at line(s) "
            f"{_lines_text([int(x) for x in lines[bad]])}"
        )
        if has_time and tcol is not None:
            notes.append("the removed rows leave gaps in the time axis")
        keep = ~bad
        t, u, lines = t[keep], u[keep], lines[keep]
        values = [v[keep] for v in values]
        extras = {k: v[keep] for k, v in extras.items()}
    for k, v in extras.items():
        if v.dtype.kind == "f" and not np.isfinite(v).all():
            nb = int((~np.isfinite(v)).sum())
            notes.append(f"extra channel {k!r} has {nb} empty/NaN/inf value(s) (kept)")
    if u.size < min_samples:
        span = f" (lines {lines[0]}..{lines[-1]})" if u.size else ""
        raise CSVError(
            f"{label}: only {u.size} usable sample(s){span}, fewer than min_samples="
            f"{min_samples}; give a longer signal (or pass a lower min_samples=)",
            source=label,
        )
    return InputSignal(
        t=np.array(t, dtype=np.float64), u=np.array(u, dtype=np.float64),
        name=name or stem,
        units={"time": "s" if has_time else "sample", "input": ucol.unit},
        columns={"time": tcol.raw if tcol is not None else "", "input": ucol.raw},
        values=tuple(np.array(v) for v in values), extra=extras, extra_units=extra_units,
        layout=lay, source=label, cleaning=tuple(notes), has_time=has_time,
        lines=np.array(lines, dtype=np.int64),
    )


def read_csv_text(content: str | bytes, *, name: str = "<text>",
                  **kwargs: object) -> list[Recording]:
    """:func:`read_csv` of CSV *content* (never a file name; e.g. an HTTP upload body).

    Parameters
    ----------
    content : str or bytes
        The CSV text or its bytes (bytes: UTF-8 with or without BOM, UTF-16 with BOM,
        else Latin-1, as for a file).
    name : str
        Label in messages and the recordings' default name.
    **kwargs
        Options of :func:`read_csv`.

    Returns
    -------
    list of Recording
    """
    kwargs.setdefault("name", None if name == "<text>" else name)
    return read_csv(CSVText(content, name), **kwargs)  # type: ignore[arg-type]


def inspect_csv_text(content: str | bytes, *, name: str = "<text>",
                     **kwargs: object) -> CSVLayout:
    """:func:`inspect_csv` of CSV *content* (never a file name); see :func:`read_csv_text`."""
    return inspect_csv(CSVText(content, name), **kwargs)  # type: ignore[arg-type]


def read_input_text(content: str | bytes, *, name: str = "<text>",
                    **kwargs: object) -> InputSignal:
    """:func:`read_input` of CSV *content* (never a file name); see :func:`read_csv_text`."""
    kwargs.setdefault("name", None if name == "<text>" else name)
    return read_input(CSVText(content, name), **kwargs)  # type: ignore[arg-type]


def read_recording(source: Source, **kwargs: object) -> Recording:
    """Read a CSV that holds exactly one recording; see :func:`read_csv` for the options.

    Raises
    ------
    CSVError
        If the file splits into several runs (the message lists them).
    """
    recs = read_csv(source, **kwargs)  # type: ignore[arg-type]
    if len(recs) != 1:
        col = recs[0].columns.get("run", "run")
        ids = ", ".join(str(r.run) for r in recs[:10])
        raise CSVError(
            f"{recs[0].source} holds {len(recs)} recordings (run column {col!r}: {ids}"
            f"{', ...' if len(recs) > 10 else ''}); use read_csv() to get all of them, or "
            "pass run=False to read the file as one recording",
            source=recs[0].source, column=col,
        )
    return recs[0]


def read_csvs(
    sources: Iterable[Source], **kwargs: object
) -> list[Recording]:
    """Read several CSV files (each may hold several runs) into one list, in order.

    Parameters
    ----------
    sources : iterable of path, str or bytes
        Anything :func:`read_csv` accepts.
    **kwargs
        Options of :func:`read_csv`, applied to every file.

    Returns
    -------
    list of Recording
    """
    out: list[Recording] = []
    for s in sources:
        out.extend(read_csv(s, **kwargs))  # type: ignore[arg-type]
    if not out:
        raise CSVError("read_csvs() got no files; pass at least one path")
    return out
