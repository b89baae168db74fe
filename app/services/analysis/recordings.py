"""Recordings of the explorer and of the file-based runs (no viser / fastapi imports).

Uploads are content, never paths: :func:`read_upload` and :func:`csv_preview` read them with
:func:`core.csvio.read_csv_text` / :func:`~core.csvio.inspect_csv_text` (a
:class:`~core.csvio.CSVError` names the line and the column; the server maps it to a 422
``{message, line, column}``). Files of ``hyst fit`` / ``hyst diagnose`` and the batch worker
are read by :func:`read_recordings` with the :class:`~core.csvio.CsvOptions` of
:func:`csv_read_options`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from app.services.analysis.columns import column_spec
from app.services.analysis.loops import keep_runs
from app.services.runs.inputs import CommandError, existing_file
from core.csvio import (
    CSVError,
    CsvOptions,
    TimeOrderError,
    UnevenTimeError,
    inspect_csv_text,
    read_csv_text,
)
from core.recordings import Recording

if TYPE_CHECKING:
    from app.services.runs.progress import Progress
    from app.services.session.sessions import Session

__all__ = [
    "TIMING_CHOICES",
    "Recording",
    "Timing",
    "UnevenUpload",
    "Upload",
    "CsvPreview",
    "csv_preview",
    "csv_read_options",
    "read_recordings",
    "read_upload",
    "recording_from_csv",
    "say_read",
    "seconds_text",
    "store_recording",
    "uneven_timing",
]

#: What an upload may do with uneven time stamps: interpolate onto an even grid, or keep.
TIMING_CHOICES = ("resample", "keep")


def seconds_text(s: float) -> str:
    """A duration in s as people write it, 3 significant digits (``"1 ms"``,
    ``"0.607 ms"``, ``"2.5 s"``, ``"40 µs"``)."""
    s = float(f"{s:.3g}")  # rounded first: 0.9998 ms is "1 ms", not "1e+03 µs"
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("µs", 1e-6)):
        if abs(s) >= scale:
            return f"{s / scale:.3g} {unit}"
    return f"{s / 1e-9:.3g} ns"


@dataclass(frozen=True)
class Timing:
    """Uneven time stamps of an upload and the even step resampling would use.

    Attributes
    ----------
    column : str
        The time column.
    spacing_min, spacing_max, spacing_mean : float
        Smallest, largest and mean spacing of the time stamps, s.
    step : float
        The even step offered for resampling: the median spacing, s.
    line : int or None
        1-based line of the largest spacing.
    column_index : int or None
        0-based index of the time column.
    """

    column: str
    spacing_min: float
    spacing_max: float
    spacing_mean: float
    step: float
    line: int | None = None
    column_index: int | None = None

    @classmethod
    def of(cls, exc: UnevenTimeError) -> Timing:
        """The timing of a reader's :class:`~core.csvio.UnevenTimeError`."""
        return cls(str(exc.column or "time"), exc.spacing_min, exc.spacing_max,
                   exc.spacing_mean, exc.spacing_median, exc.line, exc.column_index)

    @property
    def text(self) -> str:
        """What is uneven, in words (no option names)."""
        return (f"the time stamps in column {self.column!r} are uneven: the spacing varies "
                f"from {seconds_text(self.spacing_min)} to {seconds_text(self.spacing_max)} "
                f"(mean {seconds_text(self.spacing_mean)})")


@dataclass(frozen=True)
class CsvPreview:
    """The layout of CSV content for the column-mapping step (:func:`csv_preview`; the REST
    API's JSON of it is ``routers/schemas.py::csv_preview_json``).

    Attributes
    ----------
    columns : tuple of str
        The column names as written in the header.
    rows : tuple of tuple of str
        The first data rows, each cell as text.
    n_rows : int
        Data rows of the content.
    encoding : str
        The text encoding the reader found.
    notes : tuple of str
        What the reader noticed, in words.
    uneven : Timing or None
        The uneven time stamps of the automatic column mapping (the choice the page offers
        before the upload); ``None`` when they are even.
    """

    columns: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    n_rows: int
    encoding: str
    notes: tuple[str, ...]
    uneven: Timing | None = None


