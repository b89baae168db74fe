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

__all__ = ["RUN_POSITION", "file_recordings", "keep_runs", "on_samples", "split_runs"]

#: The extra channel of a recording that holds every run of its file: the 0-based position
#: of each row's run in the file (its ``columns["run"]`` names the file's run column).
RUN_POSITION = "run position"


def keep_runs(whole: Recording, runs: Sequence[Recording]) -> Recording:
    """``whole`` (every row of a file, read as one recording) with each row marked by the
    position of its run among ``runs`` (the same file read run by run; rows are matched by
    their source line).

    Raises
    ------
    ValueError
        A row of ``whole`` is in none of ``runs`` (the reads disagree).
    """
    if whole.lines is None or any(r.lines is None for r in runs):
        raise ValueError("the runs cannot be matched to the rows: no source lines")
    line_run = {int(line): k for k, r in enumerate(runs) for line in np.asarray(r.lines)}
    try:
        position = np.array([line_run[int(x)] for x in np.asarray(whole.lines)], dtype=float)
    except KeyError as exc:
        raise ValueError(f"line {exc.args[0]} is in no run of the file") from None
    col = runs[0].columns.get("run", "run")
    return replace(whole, extra={**whole.extra, RUN_POSITION: position},
                   columns={**whole.columns, "run": col}, run=None)


def split_runs(rec: Recording) -> list[Recording]:
    """The runs a recording of :func:`keep_runs` holds, each as its own recording (named as
    ``hyst fit`` names them: ``"<file> <run column>=<run id>"``; times are not shifted);
    ``[rec]`` for any other recording."""
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
        extra = {key: np.asarray(v)[m] for key, v in rec.extra.items() if key != RUN_POSITION}
        out.append(replace(rec, t=rec.t[m], u=rec.u[m], y=rec.y[m], extra=extra,
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
    runs = split_runs(rec)
    return runs if rec.columns.get("time", "") != "" else [on_samples(r) for r in runs]


def on_samples(rec: Recording) -> Recording:
    """``rec`` on its sample numbers counted from 0, without a time axis (time unit
    ``"sample"``), where its file has no time column (the upload's steps of ``dt`` are no
    measurement); as it is otherwise."""
    if rec.columns.get("time", "") != "" or not rec.has_time:
        return rec
    return replace(rec, t=np.arange(rec.n_samples, dtype=float), has_time=False,
                   units={**rec.units, "time": "sample"})
