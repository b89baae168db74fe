"""The recording reader: :func:`read_csv` and its forms for content, one recording, many files."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..recordings import Recording
from .columns import available, choose_roles, convert, convert_time
from .errors import CSVError
from .load import read_table
from .names import ColumnInfo
from .options import MIN_SAMPLES, CsvOptions
from .source import CSVText, Source
from .table import Table, lines_text
from .timebase import check_fs, time_axis, time_scale

__all__ = ["read_csv", "read_csv_text", "read_csvs", "read_recording"]


@dataclass(frozen=True, eq=False)
class _Columns:
    """The columns of every run: roles, converted values, extras and the shared notes."""

    time: ColumnInfo | None
    input: ColumnInfo
    output: ColumnInfo
    run: ColumnInfo | None
    t: np.ndarray | None  # in the column's unit (None without a time column)
    u: np.ndarray
    y: np.ndarray
    t_scale: float
    time_auto: bool
    extras: dict[str, np.ndarray]
    extra_units: dict[str, str]
    notes: tuple[str, ...]


def read_csv(source: Source, options: CsvOptions | None = None,
             **changes: Any) -> list[Recording]:
    """Read one or several recordings from CSV text.

    Parameters
    ----------
    source : path, str, bytes or open file
        A path (``str`` without newline or ``os.PathLike``), the CSV text itself (a
        ``str`` containing a newline), its bytes, or a file object.
    options : CsvOptions, optional
        How to read it: columns, layout, cleaning, limits (see :class:`CsvOptions`).
    **changes
        Fields of :class:`CsvOptions` replacing those of ``options``
        (``read_csv(path, time="t", decimal=",")``).

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
    opts = CsvOptions.of(options, **changes)
    if opts.output is False:
        raise CSVError(
            "output=False: read_csv() reads recordings, which need an output column; read a "
            "file that holds only the input (and time) with read_input()"
        )
    table, stem = read_table(source, opts)
    cols = _columns(table, opts)
    base_name = opts.name or stem
    out = []
    for run_id_raw, idx in _runs(table, cols.run):
        run_id: str | int | None = run_id_raw
        if run_id_raw is not None:
            try:
                run_id = int(run_id_raw)
            except ValueError:
                run_id = run_id_raw
        out.append(_recording(table, cols, opts, base_name, run_id, idx))
    return out


def _columns(table: Table, opts: CsvOptions) -> _Columns:
    """Pick the roles and convert every column (the work shared by all runs)."""
    lay = table.layout
    label = lay.source
    chosen, notes_roles, time_auto = choose_roles(
        table, time=opts.time, input=opts.input, output=opts.output, run=opts.run,
        with_output=True,
    )
    tcol, ucol, ycol, rcol = chosen["time"], chosen["input"], chosen["output"], chosen["run"]
    assert ucol is not None and ycol is not None
    check_fs(label, opts.fs, tcol)
    t_all, dt_note = convert_time(table, tcol) if tcol is not None else (None, None)
    u_all = convert(table, ucol, strict=True, role="input")
    y_all = convert(table, ycol, strict=True, role="output")
    assert u_all is not None and y_all is not None
    t_scale, t_unit_note = time_scale(label, tcol, opts.time_unit, dt_note)
    extras: dict[str, np.ndarray] = {}
    extra_units: dict[str, str] = {}
    extra_notes: list[str] = []
    used = {c.index for c in (tcol, ucol, ycol, rcol) if c is not None}
    for c in lay.columns:
        if c.index in used:
            continue
        key = c.name if c.name not in extras else f"{c.name}_{c.index}"
        arr = convert(table, c, strict=False, role="extra")
        if arr is None:
            extras[key] = np.asarray(table.column(c.index), dtype=str)
            extra_notes.append(f"column {c.label()} is not numeric; kept as text in extra")
        else:
            extras[key] = arr
        extra_units[key] = c.unit
    notes = list(lay.notes) + notes_roles + extra_notes
    if t_unit_note:
        notes.append(t_unit_note)
    return _Columns(tcol, ucol, ycol, rcol, t_all, u_all, y_all, t_scale, time_auto, extras,
                    extra_units, tuple(notes))


