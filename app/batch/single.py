"""One recording of a batch, run on a Dask worker: the single-file command's own steps.

:func:`run_recording` writes the recording's bytes under its own file name into a private
temporary folder and runs what ``hyst fit FILE -o MODEL.json`` or ``hyst diagnose FILE
--json --save-model MODEL.json`` runs, as function calls: the command's reader
(:func:`app.services.recordings.read_recordings` /
:func:`app.services.diagnosis.diagnose_files`, which ``hyst fit`` / ``hyst diagnose`` call too),
the one fitting entry point :func:`core.fitting.fit_recordings` or
:func:`core.diagnosis.diagnose`, and the command's document builders. Nothing is parsed
from an argument list and nothing goes through ``sys.stdout`` / ``sys.stderr``, so thread
workers (``processes=False``) never see each other's output. The parameter set a batch
stores is what the single-file command writes, and the worker needs no shared file system:
bytes in, documents out.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from ..services.progress import Progress
from .options import DiagnoseOptions, FitOptions, Options

__all__ = ["Outcome", "run_recording"]


@dataclass(frozen=True)
class Outcome:
    """What a worker sends back for one recording.

    Attributes
    ----------
    ok : bool
        The command succeeded.
    error : str
        The command's user-facing error message (empty on success).
    parameter_set : str
        Text of the parameter-set JSON the command writes (empty on failure).
    diagnosis : str
        For ``diagnose``: the ``--json`` document (one JSON object); else empty.
    samples : int
        Samples in the file (all recordings it holds); 0 when it could not be read.
    messages : str
        The lines the command prints on stderr (read notes, warnings, progress).
    elapsed_s : float
        Wall time on the worker (s).
    """

    ok: bool
    error: str = ""
    parameter_set: str = ""
    diagnosis: str = ""
    samples: int = 0
    messages: str = ""
    elapsed_s: float = 0.0


def _fit(src: Path, opts: FitOptions, progress: Progress) -> Outcome:
    """``hyst fit src`` with ``opts``: the parameter set it writes."""
    from core.fitting import fit_recordings

    from ..services.fitting import (
        check_n_operators,
        fit_errors,
        fit_source,
        say_fit,
        time_window,
    )
    from ..services.recordings import csv_read_kwargs, read_recordings, say_read

    train, test = time_window(opts.train, "train"), time_window(opts.test, "test")
    check_n_operators(opts.n_operators)
    recs = read_recordings([src], csv_read_kwargs(opts.time, opts.input_column,
                                                  opts.output_column))
    say_read(progress, recs)
    with fit_errors():
        out = fit_recordings(recs, opts.model, n_operators=opts.n_operators,
                             constraint=opts.constraint, train=train, test=test,
                             **fit_source([src]))
    say_fit(progress, out)
    return Outcome(True, parameter_set=out.parameter_set.to_json() + "\n",
                   samples=sum(r.n_samples for r in recs))


def _diagnose(src: Path, opts: DiagnoseOptions, progress: Progress) -> Outcome:
    """``hyst diagnose src --json --save-model`` with ``opts``: both documents."""
    from ..services.diagnosis import (
        diagnose_files,
        diagnosis_json,
        diagnosis_source,
        model_document,
    )
    from ..services.inputs import parse_window
    from ..services.recordings import csv_read_kwargs

    res = diagnose_files(
        [src], csv_read_kwargs(), progress, operators=opts.operators,
        train=parse_window(opts.train, "train") if opts.train is not None else None,
        test=parse_window(opts.test, "test") if opts.test is not None else None,
        fixed_grid=opts.fixed_grid, no_crossfit=opts.no_crossfit, effects=opts.effects)
    return Outcome(True, parameter_set=model_document(res, diagnosis_source([src])).to_json()
                   + "\n", diagnosis=diagnosis_json(res),
                   samples=sum(r.n_samples for r in res.records))


def run_recording(kind: str, filename: str, content: bytes, options: Options) -> Outcome:
    """Run the single-file command ``kind`` on one recording.

    Parameters
    ----------
    kind : {"fit", "diagnose"}
        Which command.
    filename : str
        The recording's file name (no folder); the command sees a file of that name, so
        the provenance it writes is the same as for a single-file run.
    content : bytes
        The file's bytes.
    options : FitOptions or DiagnoseOptions
        The command's options (of ``kind``).

    Returns
    -------
    Outcome
        Never raises for a bad recording: the error is in :attr:`Outcome.error`.
        :attr:`Outcome.messages` holds the lines the command prints on stderr.
    """
    t0 = time.perf_counter()
    lines: list[str] = []
    progress = Progress(kind, sink=lines.append)
    with tempfile.TemporaryDirectory(prefix="hyst-batch-") as tmp:
        src = Path(tmp) / Path(filename).name
        src.write_bytes(content)
        try:
            if kind == "fit" and isinstance(options, FitOptions):
                out = _fit(src, options, progress)
            elif kind == "diagnose" and isinstance(options, DiagnoseOptions):
                out = _diagnose(src, options, progress)
            else:
                raise ValueError(f"batch kind {kind!r} does not match {type(options).__name__}")
            return Outcome(True, parameter_set=out.parameter_set, diagnosis=out.diagnosis,
                           samples=out.samples, messages=_text(lines),
                           elapsed_s=time.perf_counter() - t0)
        except (ValueError, OSError) as exc:  # what `hyst` reports as "error: ..."
            msg = str(exc).replace(str(src), filename).replace(tmp + "/", "")
            return Outcome(False, error=msg, messages=_text(lines),
                           elapsed_s=time.perf_counter() - t0)
        except Exception as exc:  # noqa: BLE001 - one bad recording never stops the batch
            return Outcome(False, error=f"internal error ({type(exc).__name__}): {exc}",
                           messages=_text(lines), elapsed_s=time.perf_counter() - t0)


def _text(lines: list[str]) -> str:
    return "".join(f"{line}\n" for line in lines)
