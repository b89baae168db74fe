"""Job work in a worker process that a cancel kills at once (no web imports).

Why a process: the long steps of a fit or a diagnosis are scipy's NNLS and least squares and
compiled (numba) kernels, none of which can be interrupted from inside; a check between them
leaves a cancelled fit running for as long as its longest step (a cancelled dead-zone GPI fit
held its job slot for 96 s, issue 18). A process is killed (``SIGKILL``) at once, and the
memory it used goes with it.

How: each :class:`Task` runs in a child forked from :mod:`multiprocessing`'s forkserver, which
imports numpy, scipy, numba and the solvers once (:data:`PRELOAD`, started in the background by
:func:`start`), so a job starts in milliseconds instead of the seconds of a fresh interpreter.
The child sends its progress and its result (pickled: parent and child are the same program)
through a pipe, and watches a second pipe whose other end only the server holds: when the
server is gone (kill -9), the child exits instead of computing for nobody.

Each worker may be given a memory allowance (``memory_limit``, bytes, beyond what it holds
when it starts: the preloaded solvers, about 250 MB of address space): the worker sets its
``RLIMIT_DATA`` (Linux counts every private writable mapping there, so numpy's arrays too) to
that much more than it holds, so a job that needs more gets a ``MemoryError`` (or, inside
compiled code, dies) and fails with :func:`memory_message` instead of pushing the machine
into swap; the server is another process and goes on. Elsewhere than Linux the limit is set
where the platform has it (macOS does not enforce it).

Like every child of a forkserver or of spawn, a worker imports the main script of the program
that started the server (as ``__mp_main__``): a script that serves the app must keep its work
under ``if __name__ == "__main__":`` (``hyst serve`` and ``python -m app`` do).
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.connection as mpc
import multiprocessing.forkserver  # noqa: F401 - imported for ensure_running
import os
import signal
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from app.services.runs.cost import CostModel

__all__ = ["PRELOAD", "LiveWorkers", "OutOfMemory", "Progress", "Task", "TaskFailed", "Worker",
           "WorkerDied", "default_memory_limit", "memory_message", "start"]

#: ``progress(fraction, message)``: how a task reports to its job (``fraction`` in 0..1).
Progress = Callable[[float, str], None]

#: Modules the forkserver imports once (the last one loads the compiled kernels); every
#: worker is forked with them loaded.
PRELOAD = ["numpy", "scipy.optimize", "core.fitting", "core.diagnosis",
           "app.services.jobs.tasks", "app.services.jobs.preload",
           "app.services.session.actions"]

#: One BLAS / OpenMP / numba thread per worker unless the user set otherwise: a worker is one
#: job on one core, and a multithreaded BLAS in each of several workers (and beside the
#: server) oversubscribes the cores (a 20,000-sample diagnosis in a worker took 76-82 s at
#: load 14 on 2 cores, about 8 s single-threaded). The forkserver, started later from this
#: process, inherits these; the server's own numpy is already loaded and keeps its threads.
WORKER_THREADS_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
                      "MKL_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
for _name, _value in WORKER_THREADS_ENV.items():
    os.environ.setdefault(_name, _value)

#: forkserver where the platform has one (Linux, macOS); spawn elsewhere (Windows: each
#: worker then starts a fresh interpreter and imports the solvers itself: seconds, not
#: measured here)
_FORKSERVER = "forkserver" in multiprocessing.get_all_start_methods()
_CTX = (multiprocessing.get_context("forkserver") if _FORKSERVER
        else multiprocessing.get_context("spawn"))
if _FORKSERVER:
    _CTX.set_forkserver_preload(PRELOAD)  # read when the forkserver starts


@dataclass(frozen=True)
class Task:
    """One unit of work for a worker process.

    Parameters
    ----------
    fn : callable
        A module-level function (it is sent to the worker by name), called there as
        ``fn(*args, progress=progress)``; ``progress(fraction, message)`` reports to the
        job. Its return value is pickled back.
    args : tuple
        Its arguments (pickled: arrays, recordings, models).
    keep : callable, optional
        Called in the server with ``fn``'s return value once the work is done and was not
        cancelled (store it in the session); its return value is the job's result.
        Without it the result is ``fn``'s return value.
    samples : int
        Samples of the recording the work reads (0: none or not known).
    cost : CostModel, optional
        The work's measured memory model (:mod:`app.services.runs.cost`): with
        ``samples`` it says up front whether the work fits in a worker's allowance
        (:meth:`app.services.jobs.manager.JobManager.submit` refuses it in words if not).
    """

    fn: Callable[..., Any]
    args: tuple[Any, ...] = ()
    keep: Callable[[Any], Any] | None = None
    samples: int = 0
    cost: CostModel | None = None


class TaskFailed(RuntimeError):
    """The task raised in the worker; the message is the exception's text."""


