"""One recording of a batch, run on a Dask worker: the single-file command's own steps.

:func:`run_recording` writes the recording's bytes under its own file name into a private
temporary folder and runs what ``hyst fit FILE -o MODEL.json`` or ``hyst diagnose FILE
--json --save-model MODEL.json`` runs, as function calls: the command's reader
(:func:`app.services.analysis.recordings.read_recordings` /
:func:`~app.services.analysis.diagnosis.diagnose_files`, which ``hyst fit`` / ``hyst diagnose``
call too),
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

from app.services.runs.cost import memory_refusal
from app.services.runs.progress import Progress

from .options import DiagnoseOptions, FitOptions, Options

__all__ = ["Outcome", "memory_refusal_here", "run_recording", "worker_memory"]


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
    fmu : bytes
        With the ``fmu`` option: the FMU file (empty when none could be built).
    fmu_note : str
        What the FMU holds (``compensator`` / ``model``), or why there is none.
    dt : float or None
        Sample spacing of the recording (s), the FMU's sample time for dynamic models.
    """

    ok: bool
    error: str = ""
    parameter_set: str = ""
    diagnosis: str = ""
    samples: int = 0
    messages: str = ""
    elapsed_s: float = 0.0
    fmu: bytes = b""
    fmu_note: str = ""
    dt: float | None = None


def _fit(src: Path, opts: FitOptions, progress: Progress) -> Outcome:
    """``hyst fit src`` with ``opts``: the parameter set it writes."""
    from app.services.analysis.fitting import (
        check_n_operators,
        fit_errors,
        fit_source,
        say_fit,
        time_window,
    )
    from app.services.analysis.recordings import csv_read_options, read_recordings, say_read
    from core.fitting import fit_recordings

    train, test = time_window(opts.train, "train"), time_window(opts.test, "test")
    check_n_operators(opts.n_operators)
    recs = read_recordings([src], csv_read_options(opts.time, opts.input_column,
                                                   opts.output_column))
    say_read(progress, recs)
    with fit_errors():
        out = fit_recordings(recs, opts.model, n_operators=opts.n_operators,
                             constraint=opts.constraint, train=train, test=test,
                             **fit_source([src]))
    say_fit(progress, out)
    return Outcome(True, parameter_set=out.parameter_set.to_json() + "\n",
                   samples=sum(r.n_samples for r in recs), dt=_dt(recs))


def _diagnose(src: Path, opts: DiagnoseOptions, progress: Progress) -> Outcome:
    """``hyst diagnose src --json --save-model`` with ``opts``: both documents."""
    from app.services.analysis.diagnosis import (
        diagnose_files,
        diagnosis_json,
        diagnosis_source,
        model_document,
    )
    from app.services.analysis.recordings import csv_read_options
    from app.services.runs.inputs import parse_window

    res = diagnose_files(
        [src], csv_read_options(), progress, operators=opts.operators,
        train=parse_window(opts.train, "train") if opts.train is not None else None,
        test=parse_window(opts.test, "test") if opts.test is not None else None,
        fixed_grid=opts.fixed_grid, no_crossfit=opts.no_crossfit, effects=opts.effects)
    return Outcome(True, parameter_set=model_document(res, diagnosis_source([src])).to_json()
                   + "\n", diagnosis=diagnosis_json(res),
                   samples=sum(r.n_samples for r in res.records), dt=_dt(res.records))


def _dt(recs: list) -> float | None:
    """Median sample spacing of the first recording with a time axis (s)."""
    import numpy as np

    for r in recs:
        t = getattr(r, "t", None)
        if t is not None and np.size(t) > 1:
            return float(np.median(np.diff(t)))
    return None


