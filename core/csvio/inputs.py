"""Input-only files (a signal to simulate, no output column): :func:`read_input`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .columns import choose_roles, convert, convert_time
from .errors import CSVError
from .load import read_table
from .names import ColumnInfo
from .options import CsvOptions
from .source import CSVText, Source
from .table import CSVLayout, Table, lines_text
from .timebase import check_fs, time_axis, time_scale

__all__ = ["InputSignal", "read_input", "read_input_text"]


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


def read_input(source: Source, options: CsvOptions | None = None,
               **changes: Any) -> InputSignal:
    """Read an input signal (no output column) from CSV text, e.g. to simulate a model.

    The layout is worked out and checked exactly as by :func:`~core.csvio.read_csv` (encoding,
    delimiter, decimal mark, header, unit row, preamble, ragged rows, non-numeric cells,
    time column), with the same :class:`CSVError` messages. The differences: no column
    is the output (all columns but time and input are kept in ``extra`` and ``values``),
    a file of one column is accepted (it is the input), there is no run column, and a
    constant input or a single sample is allowed.

    Parameters
    ----------
    source : path, str, bytes or open file
        As for :func:`~core.csvio.read_csv`.
    options : CsvOptions, optional
        Reading options (see :class:`~core.csvio.CsvOptions`), read for a signal:
        ``time=None`` picks a column named ``t``/``time``/..., else the first column when
        there are at least two and it is not named like an input or output (it must then
        strictly increase, else the error asks for ``time=``); ``input=None`` picks the
        column named ``u``/``u_*``/``input``, else the first unused column not named like
        an output; ``nan`` and ``max_dropped`` apply to the input; ``min_samples`` is 1 by
        default. ``output``, ``run``, ``resample`` and ``citation`` do not apply (an error).
    **changes
        Fields of :class:`~core.csvio.CsvOptions` replacing those of ``options``.

    Returns
    -------
    InputSignal
        Time in s (or the sample index), input, and every column as written.

    Raises
    ------
    CSVError
        The message names the problem, the line and column, and the fix (see
        :func:`~core.csvio.read_csv`).

    Examples
    --------
    >>> sig = read_input("t_ms,u_V\\n0,0\\n1,2.5\\n2,-1\\n")
    >>> sig.t.tolist(), sig.u.tolist(), sig.units["input"]
    ([0.0, 0.001, 0.002], [0.0, 2.5, -1.0], 'V')
    """
    opts = CsvOptions.of(options, **changes)
    min_samples = _signal_min_samples(opts)
    table, stem = read_table(source, opts, min_columns=1)
    lay = table.layout
    label = lay.source
    chosen, notes, time_auto = choose_roles(
        table, time=opts.time, input=opts.input, output=None, run=False, with_output=False
    )
    tcol, ucol = chosen["time"], chosen["input"]
    assert ucol is not None
    check_fs(label, opts.fs, tcol)
    t_raw, dt_note = convert_time(table, tcol) if tcol is not None else (None, None)
    u = convert(table, ucol, strict=True, role="input")
    assert u is not None
    t_scale, t_unit_note = time_scale(label, tcol, opts.time_unit, dt_note)
    notes = list(lay.notes) + notes
    if t_unit_note:
        notes.append(t_unit_note)
    values, extras, extra_units = _columns_as_written(table, ucol, tcol, u, t_raw, dt_note,
                                                      notes)
    lines = table.lines
    t, has_time = time_axis(table, tcol, t_raw, np.arange(len(table.data)), opts, notes,
                            t_scale=t_scale, time_auto=time_auto, roles="input=")
    t, u, lines, values, extras = _without_bad_input(table, ucol, tcol, opts, has_time, t, u,
                                                     lines, values, extras, notes)
    _check_enough(label, u, lines, min_samples)
    return InputSignal(
        t=np.array(t, dtype=np.float64), u=np.array(u, dtype=np.float64),
        name=opts.name or stem,
        units={"time": "s" if has_time else "sample", "input": ucol.unit},
        columns={"time": tcol.raw if tcol is not None else "", "input": ucol.raw},
        values=tuple(np.array(v) for v in values), extra=extras, extra_units=extra_units,
        layout=lay, source=label, cleaning=tuple(notes), has_time=has_time,
        lines=np.array(lines, dtype=np.int64),
    )


def _signal_min_samples(opts: CsvOptions) -> int:
    """The options that do not apply to a signal refused (an error naming them), and the
    fewest samples a signal must have (``min_samples``, 1 by default), checked."""
    unused = [f"{k}={v!r}" for k, v, given in (
        ("output", opts.output, opts.output is not None),
        ("run", opts.run, opts.run is not None and opts.run is not False),
        ("resample", opts.resample, opts.resample is not False),
        ("citation", opts.citation, opts.citation != ""),
    ) if given]
    if unused:
        raise CSVError(f"{', '.join(unused)}: read_input() reads a signal without output, "
                       "runs or resampling; leave these options out (read_csv() reads "
                       "recordings)")
    min_samples = 1 if opts.min_samples is None else opts.min_samples
    if isinstance(min_samples, bool) or not isinstance(min_samples, int) or min_samples < 1:
        raise CSVError(f"min_samples={min_samples!r} must be a whole number >= 1")
    return min_samples


def _without_bad_input(table: Table, ucol: ColumnInfo, tcol: ColumnInfo | None,
                       opts: CsvOptions, has_time: bool, t: np.ndarray, u: np.ndarray,
                       lines: np.ndarray, values: list[np.ndarray],
                       extras: dict[str, np.ndarray], notes: list[str],
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[np.ndarray],
                                  dict[str, np.ndarray]]:
    """The rows whose input is empty, NaN or inf removed (at most ``max_dropped``, said in
    ``notes``), and the extra channels' non-finite values counted (kept)."""
    bad = ~np.isfinite(u)
    if bad.any():
        _check_dropped(table, ucol, opts, bad)
        notes.append(
            f"removed {int(bad.sum())} row(s) with empty/NaN/inf input at line(s) "
            f"{lines_text([int(x) for x in lines[bad]])}"
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
    return t, u, lines, values, extras


def _check_enough(label: str, u: np.ndarray, lines: np.ndarray, min_samples: int) -> None:
    """At least ``min_samples`` usable samples, else an error naming the lines."""
    if u.size < min_samples:
        span = f" (lines {lines[0]}..{lines[-1]})" if u.size else ""
        raise CSVError(
            f"{label}: only {u.size} usable sample(s){span}, fewer than min_samples="
            f"{min_samples}; give a longer signal (or pass a lower min_samples=)",
            source=label,
        )


def _columns_as_written(table: Table, ucol: ColumnInfo, tcol: ColumnInfo | None, u: np.ndarray,
                        t_raw: np.ndarray | None, dt_note: str | None, notes: list[str],
                        ) -> tuple[list[np.ndarray], dict[str, np.ndarray], dict[str, str]]:
    """Every column in file order (``values``), and those other than time and input with
    their units (``extras``); non-numeric ones as text (noted in ``notes``)."""
    values: list[np.ndarray] = []
    extras: dict[str, np.ndarray] = {}
    extra_units: dict[str, str] = {}
    for c in table.layout.columns:
        if c is ucol:
            values.append(u)
            continue
        if c is tcol and dt_note is None:
            assert t_raw is not None
            values.append(t_raw)
            continue
        arr = convert(table, c, strict=False, role="extra")
        if arr is None:
            arr = np.asarray(table.column(c.index), dtype=str)
            if c is not tcol:
                notes.append(f"column {c.label()} is not numeric; kept as text in extra")
        values.append(arr)
        if c is not tcol:
            key = c.name if c.name not in extras else f"{c.name}_{c.index}"
            extras[key] = arr
            extra_units[key] = c.unit
    return values, extras, extra_units


def _check_dropped(table: Table, ucol: ColumnInfo, opts: CsvOptions, bad: np.ndarray) -> None:
    """Refuse the non-finite inputs ``bad`` when ``nan="error"`` or when they are more than
    ``max_dropped`` of the rows."""
    label, lines = table.layout.source, table.lines
    first = int(np.flatnonzero(bad)[0])
    cell = table.cell(first, ucol.index)
    line = int(lines[first])
    if opts.nan == "error":
        raise CSVError(
            f"{label}: line {line}, input column {ucol.label()}: {cell!r} is not "
            f"a finite number ({int(bad.sum())} such row(s)); fill in the value or pass "
            "nan='drop' to remove those rows",
            source=label, line=line, column=ucol.raw, column_index=ucol.index,
        )
    frac = bad.sum() / bad.size
    if frac > opts.max_dropped:
        raise CSVError(
            f"{label}: {int(bad.sum())} of {bad.size} rows ({100 * frac:.1f} %) have an "
            f"empty/NaN/inf input {ucol.raw!r} (first at line {line}: {cell!r}); "
            f"that is more than max_dropped={opts.max_dropped:g}; check the export or raise "
            "max_dropped",
            source=label, line=line, column=ucol.raw, column_index=ucol.index,
        )


def read_input_text(content: str | bytes, options: CsvOptions | None = None, *,
                    name: str = "<text>", **changes: Any) -> InputSignal:
    """:func:`read_input` of CSV *content* (never a file name); see
    :func:`~core.csvio.read_csv_text`."""
    if "name" not in changes and name != "<text>" and (options is None or options.name is None):
        changes["name"] = name
    return read_input(CSVText(content, name), options, **changes)
