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

**Large files** (more than 8 MiB) are read in blocks when they are numeric tables
(:mod:`~core.csvio.stream`): the head goes through the reader above, the rest is parsed by
numpy's C reader into one float64 array, so the memory is that of the numbers (about 80 bytes
per row of three columns at the peak, checked up front against the machine's available
memory, refused in words when it does not fit), not of the text, and there is no row or
byte limit. A file with text cells, or comment or blank lines inside the data, is read whole
as before, up to :data:`MAX_BYTES` (64 MiB) and :data:`MAX_ROWS` (2 million rows); above
that it is refused with the line that stops the blocks. Content (text, bytes, an open file:
uploads) is always read whole within those limits. The results, notes and messages are those
of the whole-text reader (``tests/core/test_csvio_stream.py`` reads a corpus both ways).

Problems raise :class:`CSVError` (a :class:`~core.exceptions.ParameterError`, hence a
``ValueError``) whose message says what is wrong, where (line, column) and what to do.
Rows whose input or output is NaN/inf/empty are removed by default and every removal is
listed with its line numbers in ``Recording.cleaning``; nothing is dropped silently.
Uneven time stamps are an error unless you ask for ``resample=True`` (linear
interpolation onto a uniform grid, noted) or ``uneven="keep"``.

**Options** are one frozen :class:`CsvOptions`; every reader takes
``(source, options=None, **changes)``, the keywords replacing fields of ``options``::

    opts = CsvOptions(time="t", decimal=",")
    recs = read_csv(path, opts)            # the same as read_csv(path, time="t", decimal=",")
    sig = read_input(other, opts, fs=1e3)

The package follows the reading steps, one module each: :mod:`~core.csvio.source` (bytes to
text), :mod:`~core.csvio.dialect` (delimiter, decimal mark, line checks),
:mod:`~core.csvio.numbers` (cells to numbers), :mod:`~core.csvio.names` (headers and units),
:mod:`~core.csvio.table` (preamble, header, unit row, the layout), :mod:`~core.csvio.columns`
(roles and conversion), :mod:`~core.csvio.timebase` (time units, increasing and even stamps),
:mod:`~core.csvio.stream` (large numeric files in blocks), :mod:`~core.csvio.load` (which of
the two reads a source), :mod:`~core.csvio.reader` (recordings and runs) and
:mod:`~core.csvio.inputs` (input-only signals); :mod:`~core.csvio.options` and
:mod:`~core.csvio.errors` hold the options and the exceptions.
"""


from __future__ import annotations

from .dialect import MAX_LINE_CHARS
from .errors import CSVError, TimeOrderError, UnevenTimeError
from .inputs import InputSignal, read_input, read_input_text
from .load import inspect_csv, inspect_csv_text
from .names import ColumnInfo, parse_column_name
from .options import MAX_BYTES, MAX_ROWS, MIN_SAMPLES, ColumnSpec, CsvOptions
from .reader import read_csv, read_csv_text, read_csvs, read_recording
from .source import CSVText, Source
from .table import CSVLayout

__all__ = [
    "MAX_BYTES",
    "MAX_LINE_CHARS",
    "MAX_ROWS",
    "MIN_SAMPLES",
    "CSVError",
    "CSVLayout",
    "CSVText",
    "ColumnInfo",
    "ColumnSpec",
    "CsvOptions",
    "InputSignal",
    "Source",
    "TimeOrderError",
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
