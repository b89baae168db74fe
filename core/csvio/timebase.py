"""The time axis: units to seconds, strictly increasing and evenly spaced stamps."""

from __future__ import annotations

import math

import numpy as np

from .errors import CSVError, TimeOrderError, UnevenTimeError
from .names import TIME_SCALE, ColumnInfo
from .numbers import decimals
from .options import CsvOptions
from .table import Table, lines_text

__all__ = ["check_fs", "check_time", "time_axis", "time_scale"]


def time_scale(
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
        if unit not in TIME_SCALE:
            raise CSVError(
                f"{label}: time column {tcol.label()} has unit {unit!r}, which is not a time "
                f"unit ({', '.join(sorted(set(TIME_SCALE)))}); pass time_unit= or pick "
                "another column with time=", source=label, column=tcol.raw, column_index=tcol.index,
            )
        t_scale = TIME_SCALE[unit]
        if t_scale != 1.0:
            t_unit_note = f"time converted from {unit} to s (×{t_scale:g})"
    return t_scale, t_unit_note


def check_time(
    t: np.ndarray, lines: np.ndarray, tcol: ColumnInfo, table: Table, idx: np.ndarray,
    label: str, where: str, auto: bool, *, t_scale: float, uneven: str,
    resample: bool | float, notes: list[str], roles: str = "input= and output=",
) -> np.ndarray:
    """Validate a time column: present, strictly increasing, evenly spaced."""
    miss = ~np.isfinite(t)
    if miss.any():
        ml = [int(x) for x in lines[miss]]
        raise CSVError(
            f"{label}: time stamp missing (empty/NaN/inf) in column {tcol.label()}{where} at "
            f"line(s) {lines_text(ml)}; fill in the time stamps, or pass time=False (sample "
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
        raise TimeOrderError(
            f"{label}: time stamps must strictly increase, but {step}{where} ({what} time "
            f"stamp in column {tcol.label()}); remove the duplicated/out-of-order rows or sort "
            "the file by time",
            source=label, line=b, column=tcol.raw, column_index=tcol.index,
        )
    if t.size >= 3:
        mean = (t[-1] - t[0]) / (t.size - 1)
        sample = [table.cell(int(i), tcol.index) for i in idx[:1000]]
        dec = decimals(sample)
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


def check_fs(label: str, fs: float | None, tcol: ColumnInfo | None) -> None:
    """``fs=`` goes with files without a time column: with one in use it is an error."""
    if fs is not None and tcol is not None:
        raise CSVError(
            f"{label}: fs={fs!r} was given but column {tcol.label()} is the time axis; pass "
            "time=False to build the time from fs instead, or leave fs out",
            source=label, column=tcol.raw, column_index=tcol.index,
        )


def time_axis(table: Table, tcol: ColumnInfo | None, t_raw: np.ndarray | None,
              idx: np.ndarray, opts: CsvOptions, notes: list[str], *, t_scale: float,
              time_auto: bool, where: str = "", resample: bool | float = False,
              roles: str = "input= and output=") -> tuple[np.ndarray, bool]:
    """Time of the rows ``idx``: the time column in s (checked by :func:`check_time`),
    ``k / fs``, or the sample index; and whether it is a time axis. Notes go to ``notes``.

    ``t_raw`` holds the time column of every row in its own unit (None without one).
    """
    label, fs = table.layout.source, opts.fs
    if tcol is not None:
        assert t_raw is not None
        return check_time(t_raw[idx] * t_scale, table.lines[idx], tcol, table, idx, label,
                          where, time_auto, t_scale=t_scale, uneven=opts.uneven,
                          resample=resample, notes=notes, roles=roles), True
    if fs is not None:
        if not (isinstance(fs, (int, float)) and math.isfinite(fs) and fs > 0):
            raise CSVError(f"fs={fs!r} must be a sampling rate > 0 in Hz", source=label)
        notes.append(f"no time column: time axis built from fs = {fs:g} Hz")
        return np.arange(idx.size) / float(fs), True
    return np.arange(idx.size, dtype=np.float64), False
