"""Bounded, cancellable background work (fits and diagnoses); no web imports.

A :class:`JobManager` runs at most ``max_workers`` jobs at once on its own threads (never
the web server's pool), at most one per session, and at most ``max_queued`` waiting. A job
reports progress through the callback it is given; that callback raises
:class:`JobCancelled` once the job is cancelled, so cooperative work (the diagnosis) stops
at its next progress report and queued work never starts. A job nobody has asked about for
``idle_cancel_s`` seconds is cancelled (its client went away).

States: ``queued`` → ``running`` → ``done`` | ``failed`` | ``cancelled``.
"""

from __future__ import annotations

import secrets
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Job", "JobBusy", "JobCancelled", "JobManager", "JobView", "Progress"]

#: ``progress(fraction, message)``; raises :class:`JobCancelled` when the job is cancelled.
Progress = Callable[[float, str], None]

_FINAL = frozenset({"done", "failed", "cancelled"})


class JobCancelled(Exception):  # noqa: N818 - a signal, not an error
    """Raised inside a job's work when the job was cancelled."""


class JobBusy(RuntimeError):
    """The session already has a job running, or the queue is full."""


@dataclass(frozen=True)
class JobView:
    """What ``GET /api/sessions/{code}/jobs/{id}`` returns (the list leaves ``result`` out)."""

    id: str
    kind: str
    state: str
    progress: float
    message: str
    result: Any
    error: str | None

    def to_dict(self, with_result: bool = True) -> dict[str, Any]:
        """JSON-ready form (the API contract); ``with_result=False`` leaves the result out."""
        d = {"id": self.id, "kind": self.kind, "state": self.state,
             "progress": self.progress, "message": self.message, "error": self.error}
        if with_result:
            d["result"] = self.result
        return d


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
    cancel_event: threading.Event = field(default_factory=threading.Event)
    finished: threading.Event = field(default_factory=threading.Event)

    def view(self) -> JobView:
        """A frozen snapshot."""
        return JobView(self.id, self.kind, self.state, round(self.progress, 4),
                       self.message, self.result, self.error)


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
    """

    def __init__(self, max_workers: int = 2, max_queued: int = 50,
                 idle_cancel_s: float = 30.0, keep: int = 1000) -> None:
        self.max_workers = max_workers
        self.max_queued = max_queued
        self.idle_cancel_s = idle_cancel_s
        self.keep = keep
        self._pool = ThreadPoolExecutor(max_workers=max_workers, thread_name_prefix="job")
        self._lock = threading.Lock()
        self._jobs: dict[str, Job] = {}
        self._active: dict[str, str] = {}  # session code -> job id
        self._stop = threading.Event()
        threading.Thread(target=self._reaper, name="job-reaper", daemon=True).start()

    # ------------------------------------------------------------------ API
    def submit(self, code: str, kind: str, work: Callable[[Progress], Any]) -> Job:
        """Queue ``work(progress)`` for session ``code``; its return value is the result.

        Raises
        ------
        JobBusy
            If ``code`` has a job queued or running, or too many jobs are waiting.
        """
        with self._lock:
            if code in self._active:
                raise JobBusy(f"this session already has a {self._jobs[self._active[code]].kind}"
                              " job running; wait for it or cancel it")
            waiting = sum(1 for j in self._jobs.values() if j.state == "queued")
            if waiting >= self.max_queued:
                raise JobBusy("the server is busy (too many fits and diagnoses waiting); "
                              "try again in a minute")
            job = Job(id=secrets.token_hex(8), kind=kind, code=code)
            self._jobs[job.id] = job
            self._active[code] = job.id
            self._forget_old()
        self._pool.submit(self._run, job, work)
        return job

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
        """Cancel a job (a no-op once it finished); ``KeyError`` if unknown."""
        job = self.get(code, job_id)
        self._cancel(job, "cancelled by the user")
        return job

    def wait(self, job: Job, timeout: float) -> bool:
        """Wait up to ``timeout`` s for ``job`` to finish (marks it as waited for)."""
        job.seen = time.monotonic()
        return job.finished.wait(timeout)

    def cancel_all(self) -> None:
        """Cancel every job (server shutdown) and stop accepting work."""
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

    # ------------------------------------------------------------------ internals
    def _cancel(self, job: Job, why: str) -> None:
        with self._lock:
            if job.state in _FINAL:
                return
            job.cancel_event.set()
            if job.state == "queued":
                self._finish(job, "cancelled", why)
            else:
                job.message = f"cancelling: {why}"

    def _finish(self, job: Job, state: str, message: str, result: Any = None,
                error: str | None = None) -> None:
        """Called with the lock held."""
        job.state, job.message, job.result, job.error = state, message, result, error
        if state == "done":
            job.progress = 1.0
        if self._active.get(job.code) == job.id:
            del self._active[job.code]
        job.finished.set()

    def _run(self, job: Job, work: Callable[[Progress], Any]) -> None:
        with self._lock:
            if job.state != "queued":
                return
            job.state, job.message = "running", "running"

        def progress(fraction: float, message: str = "") -> None:
            if job.cancel_event.is_set():
                raise JobCancelled
            with self._lock:
                job.progress = min(1.0, max(job.progress, float(fraction)))
                if message:
                    job.message = message

        try:
            result = work(progress)
        except JobCancelled:
            with self._lock:
                self._finish(job, "cancelled", "cancelled")
            return
        except Exception as exc:  # reported to the client, never a crash
            with self._lock:
                self._finish(job, "failed", "failed", error=str(exc) or type(exc).__name__)
            return
        with self._lock:
            if job.cancel_event.is_set():
                self._finish(job, "cancelled", "cancelled (the result was discarded)")
            else:
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
