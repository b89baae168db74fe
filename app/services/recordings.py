"""Recordings of the explorer and of the file-based runs (no viser / fastapi imports).

Uploads are content, never paths: :func:`read_upload` and :func:`csv_preview` read them with
:func:`core.csvio.read_csv_text` / :func:`~core.csvio.inspect_csv_text` (a
:class:`~core.csvio.CSVError` names the line and the column; the server maps it to a 422
``{message, line, column}``). Files of ``hyst fit`` / ``hyst diagnose`` and the batch worker
are read by :func:`read_recordings` with the options of :func:`csv_read_kwargs`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from core.csvio import CSVError, inspect_csv_text, read_csv_text
from core.recordings import Recording

from .columns import column_spec
from .inputs import CommandError, existing_file

if TYPE_CHECKING:
    from .progress import Progress
    from .sessions import Session

__all__ = [
    "Recording",
    "Upload",
    "csv_preview",
    "csv_read_kwargs",
    "read_recordings",
    "read_upload",
    "recording_from_csv",
    "say_read",
    "store_recording",
]


@dataclass(frozen=True, eq=False)
class Upload:
    """An uploaded recording and what the file held.

    Attributes
    ----------
    recording : Recording
        The recording kept (its ``cleaning`` notes say what was removed or chosen).
    runs : tuple of str
        Run ids of the file's run column in file order (empty without one).
    """

    recording: Recording
    runs: tuple[str, ...] = ()


def read_upload(
    content: str | bytes,
    *,
    t_col: str | int | None = None,
    u_col: str | int | None = None,
    y_col: str | int | None = None,
    run: str | None = None,
    dt: float = 1e-3,
    max_samples: int = 200_000,
    name: str = "upload.csv",
) -> Upload:
    """Read uploaded CSV *content* (never a path) with an optional column mapping.

    The content goes through :func:`core.csvio.read_csv_text`, so bytes are decoded as the
    command line decodes a file (UTF-8 with or without BOM, UTF-16 with BOM, else Latin-1).
    Columns are names or 0-based indices (digit strings count as indices); unmapped roles
    are chosen by the core reader. A file without a time column gets ``t = k * dt``. A file
    with a run column holds several recordings: ``run`` chooses one by its id, ``"all"``
    reads every row as one recording in file order; without ``run`` the first run is kept.
    Either way a cleaning note says which run was kept and how to choose another.

    Raises
    ------
    core.csvio.CSVError
        With the 1-based ``line`` and the 0-based ``column_index`` of the problem, or when
        ``run`` names no run of the file.
    """
    recs = read_csv_text(content, time=column_spec(t_col), input=column_spec(u_col),
                         output=column_spec(y_col), run=False if run == "all" else None,
                         name=name, max_rows=max_samples)
    runs = tuple(str(r.run) for r in recs) if len(recs) > 1 or recs[0].run is not None else ()
    if run not in (None, "all"):
        if str(run) not in runs:
            raise CSVError(
                f"run={run!r} is not in this file; its runs are {', '.join(runs) or 'none'}"
                " (or pass run=all to read every row as one recording)"
            )
        rec = recs[runs.index(str(run))]
    else:
        rec = recs[0]
    if run == "all":
        rec = replace(rec, cleaning=(*rec.cleaning, "read every row as one recording "
                                     "(run=all): a run column, if any, was not used"))
    elif len(runs) > 1:
        col = rec.columns.get("run", "run")
        rec = replace(rec, name=f"{name} (run {rec.run}; {runs.index(str(rec.run)) + 1} of "
                                f"{len(runs)})",
                      cleaning=(*rec.cleaning, f"the file holds {len(runs)} runs (column "
                                f"{col!r}: {', '.join(runs)}); kept run {rec.run}; pass "
                                "run=<id> to choose another or run=all to read every row"))
    if not rec.has_time:
        rec = replace(rec, t=rec.t * dt, has_time=True, units={**rec.units, "time": "s"})
    return Upload(rec, runs)


def recording_from_csv(content: str | bytes, **kwargs: Any) -> Recording:
    """The recording of :func:`read_upload` ``(content, **kwargs)``."""
    return read_upload(content, **kwargs).recording


def store_recording(session: Session, rec: Recording) -> None:
    """Give ``session`` the recording ``rec``; its fit and diagnosis are dropped."""
    session.set_recording(rec)


def csv_preview(content: str | bytes, max_samples: int, rows: int = 5) -> dict[str, Any]:
    """Columns, the first ``rows`` data rows (as text), row count and notes of CSV content.

    Raises
    ------
    core.csvio.CSVError
        If :func:`core.csvio.inspect_csv_text` cannot work out the layout.
    """
    lay = inspect_csv_text(content, max_rows=max_samples)
    if isinstance(content, bytes):
        enc = {"utf-8": "utf-8-sig"}.get(lay.encoding, lay.encoding)
        content = content.decode(enc)
    lines = content.splitlines()[lay.first_data_line - 1: lay.first_data_line - 1 + rows]
    d = None if lay.delimiter == "whitespace" else lay.delimiter
    return {"columns": [c.raw for c in lay.columns],
            "rows": [[c.strip() for c in (ln.split(d) if d else ln.split())] for ln in lines],
            "n_rows": int(lay.n_rows), "encoding": lay.encoding, "notes": list(lay.notes)}


def csv_read_kwargs(time: str | None = None, input_column: str | None = None,
                    output_column: str | None = None, run_column: str | None = None,
                    resample: str | None = None) -> dict[str, Any]:
    """Keyword arguments of :func:`core.csvio.read_csv` from the option texts of
    :func:`add_read_options` (``None``: the option was not given)."""
    spacing: bool | float = False
    if resample is not None:
        if resample == "auto":
            spacing = True
        else:
            try:
                spacing = float(resample)
            except ValueError:
                raise CommandError(f"--resample {resample!r}: expected a spacing in "
                                   "seconds, e.g. --resample 0.0002, or no value") from None
            if not spacing > 0:
                raise CommandError(f"--resample {resample}: the spacing must be > 0 s")
    return {"time": _spec(time), "input": _spec(input_column),
            "output": _spec(output_column), "run": _spec(run_column), "resample": spacing}


def _spec(value: str | None) -> Any:
    if value is not None and value.strip().lower() == "none":
        return False
    return column_spec(value)


def read_recordings(files: Sequence[str | Path], read_kw: dict[str, Any]) -> list[Recording]:
    """Every recording of ``files`` (:func:`core.csvio.read_csv` with ``read_kw``), in order.

    Raises
    ------
    CommandError
        A file that does not exist or is a folder.
    """
    from core.csvio import read_csv

    recs: list[Recording] = []
    for f in files:
        existing_file(f, "CSV file")
        recs.extend(read_csv(Path(f), **read_kw))
    return recs


def say_read(progress: Progress, recs: list[Any]) -> None:
    """Report each recording read (samples, time axis, columns, cleaning notes) on stderr."""
    for r in recs:
        axis = f"t = {r.t[0]:g} .. {r.t[-1]:g} s" if r.has_time else "no time axis"
        progress(f"read {r.name}: {r.n_samples} samples, {axis}, "
                 f"u = {r.columns.get('input', 'u')}, y = {r.columns.get('output', 'y')}")
        for note in r.cleaning:
            progress(f"  note: {note}")
