"""Bounded, cancellable background work (fits and diagnoses); no web imports.

A :class:`JobManager` runs at most ``max_workers`` jobs at once, at most one per session, and
at most ``max_queued`` waiting. Each job is a :class:`~app.services.jobs.worker.Task` that runs in
its own worker process (:mod:`.worker`); a thread of the manager (never the web server's
pool) follows it. Cancelling a running job kills its process, so the job is ``cancelled`` and
its slot free at once, whatever numerics it was in; a queued job never starts. A result is
stored (``Task.keep``) only when the job was not cancelled, and a cancel that arrives while it
is being stored is too late (the job ends ``done``). A job nobody has asked about for
``idle_cancel_s`` seconds is cancelled (its client went away).

States: ``queued`` → ``running`` → ``done`` | ``failed`` | ``cancelled``.
"""

from __future__ import annotations

import secrets
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

from app.services.jobs.worker import Task, Worker, WorkerDied
from app.services.jobs.worker import start as start_workers
from app.services.runs.cost import WORKER_START_BYTES, memory_refusal, time_left_text

__all__ = ["Job", "JobBusy", "JobManager", "JobTooLarge", "JobView"]

_FINAL = frozenset({"done", "failed", "cancelled"})


class JobBusy(RuntimeError):
    """The session already has a job running, or the queue is full."""


class JobTooLarge(JobBusy):
    """The job's recording would not fit in a worker's memory allowance (the sizes in
    words); refused before it starts."""


@dataclass(frozen=True)
class JobView:
    """A job's state as ``GET /api/sessions/{code}/jobs/{id}`` shows it (its JSON is
    ``routers/schemas.py::job_json``; ``result`` is the task's typed result once done)."""

    id: str
    kind: str
    state: str
    progress: float
    message: str
    result: Any
    error: str | None
    #: the time left in words while it runs (``"about 40 s left"``), ``""`` when the run is
    #: expected to be short or is not running (:func:`~app.services.runs.cost.time_left_text`)
    time_left: str = ""


@dataclass(eq=False)
class Job:
    """One unit of background work of a session (mutated under the manager's lock)."""

    id: str
    kind: str
    code: str
    state: str = "queued"
    progress: float = 0.0
    message: str = "queued"
    result: Any = None
    error: str | None = None
    seen: float = field(default_factory=time.monotonic)
    finished: threading.Event = field(default_factory=threading.Event)
    #: the worker process of the running job (``None`` while queued and once finished)
    worker: Worker | None = None
    #: the result is being stored: too late to cancel
    storing: bool = False
    #: CPU time the task's measured model predicts on one thread, s (0: not known)
    expected_s: float = 0.0
    #: when it started running (``time.monotonic``), ``None`` before
    started: float | None = None

    def view(self) -> JobView:
        """A frozen snapshot."""
        left = ""
        if self.state == "running" and self.started is not None and not self.storing:
            left = time_left_text(self.expected_s, time.monotonic() - self.started)
        return JobView(self.id, self.kind, self.state, round(self.progress, 4),
                       self.message, self.result, self.error, left)