def _runs(table: Table, rcol: ColumnInfo | None) -> list[tuple[str | None, np.ndarray]]:
    """``(run id as written, row indices)`` of each run, in order of first appearance."""
    if rcol is None:
        return [(None, np.arange(len(table.data)))]
    m = table.matrix()
    if m is not None:  # numeric run ids: group without splitting the lines
        _, first_i, inv = np.unique(m[:, rcol.index], return_index=True, return_inverse=True)
        return [(table.cell(int(first_i[g]), rcol.index), np.flatnonzero(inv == g))
                for g in np.argsort(first_i)]
    order: dict[str, list[int]] = {}
    for i, v in enumerate(table.column(rcol.index)):
        order.setdefault(v, []).append(i)
    return [(k, np.asarray(v)) for k, v in order.items()]


def _recording(table: Table, cols: _Columns, opts: CsvOptions, base_name: str,
               run_id: str | int | None, idx: np.ndarray) -> Recording:
    """The recording of the rows ``idx`` (one run): time axis, cleaning, checks."""
    label = table.layout.source
    tcol, ucol, ycol, rcol = cols.time, cols.input, cols.output, cols.run
    rname = base_name if rcol is None else f"{base_name} {rcol.name}={run_id}"
    where = "" if rcol is None else f" (run {rcol.name}={run_id})"
    lines = table.lines[idx]
    notes = list(cols.notes)
    u, y = cols.u[idx], cols.y[idx]
    ex = {k: v[idx] for k, v in cols.extras.items()}
    t, has_time = time_axis(table, tcol, cols.t, idx, opts, notes, t_scale=cols.t_scale,
                            time_auto=cols.time_auto, where=where, resample=opts.resample)
    bad = ~(np.isfinite(u) & np.isfinite(y))
    if bad.any():
        _check_dropped(table, cols, opts, idx, bad, where)
        bad_lines = [int(x) for x in lines[bad]]
        notes.append(
            f"removed {len(bad_lines)} row(s) with empty/NaN/inf input or output at "
            f"line(s) {lines_text(bad_lines)}"
        )
        keep = ~bad
        t, u, y, lines = t[keep], u[keep], y[keep], lines[keep]
        ex = {k: v[keep] for k, v in ex.items()}
    for k, v in ex.items():
        if v.dtype.kind == "f" and not np.isfinite(v).all():
            nb = int((~np.isfinite(v)).sum())
            notes.append(f"extra channel {k!r} has {nb} empty/NaN/inf value(s) (kept)")
    _check_usable(table, ucol, opts, u, lines, where)
    columns = {"time": tcol.raw if tcol else "", "input": ucol.raw, "output": ycol.raw}
    if rcol is not None:
        columns["run"] = rcol.raw
    rec = Recording(
        t=t, u=u, y=y, name=rname,
        units={"time": "s" if has_time else "sample", "input": ucol.unit, "output": ycol.unit},
        columns=columns, extra=ex, extra_units=cols.extra_units, source=label, run=run_id,
        cleaning=tuple(notes), has_time=has_time, citation=opts.citation, lines=lines,
    )
    resample = opts.resample
    if resample is not False and resample is not None:
        if not has_time:
            raise CSVError(
                f"{label}: resample= needs a time axis, but no time column was found; "
                "pass time= or fs=", source=label,
            )
        if resample is True:
            return rec if rec.is_uniform else rec.resampled()
        return rec.resampled(float(resample))
    if has_time and not rec.is_uniform and bad.any():
        return replace(rec, cleaning=rec.cleaning + (
            "the removed rows leave gaps in the time axis; call .resampled() or read with "
            "resample=True for a uniform grid",))
    return rec