class UnevenUpload(UnevenTimeError):
    """An upload whose time stamps are uneven, with no choice made: the message offers
    resampling (with the step) or keeping them, in words; :attr:`timing` has the numbers."""

    def __init__(self, timing: Timing, source: str) -> None:
        super().__init__(
            f"{timing.text}. Choose what to do: resample the recording onto an even grid of "
            f"{seconds_text(timing.step)} steps (linear interpolation; dynamic models need "
            "an even step), or keep the time stamps as measured",
            source=source, line=timing.line, column=timing.column,
            column_index=timing.column_index,
            spacing=(timing.spacing_min, timing.spacing_max, timing.spacing_mean, timing.step))
        self.timing = timing


def uneven_timing(content: str | bytes, *, t_col: str | int | None = None,
                  u_col: str | int | None = None, y_col: str | int | None = None,
                  max_samples: int = 200_000) -> Timing | None:
    """The uneven timing of CSV *content* read with this column mapping, or ``None`` when
    its time stamps are even (or the file cannot be read: the upload will say why)."""
    try:
        read_csv_text(content, time=column_spec(t_col), input=column_spec(u_col),
                      output=column_spec(y_col), max_rows=max_samples)
    except UnevenTimeError as exc:
        return Timing.of(exc)
    except (CSVError, ValueError):
        return None
    return None


#: Cleaning notes of the reader that name its Python options -> the same in words.
_NOTE_WORDS = (
    ("; kept as measured (uneven='keep')", "; kept as measured, as chosen"),
    ("; call .resampled() or read with resample=True for a uniform grid",
     "; resample at upload for an even grid"),
)


def _words(note: str) -> str:
    for old, new in _NOTE_WORDS:
        note = note.replace(old, new)
    return note


@dataclass(frozen=True, eq=False)
class Upload:
    """An uploaded recording and what the file held.

    Attributes
    ----------
    recording : Recording
        The recording kept (its ``cleaning`` notes say what was removed or chosen).
    runs : tuple of str
        Run ids of the file's run column in file order (empty without one).
    time_steps : str or None
        What was done with uneven time stamps, in words (``None``: they were even).
    kept : str or None
        What of the runs was kept: a run id, ``"each"`` (every run, each its own loop),
        ``"all"`` (every row as one recording); ``None`` for a file without runs.
    """

    recording: Recording
    runs: tuple[str, ...] = ()
    time_steps: str | None = None
    kept: str | None = None


def _binary(exc: CSVError) -> bool:
    """Whether the reader refused the content as binary (not text at all)."""
    text = str(exc)
    return "is not a text CSV" in text and ("NUL byte" in text or "control character" in text)