def _fmu(parameter_set: str, dt: float | None, version: int) -> tuple[bytes, str]:
    """``(FMU bytes, note)``: the compensator's FMU, or the model's when it has no inverse;
    no bytes and the reason when it cannot be built (the fit itself stands)."""
    from core.exceptions import NotInvertibleError, ParameterError
    from core.export_fmu import build_fmu
    from core.paramset import ParameterSet

    ps = ParameterSet.from_json(parameter_set)
    dyn = dt if ps.model.is_dynamic else None
    with tempfile.TemporaryDirectory(prefix="hyst-fmu-") as tmp:
        try:
            try:
                path = build_fmu(ps, Path(tmp) / "c.fmu", fmi_version=version, inverse=True,
                                 dt=dyn, name="hysteresis_compensator")
                what = "compensator"
            except NotInvertibleError as exc:
                path = build_fmu(ps, Path(tmp) / "m.fmu", fmi_version=version, dt=dyn,
                                 name="hysteresis_model")
                what = f"model (no compensator: {exc})"
            return path.read_bytes(), what
        except (ParameterError, ValueError, OSError) as exc:
            return b"", f"no FMU: {exc}"


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
        refusal = memory_refusal_here(kind, filename, content)
        if refusal:
            return Outcome(False, error=refusal, elapsed_s=time.perf_counter() - t0)
        try:
            if kind == "fit" and isinstance(options, FitOptions):
                out = _fit(src, options, progress)
            elif kind == "diagnose" and isinstance(options, DiagnoseOptions):
                out = _diagnose(src, options, progress)
            else:
                raise ValueError(f"batch kind {kind!r} does not match {type(options).__name__}")
            fmu, note = (b"", "")
            if options.fmu is not None:
                fmu, note = _fmu(out.parameter_set, out.dt, options.fmu)
            return Outcome(True, parameter_set=out.parameter_set, diagnosis=out.diagnosis,
                           samples=out.samples, messages=_text(lines),
                           elapsed_s=time.perf_counter() - t0, fmu=fmu, fmu_note=note,
                           dt=out.dt)
        except (ValueError, OSError) as exc:  # what `hyst` reports as "error: ..."
            msg = str(exc).replace(str(src), filename).replace(tmp + "/", "")
            return Outcome(False, error=msg, messages=_text(lines),
                           elapsed_s=time.perf_counter() - t0)
        except Exception as exc:  # noqa: BLE001 - one bad recording never stops the batch
            return Outcome(False, error=f"internal error ({type(exc).__name__}): {exc}",
                           messages=_text(lines), elapsed_s=time.perf_counter() - t0)


def worker_memory() -> float | None:
    """Bytes the whole worker process may take: what the machine still has for it (its
    own resident memory plus :func:`core.memory.available_memory`), within 95 % of its Dask
    worker's memory limit (where the nanny ends the worker); ``None`` where nothing says."""
    from core.memory import available_memory

    caps: list[float] = []
    free = available_memory()
    if free is not None:
        caps.append(free + _resident())
    try:
        from distributed import get_worker

        limit = get_worker().memory_manager.memory_limit
    except (ImportError, ValueError, AttributeError):
        limit = None
    if limit:
        caps.append(0.95 * float(limit))
    return min(caps) if caps else None


def _resident() -> int:
    """Resident memory of this process, bytes (Linux ``VmRSS``; 0 where unknown)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0


def memory_refusal_here(kind: str, filename: str, content: bytes,
                        allowed: float | None = None) -> str | None:
    """The refusal, in words, of a recording whose ``kind`` run would not fit in this
    worker's memory (:func:`worker_memory`, or ``allowed`` bytes), else ``None``; its samples
    are its lines, counted before anything is read (the model of ``hyst fit`` / ``hyst
    diagnose``, :mod:`app.services.runs.cost`)."""
    from app.services.runs.cost import DIAGNOSE, FIT

    allowed = worker_memory() if allowed is None else allowed
    if allowed is None:
        return None
    samples = content.count(b"\n") + (not content.endswith(b"\n"))
    return memory_refusal(samples, DIAGNOSE if kind == "diagnose" else FIT, filename, allowed,
                          where="a batch worker has")


def _text(lines: list[str]) -> str:
    return "".join(f"{line}\n" for line in lines)