def _check_dropped(table: Table, cols: _Columns, opts: CsvOptions, idx: np.ndarray,
                   bad: np.ndarray, where: str) -> None:
    """Refuse the non-finite input / output rows ``bad`` when ``nan="error"`` or when they
    are more than ``max_dropped`` of the run."""
    label = table.layout.source
    ucol, ycol = cols.input, cols.output
    lines = table.lines[idx]
    first = int(np.flatnonzero(bad)[0])
    which = ucol if not np.isfinite(cols.u[idx][first]) else ycol
    cell = table.cell(int(idx[first]), which.index)
    if opts.nan == "error":
        raise CSVError(
            f"{label}: line {lines[first]}, column {which.label()}: {cell!r} is not a "
            f"finite number{where} ({int(bad.sum())} such row(s)); fill in the value "
            "or pass nan='drop' to remove those rows",
            source=label, line=int(lines[first]), column=which.raw, column_index=which.index,
        )
    frac = bad.sum() / bad.size
    if frac > opts.max_dropped:
        raise CSVError(
            f"{label}{where}: {int(bad.sum())} of {bad.size} rows ({100 * frac:.1f} %) "
            f"have an empty/NaN/inf input {ucol.raw!r} or output {ycol.raw!r} (first "
            f"at line {lines[first]}, column {which.raw!r}: {cell!r}); that is more "
            f"than max_dropped={opts.max_dropped:g}; check the export or raise max_dropped",
            source=label, line=int(lines[first]), column=which.raw, column_index=which.index,
        )


def _check_usable(table: Table, ucol: ColumnInfo, opts: CsvOptions, u: np.ndarray,
                  lines: np.ndarray, where: str) -> None:
    """Enough samples after cleaning, and an input that moves."""
    label = table.layout.source
    min_samples = MIN_SAMPLES if opts.min_samples is None else opts.min_samples
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
            f"{available(list(table.layout.columns))})",
            source=label, column=ucol.raw, column_index=ucol.index,
        )


def read_csv_text(content: str | bytes, options: CsvOptions | None = None, *,
                  name: str = "<text>", **changes: Any) -> list[Recording]:
    """:func:`read_csv` of CSV *content* (never a file name; e.g. an HTTP upload body).

    Parameters
    ----------
    content : str or bytes
        The CSV text or its bytes (bytes: UTF-8 with or without BOM, UTF-16 with BOM,
        else Latin-1, as for a file).
    options : CsvOptions, optional
        Reading options, as for :func:`read_csv`.
    name : str
        Label in messages and the recordings' default name.
    **changes
        Fields of :class:`CsvOptions` replacing those of ``options``.

    Returns
    -------
    list of Recording
    """
    if "name" not in changes and name != "<text>" and (options is None or options.name is None):
        changes["name"] = name
    return read_csv(CSVText(content, name), options, **changes)


def read_recording(source: Source, options: CsvOptions | None = None,
                   **changes: Any) -> Recording:
    """Read a CSV that holds exactly one recording; see :func:`read_csv` for the options.

    Raises
    ------
    CSVError
        If the file splits into several runs (the message lists them).
    """
    recs = read_csv(source, options, **changes)
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


def read_csvs(sources: Iterable[Source], options: CsvOptions | None = None,
              **changes: Any) -> list[Recording]:
    """Read several CSV files (each may hold several runs) into one list, in order.

    Parameters
    ----------
    sources : iterable of path, str or bytes
        Anything :func:`read_csv` accepts.
    options : CsvOptions, optional
        Reading options applied to every file.
    **changes
        Fields of :class:`CsvOptions` replacing those of ``options``.

    Returns
    -------
    list of Recording
    """
    opts = CsvOptions.of(options, **changes)
    out: list[Recording] = []
    for s in sources:
        out.extend(read_csv(s, opts))
    if not out:
        raise CSVError("read_csvs() got no files; pass at least one path")
    return out
