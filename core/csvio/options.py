"""How to read a CSV: :class:`CsvOptions`, one frozen object for every reader option."""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any, Literal

from .errors import CSVError

__all__ = ["MAX_BYTES", "MAX_ROWS", "MIN_SAMPLES", "ColumnSpec", "CsvOptions"]

#: Default size limit of one CSV read whole (bytes): content, and files that are not plain
#: numeric tables (a numeric file is read in blocks, :mod:`core.csvio.stream`).
MAX_BYTES = 64 * 2**20
#: Default limit on the number of data rows of one CSV read whole.
MAX_ROWS = 2_000_000
#: Default smallest number of samples per recording.
MIN_SAMPLES = 10

ColumnSpec = int | str | None | Literal[False]


@dataclass(frozen=True)
class CsvOptions:
    """The options of :func:`~core.csvio.read_csv`, :func:`~core.csvio.read_input` and
    :func:`~core.csvio.inspect_csv`, passed as one object.

    Every reader takes ``(source, options=None, **changes)``: the fields given as keywords
    replace those of ``options`` (``read_csv(path, time="t")`` is
    ``read_csv(path, CsvOptions(time="t"))``). Every field's default means "detect" or
    "the usual"; an unknown keyword is a ``TypeError``.

    Parameters
    ----------
    time : int, str, False or None
        Time column (name or 0-based index); ``False`` for none (the time axis is then
        the sample index, or ``k / fs`` when ``fs`` is given); ``None`` to choose (see
        the :mod:`core.csvio` docstring). A chosen column must strictly increase within
        each run.
    input, output : int, str or None
        Input and output columns; ``None`` to choose. For a file without an output
        column (a signal to simulate) use :func:`~core.csvio.read_input`;
        ``read_csv(output=False)`` raises ``CSVError`` saying so.
    run : int, str, False or None
        Column whose value identifies the run / record / loop: each distinct value becomes
        its own :class:`~core.recordings.Recording` (in order of first appearance) with
        ``run`` set. ``None`` picks a column named ``run``/``record``/``loop``/``trial``/...,
        ``False`` disables it.
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
    max_bytes, max_rows : int, optional
        Size limits; larger sources raise ``CSVError``. ``None`` (the default): content
        (text, bytes, an open file) and files that are not plain numeric tables are read
        whole, up to :data:`MAX_BYTES` (64 MiB) and :data:`MAX_ROWS` (2 million rows),
        which keep the memory of the text parse below about 1 GB; a numeric file larger
        than 8 MiB is read in blocks (:mod:`core.csvio.stream`) with no limit but the
        memory its numbers need (about 80 bytes per row of three columns), which is checked
        against the machine's available memory before they are read.
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
        their lines in ``cleaning`` (default), or raise.
    max_dropped : float
        Largest fraction of rows ``nan="drop"`` may remove before it raises instead.
    min_samples : int, optional
        Fewest samples a recording may have after cleaning; ``None`` means 10
        (:data:`MIN_SAMPLES`) for recordings and 1 for input signals.
    resample : bool or float
        ``True``: recordings with uneven time stamps (or gaps left by dropped rows) are
        linearly interpolated onto a uniform grid at their median spacing; a float: every
        recording is resampled to that spacing in seconds. Both are noted in ``cleaning``.
        Recordings only.
    uneven : {"error", "keep"}
        Without ``resample``, uneven time stamps (any spacing more than 1 % plus the printed
        resolution away from the mean) raise ``CSVError`` (default) or are kept as
        measured (noted).
    citation : str
        Attribution stored in every returned recording. Recordings only.

    Raises
    ------
    CSVError
        ``nan``, ``uneven`` or ``max_dropped`` out of range (the message names the field).
    """

    time: ColumnSpec = None
    input: ColumnSpec = None  # noqa: A003 - the role name
    output: ColumnSpec = None
    run: ColumnSpec = None
    delimiter: str | None = None
    decimal: str | None = None
    header: bool | None = None
    skiprows: int = 0
    encoding: str | None = None
    max_bytes: int | None = None
    max_rows: int | None = None
    name: str | None = None
    fs: float | None = None
    time_unit: str | None = None
    nan: Literal["drop", "error"] = "drop"
    max_dropped: float = 0.05
    min_samples: int | None = None
    resample: bool | float = False
    uneven: Literal["error", "keep"] = "error"
    citation: str = ""

    def __post_init__(self) -> None:
        if self.nan not in ("drop", "error"):
            raise CSVError(f"nan={self.nan!r} must be 'drop' or 'error'")
        if self.uneven not in ("error", "keep"):
            raise CSVError(f"uneven={self.uneven!r} must be 'error' or 'keep'")
        if not 0 <= self.max_dropped <= 1:
            raise CSVError(
                f"max_dropped={self.max_dropped!r} must be a fraction between 0 and 1")

    @classmethod
    def of(cls, options: CsvOptions | None = None, **changes: Any) -> CsvOptions:
        """``options`` (the defaults when None) with the fields in ``changes`` replaced.

        Raises
        ------
        TypeError
            ``options`` is not a CsvOptions, or a keyword is not one of its fields.
        CSVError
            A value out of range (see the class docstring).
        """
        if options is None:
            options = cls()
        elif not isinstance(options, CsvOptions):
            raise TypeError(f"options must be a CsvOptions, not {type(options).__name__}; "
                            "pass single options as keywords (time='t', decimal=',')")
        unknown = sorted(set(changes) - {f.name for f in fields(cls)})
        if unknown:
            raise TypeError(f"{', '.join(unknown)}: not a CSV reading option; the options "
                            f"are {', '.join(f.name for f in fields(cls))}")
        return replace(options, **changes) if changes else options