class WorkerDied(RuntimeError):
    """The worker process ended without a result (killed, or out of memory)."""


class OutOfMemory(TaskFailed):
    """The task needed more memory than its worker's allowance (:func:`memory_message`)."""


def memory_message(limit: int) -> str:
    """What a user reads when a job needed more than ``limit`` bytes."""
    return (f"this job needed more memory than the server allows ({limit / 1e6:,.0f} MB); "
            "use fewer samples or operators")


def default_memory_limit(priced_memory: float, machine_memory: int | None = None) -> int:
    """A worker's default allowance, bytes: twice the priced memory bound of one request
    (:attr:`app.services.explore.cost.Limits.max_memory_bytes`: what a heavy figure request may
    use, with room for numpy's temporaries), at most a quarter of the machine's memory (two
    jobs and the figure workers may run at once), at least 512 MB (a fit or a diagnosis of
    a 200,000-sample recording peaks at about 130 MB beyond the worker's start)."""
    if machine_memory is None:
        machine_memory = _machine_memory()
    cap = 2.0 * float(priced_memory)
    if machine_memory:
        cap = min(cap, machine_memory / 4)
    return int(max(512e6, cap))


def _machine_memory() -> int | None:
    """Physical memory in bytes, where the platform says (``None`` otherwise)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return None


def _data_size() -> int:
    """Bytes of this process's data segment now (Linux ``VmData``; 0 where unknown)."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmData:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0


def _limit_memory(allowance: int) -> None:
    """In the worker: let its data segment grow by ``allowance`` bytes at most.

    OpenBLAS stops its threads at a fork and starts them again at the child's first matrix
    product; a thread that cannot get its stack under the limit leaves that product waiting
    for ever (seen with a 20 MB limit). So one product runs first, and the limit counts the
    threads' stacks as held at the start.
    """
    try:
        import resource
    except ImportError:  # Windows: no limit
        return
    import numpy as np

    a = np.ones((256, 256))
    a @ a  # noqa: B018 - starts the BLAS threads
    _, hard = resource.getrlimit(resource.RLIMIT_DATA)
    soft = _data_size() + allowance
    if hard != resource.RLIM_INFINITY:
        soft = min(soft, hard)
    try:
        resource.setrlimit(resource.RLIMIT_DATA, (soft, hard))
    except (ValueError, OSError):
        pass


def start() -> None:
    """Start the forkserver with :data:`PRELOAD` imported, if it is not running yet.

    Safe to call more than once and from any thread; the first job calls it anyway (and
    then waits for the imports, a few seconds)."""
    if _FORKSERVER:
        multiprocessing.forkserver.ensure_running()


def _watch_server(lifeline: mpc.Connection) -> None:
    """In the worker: exit as soon as the server's end of ``lifeline`` closes."""
    try:
        lifeline.recv()
    except (EOFError, OSError):
        pass
    os._exit(1)


