"""A file's runs kept together: an upload of every run of a file with a run column (B-H loops
of several amplitudes, one per ``loop``), each fitted as its own recording as ``hyst fit
FILE`` reads them (no viser / fastapi imports).

The explorer's session holds one recording. An upload with ``run="each"`` keeps every row of
the file in it, in file order, and marks each row with the position of its run in the file
(the extra channel :data:`RUN_POSITION`); :func:`split_runs` gives the runs back as separate
recordings for the fit.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Sequence

    from core.recordings import Recording

__all__ = ["RUN_POSITION", "RUN_TIME", "file_recordings", "keep_runs", "on_samples", "split_runs"]

#: The extra channel of a recording that holds every run of its file: the 0-based position
#: of each row's run in the file (its ``columns["run"]`` names the file's run column).
RUN_POSITION = "run position"
#: The extra channel of such a recording with each row's time as its run gives it (the
#: recording's own times lay the runs one after the other: :func:`keep_runs`).
RUN_TIME = "run time"


def keep_runs(runs: Sequence[Recording]) -> Recording:
    """Every run of a file (``runs``: the file read run by run, in file order) in one
    recording, each row marked by the position of its run (:data:`RUN_POSITION`).

    A file's runs usually each start their own clock (``t`` from 0 again), so the runs are
    laid one after the other: each run's times are shifted to start one sample step after
    the previous run ends, and its times as the file gives them are kept in the extra
    channel :data:`RUN_TIME`, which :func:`split_runs` gives back. Cleaning notes are the
    runs' notes, each once, in order.

    Raises
    ------
    ValueError
        ``runs`` is empty.
    """
    if not runs:
        raise ValueError("a file's runs are needed to keep them together")
    first = runs[0]
    ts: list[np.ndarray] = []
    start = 0.0
    for k, r in enumerate(runs):
        t = np.asarray(r.t, dtype=float)
        if k:
            start = ts[-1][-1] + _step(ts[-1]) - t[0]
        ts.append(t + start)
    position = np.concatenate([np.full(r.n_samples, float(k)) for k, r in enumerate(runs)])
    notes = tuple(dict.fromkeys(c for r in runs for c in r.cleaning))
    extra = {key: np.concatenate([np.asarray(r.extra[key]) for r in runs])
             for key in first.extra if all(key in r.extra for r in runs)}
    lines = (None if any(r.lines is None for r in runs)
             else np.concatenate([np.asarray(r.lines) for r in runs]))
    col = first.columns.get("run", "run")
    return replace(first, t=np.concatenate(ts), u=np.concatenate([r.u for r in runs]),
                   y=np.concatenate([r.y for r in runs]), lines=lines, cleaning=notes,
                   extra={**extra, col: np.concatenate([np.full(r.n_samples, str(r.run))
                                                        for r in runs]),
                          RUN_POSITION: position,
                          RUN_TIME: np.concatenate([np.asarray(r.t, dtype=float)
                                                    for r in runs])},
                   columns={**first.columns, "run": col}, run=None)


def _step(t: np.ndarray) -> float:
    """The median sample step of the times ``t`` (1 for a single sample)."""
    return float(np.median(np.diff(t))) if t.size > 1 else 1.0


def split_runs(rec: Recording) -> list[Recording]:
    """The runs a recording of :func:`keep_runs` holds, each as its own recording (named as
    ``hyst fit`` names them: ``"<file> <run column>=<run id>"``, at the times the file gives
    them, :data:`RUN_TIME`); ``[rec]`` for any other recording."""
    position = rec.extra.get(RUN_POSITION)
    if position is None:
        return [rec]
    col = rec.columns.get("run", "run")
    ids = rec.extra.get(col)
    stem = rec.name.split(" (", 1)[0].removesuffix(".csv")
    out = []
    for k in np.unique(np.asarray(position)):
        m = np.asarray(position) == k
        run_id = _run_id(ids, m, int(k))
        extra = {key: np.asarray(v)[m] for key, v in rec.extra.items()
                 if key not in (RUN_POSITION, RUN_TIME)}
        t = np.asarray(rec.extra.get(RUN_TIME, rec.t), dtype=float)[m]
        out.append(replace(rec, t=t, u=rec.u[m], y=rec.y[m], extra=extra,
                           lines=None if rec.lines is None else np.asarray(rec.lines)[m],
                           name=f"{stem} {col}={run_id}", run=run_id))
    return out


def _run_id(ids: object, rows: np.ndarray, position: int) -> str:
    """The run id as the file writes it (a whole number without ``.0``), else its position."""
    if ids is None:
        return str(position)
    first = np.asarray(ids)[rows][0]
    if isinstance(first, (float, np.floating)) and float(first).is_integer():
        return str(int(first))
    return str(first)


def file_recordings(rec: Recording) -> list[Recording]:
    """The recordings ``hyst fit`` reads from the file ``rec`` was uploaded from: its runs
    (:func:`split_runs`), and, for a file without a time column (the upload gave it steps of
    ``dt``), each on its sample numbers counted from 0 without a time axis, so that a fit's
    words give samples, never rates or times the file does not hold."""
    return [on_samples(r) for r in split_runs(rec)]


def on_samples(rec: Recording) -> Recording:
    """``rec`` on its sample numbers counted from 0, without a time axis (time unit
    ``"sample"``), where its file has no time column (the reader maps the time role to no
    column, ``columns["time"] == ""``; the upload's steps of ``dt`` are no measurement); as
    it is otherwise, a recording made in code (no column map) included."""
    if rec.columns.get("time") != "" or not rec.has_time:
        return rec
    return replace(rec, t=np.arange(rec.n_samples, dtype=float), has_time=False,
                   units={**rec.units, "time": "sample"})