def _plain(exc: CSVError, name: str | None = None) -> CSVError:
    """A refusal of binary content in words a student understands (an upload's message:
    no byte offsets); other errors as they are."""
    if not _binary(exc):
        return exc
    src = exc.source if exc.source and not str(exc.source).startswith("<") else None
    name = name or src or "This file"
    return CSVError(f"{name} is not a CSV text file: it looks like an image, a spreadsheet "
                    "workbook or another binary file. Save the measurement as CSV (comma-"
                    "separated text, one row per sample, e.g. \"Save as: CSV\" in a "
                    "spreadsheet) and upload that file.", source=exc.source)


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
    timing: str | None = None,
    step: float | None = None,
) -> Upload:
    """Read uploaded CSV *content* (never a path) with an optional column mapping.

    The content goes through :func:`core.csvio.read_csv_text`, so bytes are decoded as the
    command line decodes a file (UTF-8 with or without BOM, UTF-16 with BOM, else Latin-1).
    Columns are names or 0-based indices (digit strings count as indices); unmapped roles
    are chosen by the core reader. A file without a time column gets ``t = k * dt``. A file
    with a run column holds several recordings: ``run`` chooses one by its id, ``"all"``
    reads every row as one recording in file order, ``"each"`` too with each row marked by
    its run (:func:`.loops.keep_runs`: a fit and a diagnosis take the runs as separate
    recordings, as ``hyst fit FILE`` and ``hyst diagnose FILE`` do); without ``run`` a file
    of several runs is read as ``"each"``, so the browser and the command line see the same
    recordings. Either way a cleaning note says what was kept.

    Uneven time stamps need a choice: ``timing="resample"`` interpolates onto an even grid
    of ``step`` seconds (the median spacing, 3 significant digits, when ``step`` is None),
    ``timing="keep"`` keeps them as measured; a cleaning note says which was done.

    Raises
    ------
    UnevenUpload
        Uneven time stamps without a ``timing`` choice (its ``timing`` has the spacing
        and the step offered).
    core.csvio.CSVError
        With the 1-based ``line`` and the 0-based ``column_index`` of the problem, or when
        ``run`` names no run of the file.
    """
    if timing not in (None, *TIMING_CHOICES):
        raise CSVError(f"the choice for uneven time stamps must be one of "
                       f"{', '.join(TIMING_CHOICES)}, not {str(timing)[:40]!r}")
    if step is not None and not (timing == "resample" and 0 < step < float("inf")):
        raise CSVError("a resampling step (> 0 s) goes with the choice to resample")
    resample: bool | float = False
    if timing == "resample":
        resample = True if step is None else float(step)
    try:
        options = CsvOptions(time=column_spec(t_col), input=column_spec(u_col),
                             output=column_spec(y_col), run=None,
                             max_rows=max_samples, resample=resample,
                             uneven="keep" if timing == "keep" else "error")
        recs, split, run = _read_runs(content, options, name, run)
    except UnevenTimeError as exc:
        raise UnevenUpload(Timing.of(exc), exc.source) from None
    except CSVError as exc:
        if _binary(exc):
            raise _plain(exc, name) from None
        if timing == "resample" and "needs a time axis" in str(exc):
            raise CSVError(f"{exc.source}: there is no time column, so there is nothing to "
                           "resample (the samples are taken as evenly spaced); upload "
                           "without the choice to resample", source=exc.source) from None
        raise
    recs = [replace(r, cleaning=tuple(_words(c) for c in r.cleaning)) for r in recs]
    read = split
    runs = tuple(str(r.run) for r in read) if len(read) > 1 or read[0].run is not None else ()
    if run not in (None, "all", "each"):
        if str(run) not in runs:
            raise CSVError(
                f"run={run!r} is not in this file; its runs are {', '.join(runs) or 'none'}"
                " (or pass run=all to read every row as one recording)"
            )
        rec = recs[runs.index(str(run))]
    else:
        rec = recs[0]
    rec = _kept(rec, run, runs, name)
    if not rec.has_time:
        rec = replace(rec, t=rec.t * dt, has_time=True, units={**rec.units, "time": "s"})
    kept = (str(rec.run) if rec.run is not None else run) if runs else None
    return Upload(rec, runs, _time_steps(rec), kept)



def _read_runs(content: str | bytes, options: CsvOptions, name: str, run: str | None
               ) -> tuple[list[Recording], list[Recording], str | None]:
    """The recordings of :func:`read_upload` before a run is picked: ``(recs, split, run)``
    with ``split`` the file read run by run and ``run`` the choice (``None`` for a file of
    several runs becomes ``"each"``: every run, each its own loop, as ``hyst fit`` reads it).
    ``"each"`` lays the runs one after the other (:func:`.loops.keep_runs`), ``"all"`` reads
    every row as one recording, which a file whose runs each restart their time cannot be.
    """
    split = read_csv_text(content, options, name=name)
    if run is None and len(split) > 1:
        run = "each"
    if run == "each" and len(split) > 1:
        return [keep_runs(split)], split, run
    if run not in ("all", "each"):
        return split, split, run
    try:
        return read_csv_text(content, replace(options, run=False), name=name), split, run
    except TimeOrderError as exc:
        if len(split) > 1:
            raise CSVError(
                f"{exc.source}: the file's {len(split)} runs each start their own time, so "
                "its rows cannot be read as one recording with one time axis; keep all "
                f"{len(split)} runs, each its own loop, or choose one run",
                source=exc.source) from None
        raise


def _kept(rec: Recording, run: str | None, runs: tuple[str, ...], name: str) -> Recording:
    """``rec`` named for what of the file's ``runs`` it keeps, with a cleaning note saying so
    (``run``: :func:`read_upload`'s choice)."""
    col = rec.columns.get("run", "run")
    if run == "each" and len(runs) > 1:
        return replace(rec, name=f"{name} (all {len(runs)} runs, each its own loop)",
                       cleaning=(*rec.cleaning, f"kept all {len(runs)} runs of the file "
                                 f"(column {col!r}: {', '.join(runs)}), each its own loop: a "
                                 "fit fits them together, each run starting on its own, as "
                                 "hyst fit reads the file"))
    if run in ("all", "each"):
        return replace(rec, cleaning=(*rec.cleaning, "read every row as one recording "
                                      "(run=all): a run column, if any, was not used"))
    if len(runs) > 1:
        return replace(rec, name=f"{name} (run {rec.run}; {runs.index(str(rec.run)) + 1} of "
                                 f"{len(runs)})",
                       cleaning=(*rec.cleaning, f"the file holds {len(runs)} runs (column "
                                 f"{col!r}: {', '.join(runs)}); kept run {rec.run}; pass "
                                 "run=<id> to choose another or run=all to read every row"))
    return rec