def _main(task_fn: Callable[..., Any], args: tuple[Any, ...], out: mpc.Connection,
          lifeline: mpc.Connection, memory_limit: int | None = None) -> None:
    """The worker process: run ``task_fn``, send progress and the outcome through ``out``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl+C in a terminal: the server decides
    threading.Thread(target=_watch_server, args=(lifeline,), daemon=True).start()
    if memory_limit:
        _limit_memory(memory_limit)

    def progress(fraction: float, message: str = "") -> None:
        out.send(("progress", float(fraction), str(message)))

    try:
        value = task_fn(*args, progress=progress)
        out.send(("done", value))
    except MemoryError:  # over the allowance: the arrays are freed by now
        out.send(("memory", memory_message(memory_limit or 0) if memory_limit else
                  "this job needed more memory than this machine has; use fewer samples or "
                  "operators"))
    except Exception as exc:  # the job reports it; a worker never prints a traceback
        out.send(("failed", str(exc) or type(exc).__name__))


class Worker:
    """One task in its own process: :meth:`run` it, :meth:`kill` it from any thread.

    ``memory_limit`` (bytes) is the most the process may allocate beyond what it holds at
    its start (``None``: no limit); a task that needs more fails with :class:`OutOfMemory`.
    """

    def __init__(self, task: Task, memory_limit: int | None = None) -> None:
        self.task = task
        self.memory_limit = memory_limit
        self._proc: Any = None
        self._lock = threading.Lock()
        self._killed = False

    @property
    def pid(self) -> int | None:
        """The worker's process id (``None`` before it started)."""
        return None if self._proc is None else self._proc.pid

    @property
    def stopped(self) -> bool:
        """Whether :meth:`kill` was called."""
        return self._killed

    def kill(self) -> None:
        """Stop the worker now (SIGKILL); :meth:`run` then raises :class:`WorkerDied`."""
        with self._lock:
            self._killed = True
            if self._proc is not None and self._proc.exitcode is None:
                self._proc.kill()

    def run(self, progress: Progress) -> Any:
        """Start the process, pass its progress reports to ``progress`` and return the
        task's return value.

        Raises
        ------
        TaskFailed
            The task raised (the message is its text); :class:`OutOfMemory` when it needed
            more than ``memory_limit``.
        WorkerDied
            The process was killed (:meth:`kill`) or ended without a result.
        """
        start()
        out_r, out_w = _CTX.Pipe(duplex=False)
        life_r, life_w = _CTX.Pipe(duplex=False)
        proc = _CTX.Process(target=_main, args=(self.task.fn, self.task.args, out_w, life_r,
                                                self.memory_limit),
                            name="hyst-job", daemon=True)
        try:
            with self._lock:
                if self._killed:
                    raise WorkerDied("the job was stopped before it started")
                proc.start()
                self._proc = proc
            out_w.close()
            life_r.close()
            return self._collect(proc, out_r, progress)
        finally:
            if proc.pid is not None:
                with self._lock:
                    if proc.exitcode is None:
                        proc.kill()
                proc.join()
                proc.close()
            for c in (out_r, out_w, life_r, life_w):
                c.close()

    def _collect(self, proc: Any, out: mpc.Connection, progress: Progress) -> Any:
        while True:
            try:
                msg = out.recv()  # blocks until a message, or EOF once the worker is gone
            except (EOFError, OSError):
                proc.join()
                if self._killed:
                    raise WorkerDied("it was stopped") from None
                if self.memory_limit:  # compiled code that cannot allocate ends the process
                    raise WorkerDied(
                        f"the work stopped unexpectedly (exit code {proc.exitcode}); it may "
                        f"have needed more memory than the server allows "
                        f"({self.memory_limit / 1e6:,.0f} MB): use fewer samples or "
                        "operators") from None
                raise WorkerDied(f"the work stopped unexpectedly (exit code {proc.exitcode}; "
                                 "the server may have run out of memory): try fewer "
                                 "operators or a shorter recording") from None
            if msg[0] == "progress":
                progress(msg[1], msg[2])
            elif msg[0] == "done":
                return msg[1]
            elif msg[0] == "memory":
                raise OutOfMemory(msg[1])
            else:
                raise TaskFailed(msg[1])


class LiveWorkers:
    """The workers running now, outside the job queue (a request's heavy figures): their
    process ids for tests and monitoring, and :attr:`max_running`, how many may run at once
    (the routes wait for a free one; a worker thread per request was bounded by the thread
    pool, a process per request must be too)."""

    def __init__(self, max_running: int | None = None, memory_limit: int | None = None) -> None:
        self._lock = threading.Lock()
        self._workers: set[Worker] = set()
        #: Workers allowed at once: the number of cores (at least 2).
        self.max_running = max_running or max(2, os.cpu_count() or 2)
        #: Bytes each may allocate beyond its start (:class:`Worker`; ``None``: no limit).
        self.memory_limit = memory_limit

    def add(self, w: Worker) -> None:
        with self._lock:
            self._workers.add(w)

    def discard(self, w: Worker) -> None:
        with self._lock:
            self._workers.discard(w)

    def running(self) -> int:
        """Workers listed now (started or about to start)."""
        with self._lock:
            return len(self._workers)

    def pids(self) -> list[int]:
        """Process ids of the workers that have started."""
        with self._lock:
            return [p for w in self._workers if (p := w.pid) is not None]