class JobManager:
    """Runs jobs with bounded concurrency, one per session at a time.

    Parameters
    ----------
    max_workers : int
        Jobs running at once.
    max_queued : int
        Jobs waiting at most (beyond it :meth:`submit` raises :class:`JobBusy`).
    idle_cancel_s : float
        A queued or running job nobody polled for this long is cancelled.
    keep : int
        Finished jobs remembered (for late polls).
    memory_limit : int, optional
        Bytes each job's worker process may allocate beyond its start (a job that needs
        more fails with a message saying so, :class:`~app.services.jobs.worker.OutOfMemory`);
        ``None``: no limit.
    """

    def __init__(self, max_workers: int = 2, max_queued: int = 50,
                 idle_cancel_s: float = 30.0, keep: int = 1000,
                 memory_limit: int | None = None) -> None:
        self.max_workers = max_workers
        self.memory_limit = memory_limit
        self.max_queued = max_queued
        self.idle_cancel_s = idle_cancel_s
        self.keep = keep
        self._pool = ThreadPoolExecutor(max_workers=max_workers, thread_name_prefix="job")
        self._lock = threading.Lock()
        self._jobs: dict[str, Job] = {}
        self._active: dict[str, str] = {}  # session code -> job id
        self._stop = threading.Event()
        threading.Thread(target=self._reaper, name="job-reaper", daemon=True).start()
        # the worker processes' forkserver imports the solvers now, not at the first job
        threading.Thread(target=start_workers, name="job-forkserver", daemon=True).start()

    # ------------------------------------------------------------------ API
    def submit(self, code: str, kind: str, task: Task) -> Job:
        """Queue ``task`` for session ``code`` (see :class:`~app.services.jobs.worker.Task`).

        Raises
        ------
        JobBusy
            If ``code`` has a job queued or running, or too many jobs are waiting.
        JobTooLarge
            If the task's measured memory model (``task.cost``) predicts more for its
            ``task.samples`` than a worker's allowance (``memory_limit``, beyond the
            worker's start): the message gives both sizes and the samples that fit.
        """
        refusal = self.memory_refusal(task)
        if refusal:
            raise JobTooLarge(refusal)
        with self._lock:
            if code in self._active:
                raise JobBusy(f"this session already has a {self._jobs[self._active[code]].kind}"
                              " job running; wait for it or cancel it")
            waiting = sum(1 for j in self._jobs.values() if j.state == "queued")
            if waiting >= self.max_queued:
                raise JobBusy("the server is busy (too many fits and diagnoses waiting); "
                              "try again in a minute")
            expected = task.cost.cpu_s(task.samples) if task.cost and task.samples else 0.0
            job = Job(id=secrets.token_hex(8), kind=kind, code=code, expected_s=expected)
            self._jobs[job.id] = job
            self._active[code] = job.id
            self._forget_old()
        self._pool.submit(self._run, job, task)
        return job

    def memory_refusal(self, task: Task) -> str | None:
        """Why ``task`` would not fit in a worker's allowance, in words, or ``None``."""
        if not (self.memory_limit and task.cost is not None and task.samples):
            return None
        return memory_refusal(task.samples, task.cost, "the recording",
                              self.memory_limit + WORKER_START_BYTES,
                              where="a job on this server has")

    def get(self, code: str, job_id: str) -> Job:
        """The job ``job_id`` of session ``code`` (marks it as waited for); ``KeyError``."""
        with self._lock:
            job = self._jobs.get(job_id)
            if job is None or job.code != code:
                raise KeyError(job_id)
            job.seen = time.monotonic()
            return job

    def recent(self, code: str, limit: int = 10) -> list[Job]:
        """The newest ``limit`` jobs of session ``code``, newest first.

        Queued and running jobs are always listed (a session has at most one); finished
        ones are those still remembered. Listing counts as asking for the unfinished job
        (a page reloaded during a job finds it and follows it), so it is not cancelled
        as abandoned.
        """
        now = time.monotonic()
        with self._lock:
            mine = [j for j in reversed(self._jobs.values()) if j.code == code][:max(0, limit)]
            for j in mine:
                if j.state not in _FINAL:
                    j.seen = now
            return mine

    def cancel(self, code: str, job_id: str) -> Job:
        """Cancel a job: a running one's worker process is killed, and the job is
        ``cancelled`` on return (a no-op once it finished, or while its result is being
        stored); ``KeyError`` if unknown."""
        job = self.get(code, job_id)
        self._cancel(job, "cancelled by the user")
        return job

    def wait(self, job: Job, timeout: float) -> bool:
        """Wait up to ``timeout`` s for ``job`` to finish (marks it as waited for)."""
        job.seen = time.monotonic()
        return job.finished.wait(timeout)

    def cancel_all(self) -> None:
        """Cancel every job (server shutdown; worker processes are killed) and stop
        accepting work."""
        self._stop.set()
        with self._lock:
            jobs = list(self._jobs.values())
        for j in jobs:
            self._cancel(j, "the server is shutting down")
        self._pool.shutdown(wait=False, cancel_futures=True)

    def running(self) -> int:
        """Jobs running now."""
        with self._lock:
            return sum(1 for j in self._jobs.values() if j.state == "running")

    def workers(self) -> list[int]:
        """Process ids of the worker processes running now."""
        with self._lock:
            return [j.worker.pid for j in self._jobs.values()
                    if j.worker is not None and j.worker.pid is not None]

    # ------------------------------------------------------------------ internals
    def _cancel(self, job: Job, why: str) -> None:
        with self._lock:
            if job.state in _FINAL or job.storing:
                return
            if job.worker is not None:
                job.worker.kill()
            self._finish(job, "cancelled", why)

    def _finish(self, job: Job, state: str, message: str, result: Any = None,
                error: str | None = None) -> None:
        """Called with the lock held."""
        job.state, job.message, job.result, job.error = state, message, result, error
        job.worker = None
        if state == "done":
            job.progress = 1.0
        if self._active.get(job.code) == job.id:
            del self._active[job.code]
        job.finished.set()

    def _run(self, job: Job, task: Task) -> None:
        worker = Worker(task, self.memory_limit)
        with self._lock:
            if job.state != "queued":
                return
            job.state, job.message, job.worker = "running", "running", worker
            job.started = time.monotonic()

        def progress(fraction: float, message: str = "") -> None:
            with self._lock:
                if job.state == "running":
                    job.progress = min(1.0, max(job.progress, float(fraction)))
                    if message:
                        job.message = message

        try:
            value = worker.run(progress)
        except WorkerDied as exc:  # killed by a cancel (then the job is final already)
            with self._lock:
                if job.state not in _FINAL:
                    self._finish(job, "failed", "failed", error=str(exc))
            return
        except Exception as exc:  # TaskFailed and any other: reported, never a crash
            with self._lock:
                if job.state not in _FINAL:
                    self._finish(job, "failed", "failed", error=str(exc) or type(exc).__name__)
            return
        with self._lock:
            if job.state in _FINAL:  # cancelled while the result was on its way
                return
            job.storing, job.message = True, "storing the result"
        try:
            result = value if task.keep is None else task.keep(value)
        except Exception as exc:
            with self._lock:
                self._finish(job, "failed", "failed", error=str(exc) or type(exc).__name__)
            return
        with self._lock:
            self._finish(job, "done", "done", result=result)

    def _forget_old(self) -> None:
        """Called with the lock held: drop the oldest finished jobs beyond ``keep``."""
        done = [j for j in self._jobs.values() if j.state in _FINAL]
        for j in done[: max(0, len(done) - self.keep)]:
            del self._jobs[j.id]

    def _reaper(self) -> None:
        while not self._stop.wait(1.0):
            cutoff = time.monotonic() - self.idle_cancel_s
            with self._lock:
                idle = [j for j in self._jobs.values()
                        if j.state not in _FINAL and j.seen < cutoff]
            for j in idle:
                self._cancel(j, f"nobody asked for it for {self.idle_cancel_s:g} s")