def _time_steps(rec: Recording) -> str | None:
    """What the reader did with uneven time stamps (from its cleaning notes), in words."""
    if any(c.startswith("resampled by linear interpolation") for c in rec.cleaning):
        return (f"the time stamps were resampled onto an even grid of "
                f"{seconds_text(rec.dt)} steps (linear interpolation)")
    if any("kept as measured" in c for c in rec.cleaning):
        return "the uneven time stamps were kept as measured"
    return None


def recording_from_csv(content: str | bytes, **kwargs: Any) -> Recording:
    """The recording of :func:`read_upload` ``(content, **kwargs)``."""
    return read_upload(content, **kwargs).recording


def store_recording(session: Session, rec: Recording) -> None:
    """Give ``session`` the recording ``rec``; its fit and diagnosis are dropped."""
    session.set_recording(rec)


def csv_preview(content: str | bytes, max_samples: int, rows: int = 5) -> CsvPreview:
    """Columns, the first ``rows`` data rows (as text), row count and notes of CSV content,
    and the :class:`Timing` when the time stamps of the automatic column mapping are
    uneven, so the page can offer the choice before the upload.

    Raises
    ------
    core.csvio.CSVError
        If :func:`core.csvio.inspect_csv_text` cannot work out the layout.
    """
    try:
        lay = inspect_csv_text(content, max_rows=max_samples)
    except CSVError as exc:
        raise _plain(exc) from None
    if isinstance(content, bytes):
        enc = {"utf-8": "utf-8-sig"}.get(lay.encoding, lay.encoding)
        content = content.decode(enc)
    lines = content.splitlines()[lay.first_data_line - 1: lay.first_data_line - 1 + rows]
    d = None if lay.delimiter == "whitespace" else lay.delimiter
    return CsvPreview(
        columns=tuple(c.raw for c in lay.columns),
        rows=tuple(tuple(c.strip() for c in (ln.split(d) if d else ln.split()))
                   for ln in lines),
        n_rows=int(lay.n_rows), encoding=lay.encoding, notes=tuple(lay.notes),
        uneven=uneven_timing(content, max_samples=max_samples))


def csv_read_options(time: str | None = None, input_column: str | None = None,
                     output_column: str | None = None, run_column: str | None = None,
                     resample: str | None = None) -> CsvOptions:
    """The :class:`~core.csvio.CsvOptions` of :func:`core.csvio.read_csv` from the option texts of
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
    return CsvOptions(time=_spec(time), input=_spec(input_column), output=_spec(output_column),
                      run=_spec(run_column), resample=spacing)


def _spec(value: str | None) -> Any:
    if value is not None and value.strip().lower() == "none":
        return False
    return column_spec(value)


def read_recordings(files: Sequence[str | Path],
                    options: CsvOptions | None = None) -> list[Recording]:
    """Every recording of ``files`` (:func:`core.csvio.read_csv` with ``options``), in order.

    Raises
    ------
    CommandError
        A file that does not exist or is a folder, or whose time stamps are uneven
        without ``resample`` (the message offers ``--resample`` with the step).
    """
    from core.csvio import read_csv

    recs: list[Recording] = []
    for f in files:
        existing_file(f, "CSV file")
        try:
            recs.extend(read_csv(Path(f), options))
        except UnevenTimeError as exc:  # the command line's words for the choice
            timing = Timing.of(exc)
            raise CommandError(
                f"{f}: {timing.text}; pass --resample to interpolate onto an even grid of "
                f"{seconds_text(timing.step)} steps (or --resample DT for another step in s)"
            ) from None
    return recs


def say_read(progress: Progress, recs: list[Any]) -> None:
    """Report each recording read (samples, time axis, columns, cleaning notes) on stderr."""
    for r in recs:
        axis = f"t = {r.t[0]:g} .. {r.t[-1]:g} s" if r.has_time else "no time axis"
        progress(f"read {r.name}: {r.n_samples} samples, {axis}, "
                 f"u = {r.columns.get('input', 'u')}, y = {r.columns.get('output', 'y')}")
        for note in r.cleaning:
            progress(f"  note: {note}")
