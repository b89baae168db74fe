"""Module-level work for job tests: a job runs in a worker process, which finds its function
by module and name, so test work cannot be a lambda or a closure. A file is the gate between
the test and the worker."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any


def alive(pid: int) -> bool:
    """Whether process ``pid`` exists and is not a zombie (one that ended but was not reaped
    yet: it holds no memory and computes nothing)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def wait_gone(pid: int, timeout: float = 30.0) -> None:
    """In the test: wait until process ``pid`` has ended."""
    deadline = time.monotonic() + timeout
    while alive(pid):
        assert time.monotonic() < deadline, f"worker process {pid} is still there"
        time.sleep(0.02)


def constant(value: Any, *, progress: Any) -> Any:
    """Return ``value`` at once."""
    return value


def fail(message: str, *, progress: Any) -> Any:
    """Raise ``ValueError(message)``."""
    raise ValueError(message)


def die(code: int, *, progress: Any) -> Any:
    """End the worker process at once with exit status ``code`` (as the OOM killer would)."""
    import os

    os._exit(code)


def until_file(path: str, value: Any = None, limit_s: float = 120.0, *, progress: Any) -> Any:
    """Report progress 0.5, then wait until ``path`` exists (at most ``limit_s``); return
    ``value``."""
    progress(0.5, "waiting")
    deadline = time.monotonic() + limit_s
    while not Path(path).exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    return value


def stalled_diagnosis(rec: Any, model: Any, *, progress: Any) -> Any:
    """Stands in for :func:`app.services.jobs.tasks.run_diagnosis`: reports its last progress,
    then stalls (as if building the report) until killed or 120 s have passed."""
    progress(0.99, "building the report")
    time.sleep(120)
    raise AssertionError("a stalled diagnosis must be cancelled before it ends")


def slow_diagnosis(rec: Any, model: Any, *, progress: Any) -> Any:
    """Stands in for :func:`app.services.jobs.tasks.run_diagnosis`: the real diagnosis, pausing
    0.5 s at each progress report (so that a browser test can act while it runs)."""
    from app.services.analysis.diagnosis import run_diagnosis

    def slow(fraction: float = 0.0, message: str = "", *_: Any, **__: Any) -> None:
        time.sleep(0.5)
        progress(0.01 + 0.98 * float(fraction), str(message) or "diagnosing")

    return run_diagnosis(rec, model, slow)


def stalled_fit(rec: Any, n: int, kind: str, *, progress: Any) -> Any:
    """Stands in for :func:`app.services.jobs.tasks.run_fit`: reports half way, then stalls
    until killed or 120 s have passed."""
    progress(0.5, "fitting")
    time.sleep(120)
    raise AssertionError("a stalled fit must be cancelled before it ends")


def allocate(megabytes: float, *, progress: Any) -> int:
    """Allocate and touch ``megabytes`` MB (as a job that needs that much would); return
    the bytes held."""
    import numpy as np

    progress(0.5, "allocating")
    a = np.ones(int(megabytes * 1e6) // 8)
    return int(a.nbytes)


def run_here(task: Any) -> Any:
    """Run a :class:`~app.services.jobs.worker.Task` in this thread as the job manager runs
    it in a worker (``fn(*args, progress=...)``, then ``keep`` in the server): the session's
    own fit and diagnosis path, without a worker process."""
    value = task.fn(*task.args, progress=lambda *_: None)
    return value if task.keep is None else task.keep(value)
