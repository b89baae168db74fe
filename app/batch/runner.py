"""``run_batch``: many recordings through ``hyst fit`` / ``hyst diagnose`` on Dask.

The driver (this process) expands the file list, skips what the manifest says is done, sends
each remaining recording's bytes to a Dask worker (:func:`app.batch.single.run_recording`),
writes what comes back into the output folder as it arrives, and finally writes
``summary.csv`` and ``report.html``. At most a few tasks per worker thread are in flight, so
memory stays bounded however many recordings there are.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from app.services.runs.inputs import CommandError
from app.services.runs.progress import Progress

from .files import Manifest, content_hash, expand, output_names
from .options import DiagnoseOptions, FitOptions, Options
from .results import BatchResult, RecordingResult, from_outcome, write_json
from .single import Outcome, run_recording

__all__ = ["LOCAL_CLUSTER_QUIET", "connect", "run_batch"]

#: Environment of local worker processes: one BLAS/OpenMP thread each (one task per core).
_WORKER_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
               "NUMBA_NUM_THREADS": "1"}
#: Dask configuration of local workers (the Nanny hands it to each worker process). Our
#: tasks are GIL-bound Python and numpy; every wake-up of the worker's event-loop thread takes
#: the GIL from the task thread, which on a loaded machine stalls it (measured at load 16 on 2
#: cores: a 0.42 s fit took 1.0 s in a default worker, 0.45 s with these settings). So: no
#: statistical profiler (samples every stack every 10 ms), event-loop health tick every 1 s
#: instead of 20 ms, system monitor every 5 s instead of 0.5 s.
_WORKER_CONFIG = {"distributed.worker.profile.enabled": False,
                  "distributed.admin.tick.interval": "1s",
                  "distributed.admin.system-monitor.interval": "5s"}


#: No dashboard, and the scheduler's HTTP endpoint on a free loopback port (it defaults to
#: 8787, which another cluster on the machine may hold).
LOCAL_CLUSTER_QUIET: dict[str, Any] = {
    "dashboard_address": None, "scheduler_kwargs": {"dashboard_address": "127.0.0.1:0"}}


@contextlib.contextmanager
def connect(scheduler: str | None, workers: int, processes: bool = True) -> Iterator[Any]:
    """A ``distributed.Client`` on the scheduler at ``scheduler`` (``tcp://HOST:PORT``), or
    on a new LocalCluster of ``workers`` single-thread workers (processes, or threads of this
    process with ``processes=False``) that closes with the context.

    Raises
    ------
    CommandError
        Unreachable scheduler, or ``workers < 1``.
    """
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise CommandError(
                f"cannot reach the Dask scheduler at {scheduler}: {exc} (start one with "
                "'dask scheduler' and give its tcp://HOST:PORT address)") from None
        try:
            yield client
        finally:
            client.close()
        return
    if workers < 1:
        raise CommandError(f"--workers must be at least 1, got {workers}")
    import dask

    kw: dict[str, Any] = {"env": _WORKER_ENV} if processes else {}
    with dask.config.set(_WORKER_CONFIG), LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=processes, **LOCAL_CLUSTER_QUIET,
            **kw) as cluster, Client(cluster) as client:
        yield client


def _cluster_error(exc: BaseException) -> str:
    """A one-line message for a task the Dask cluster itself could not run."""
    first = (str(exc).strip().splitlines() or [""])[0]
    hint = ""
    if "deserializ" in first.lower() or isinstance(exc, ImportError):
        hint = (" (the scheduler and every worker must be able to import "
                "hysteresis-explorer: install it there, or start them with "
                "PYTHONPATH=<repository root>)")
    return f"the Dask cluster could not run this recording: {type(exc).__name__}: {first}{hint}"


def _outputs(folder: Path, name: str, kind: str) -> list[Path]:
    """The files a recording writes: the parameter set and, for diagnose, the diagnosis."""
    out = [folder / f"{name}.json"]
    if kind == "diagnose":
        out.append(folder / "diagnosis" / f"{name}.json")
    return out


def _eta(done: int, remaining: int, elapsed: float) -> str:
    if not done or elapsed <= 0:
        return ""
    rate = done / elapsed
    left = remaining / rate
    return f", {rate:.2f}/s, ~{left:.0f} s left" if left < 600 else \
        f", {rate:.2f}/s, ~{left / 60:.0f} min left"


def run_batch(
    files: Sequence[str | Path],
    output: str | Path,
    options: Options | None = None,
    *,
    scheduler: str | None = None,
    workers: int = 2,
    processes: bool = True,
    resume: bool = True,
    quiet: bool = False,
    report_title: str | None = None,
) -> BatchResult:
    """Fit or diagnose every recording on Dask and write the fleet outputs.

    Parameters
    ----------
    files : sequence of str or Path
        CSV paths, folders (their ``*.csv``) or glob patterns (``**`` recurses).
    output : str or Path
        Output folder (created): ``<name>.json`` per recording (exactly what ``hyst fit -o``
        / ``hyst diagnose --save-model`` writes), for diagnose also
        ``diagnosis/<name>.json`` (the ``--json`` document), ``summary.csv``,
        ``report.html`` and the manifest ``.hyst-batch.json``.
    options : FitOptions or DiagnoseOptions, optional
        The single-file command and its options (default ``FitOptions()``).
    scheduler : str, optional
        ``tcp://HOST:PORT`` of a running Dask scheduler; default: a LocalCluster.
    workers : int
        Local worker processes (one thread each); ignored with ``scheduler``.
    processes : bool
        Local workers as processes (default) or threads in this process (tests).
    resume : bool
        Skip recordings already done with the same content and options.
    quiet : bool
        No progress on stderr.
    report_title : str, optional
        Heading of the fleet report.

    Returns
    -------
    BatchResult

    Raises
    ------
    CommandError
        Bad options, no recordings, or an unreachable scheduler (before any work).
    """
    from .report import write_report
    from .summary import write_summary

    opts = options if options is not None else FitOptions()
    if not isinstance(opts, (FitOptions, DiagnoseOptions)):
        raise CommandError("options must be FitOptions or DiagnoseOptions")
    opts.validate()
    kind = opts.kind
    progress = Progress(f"batch {kind}", quiet=quiet)
    paths, unmatched = expand(list(files))
    for pat in unmatched:
        progress(f"warning: nothing matches {pat}")
    folder = Path(output)
    if folder.exists() and not folder.is_dir():
        raise CommandError(f"--output {folder} is a file; give a folder")
    folder.mkdir(parents=True, exist_ok=True)
    names = output_names(paths)
    manifest = Manifest.load(folder)
    okey = opts.key()
    t0 = time.perf_counter()
    results: dict[str, RecordingResult] = {}
    todo: list[tuple[Path, str, str]] = []
    for p, name in zip(paths, names, strict=True):
        try:
            sha = content_hash(p)
        except OSError as exc:
            msg = (f"file not found: {p} (check the path)" if not p.exists()
                   else f"{p} is a folder without CSV files" if p.is_dir()
                   else f"cannot read {p}: {exc.strerror or exc}")
            results[name] = RecordingResult(str(p), name, "failed", error=msg)
            manifest.record(name, {"file": str(p), "content_sha256": "", "options_key": okey,
                                   "status": "failed", "row": results[name].to_dict()})
            continue
        if resume and manifest.done(name, sha, okey, _outputs(folder, name, kind)):
            results[name] = RecordingResult.from_dict(manifest.entries[name]["row"],
                                                      file=str(p), resumed=True, elapsed_s=0.0)
        else:
            todo.append((p, name, sha))
    n_total = len(paths)
    n_skip = sum(r.resumed for r in results.values())
    n_bad0 = len(results) - n_skip
    progress(f"{n_total} recordings: {len(todo)} to run, {n_skip} already done"
             + (f", {n_bad0} unreadable" if n_bad0 else ""))
    nthreads = workers
    if todo:
        with connect(scheduler, workers, processes) as client:
            nthreads = max(1, sum(client.nthreads().values()))
            progress(f"Dask: {len(client.nthreads())} workers, {nthreads} threads"
                     + (f" at {scheduler}" if scheduler else " (local)"))
            _run(client, opts, todo, folder, manifest, okey, results, progress,
                 nthreads, t_start=time.perf_counter())
    ordered = tuple(results[n] for n in names)
    summary = write_summary(folder / "summary.csv", ordered)
    report = write_report(folder / "report.html", kind, ordered, opts, title=report_title)
    elapsed = time.perf_counter() - t0
    res = BatchResult(kind, folder, ordered, summary, report, elapsed, nthreads)
    progress(f"done: {len(res.succeeded)} ok ({len(res.resumed)} from an earlier run), "
             f"{len(res.failed)} failed, {elapsed:.1f} s; wrote {summary} and {report}")
    return res


def _run(client: Any, opts: Options, todo: list[tuple[Path, str, str]],
         folder: Path, manifest: Manifest, okey: str, results: dict[str, RecordingResult],
         progress: Progress, nthreads: int, t_start: float) -> None:
    """Submit ``todo`` with a bounded window and store every outcome as it arrives."""
    from distributed import as_completed

    kind = opts.kind
    window = max(2, 2 * nthreads)
    pending = iter(todo)
    meta: dict[str, tuple[Path, str, str]] = {}

    def submit() -> Any:
        try:
            p, name, sha = next(pending)
        except StopIteration:
            return None
        fut = client.submit(run_recording, kind, p.name, p.read_bytes(), opts, pure=False,
                            key=f"hyst-{kind}-{name}-{sha[:12]}")
        meta[fut.key] = (p, name, sha)
        return fut

    first = [f for f in (submit() for _ in range(window)) if f is not None]
    done = failed = 0
    ac = as_completed(first)
    for fut in ac:
        p, name, sha = meta.pop(fut.key)
        try:
            outcome: Outcome = fut.result()
        except Exception as exc:  # noqa: BLE001 - the cluster failed (e.g. cannot import)
            outcome = Outcome(False, error=_cluster_error(exc))
        fut.release()
        row = from_outcome(kind, str(p), name, outcome)
        if outcome.ok:
            paths = _outputs(folder, name, kind)
            write_json(paths[0], outcome.parameter_set)
            if kind == "diagnose":
                write_json(paths[1], outcome.diagnosis + "\n")
            if row.fmu:
                (folder / row.fmu).parent.mkdir(parents=True, exist_ok=True)
                (folder / row.fmu).write_bytes(outcome.fmu)
        results[name] = row
        manifest.record(name, {"file": str(p), "content_sha256": sha, "options_key": okey,
                               "status": row.status, "row": row.to_dict()})
        done += 1
        failed += not row.ok
        nxt = submit()
        if nxt is not None:
            ac.add(nxt)
        remaining = len(todo) - done
        status = "ok" if row.ok else f"FAILED: {row.error}"
        progress(f"{done - failed} done, {failed} failed, {remaining} remaining"
                 f"{_eta(done, remaining, time.perf_counter() - t_start)} | {name}: {status}")
    sys.stderr.flush()
