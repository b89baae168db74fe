"""How many threads the numeric libraries may use inside one of our calls.

The fitting and diagnosis loops are many small matrix products: a second BLAS thread gains
little on them, and on a busy machine (two cores shared with other work) it loses a lot,
because every product waits for a thread that is not scheduled. Measured on the README's
piezo diagnosis beside two busy processes on the two cores: 26.4 s (16.6 s of CPU) with
OpenBLAS's default of two threads, 6.7 s (4.8 s of CPU) with one, 4.8 s alone
(``benchmarks/bench_diagnose_scale.py --contention``, docs/pages/diagnose.md "Scale"). So
the entry points people call (:func:`core.diagnosis.diagnose`,
:func:`core.fitting.fit_recordings`) and ``hyst`` run the libraries on
:data:`DEFAULT_THREADS` thread unless asked for more.

:func:`numeric_threads` sets the limit for a block and gives the caller back its own
settings afterwards:

* BLAS and OpenMP pools (numpy's and scipy's OpenBLAS, MKL, libgomp...) through
  ``threadpoolctl``. Their limit is process-wide, so calls running at the same time in threads
  of one process share it: the first call in saves the caller's settings, the last one out
  restores them (a later call's limit applies to all the calls running with it).
* numba's parallel layer (``numba.set_num_threads``, per calling thread), when a parallel
  kernel has started it; no kernel of :mod:`core.kernels` is parallel, so this block never
  starts it.

Examples
--------
>>> from core.threads import numeric_threads
>>> with numeric_threads(1):
...     pass  # numpy / scipy run on one thread here
"""

from __future__ import annotations

import functools
import inspect
import os
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar, cast

from .exceptions import ParameterError

__all__ = ["DEFAULT_THREADS", "check_threads", "max_threads", "numeric_threads",
           "with_thread_limit"]

#: Threads of the numeric libraries when nobody asks for more.
DEFAULT_THREADS = 1

_F = TypeVar("_F", bound=Callable[..., Any])

_lock = threading.Lock()
_inside = 0  # calls of this process inside numeric_threads (any thread)
_limiter: Any = None  # the threadpoolctl limiter of the first call in: the caller's settings
_asked = threading.local()  # .threads: the limit of this thread's innermost block
_UNSET: Any = object()


def max_threads() -> int:
    """CPUs this process may run on (its affinity mask, else ``os.cpu_count()``)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def check_threads(threads: object) -> int:
    """``threads`` as a thread count from 1 to :func:`max_threads`.

    Raises
    ------
    ParameterError
        Not a whole number, below 1, or above the CPUs this process may use.
    """
    if isinstance(threads, bool) or not isinstance(threads, int | float) or (
            isinstance(threads, float) and not threads.is_integer()):
        raise ParameterError(f"threads must be a whole number of threads, got {threads!r}")
    n, top = int(threads), max_threads()
    if not 1 <= n <= top:
        raise ParameterError(f"threads must be between 1 and {top} (the CPUs this machine "
                             f"lets the process use), got {n}")
    return n


def _load_blas() -> None:
    """Import the libraries that bring a BLAS pool, so the limit reaches every pool (a
    library loaded after the limit was set would keep its own default)."""
    import numpy  # noqa: F401
    import scipy.linalg  # noqa: F401


@contextmanager
def numeric_threads(threads: int | None = DEFAULT_THREADS) -> Iterator[None]:
    """Run the block with at most ``threads`` BLAS / OpenMP / numba threads.

    Parameters
    ----------
    threads : int or None
        Threads (1 to :func:`max_threads`); ``None`` leaves the caller's settings alone.

    Raises
    ------
    ParameterError
        A bad ``threads`` (:func:`check_threads`), before anything changes.
    """
    if threads is None:
        yield
        return
    n = check_threads(threads)
    _load_blas()
    global _inside, _limiter
    with _lock:
        limiter = _set_limit(n)
        if _inside == 0:
            _limiter = limiter  # holds the caller's settings
        _inside += 1
    outer = getattr(_asked, "threads", None)
    _asked.threads = n
    restore_numba = _numba_limit(n)
    try:
        yield
    finally:
        if restore_numba is not None:
            restore_numba()
        _asked.threads = outer
        with _lock:
            _inside -= 1
            if _inside == 0:
                _set_limit(None, restore=_limiter)
                _limiter = None
            elif outer is not None:
                _set_limit(outer)


def _set_limit(n: int | None, restore: Any = None) -> Any:
    """Set every loaded BLAS / OpenMP pool to ``n`` threads (or back to the settings saved
    by the limiter ``restore``); returns the limiter holding the settings before.

    threadpoolctl lets only one thread of a process change OpenBLAS's process-wide pool (the
    first that does; the others silently change nothing). Every change of ours is made under
    ``_lock``, by whichever thread enters first or leaves last, so the control is released
    after each change; a caller's own ``threadpool_limits`` block takes it back when it ends.
    """
    import threadpoolctl

    release = getattr(getattr(threadpoolctl, "OpenBLASController", None),
                      "clear_controlling_thread", None)
    if release is not None:
        release(force=True)
    try:
        if restore is not None:
            restore.restore_original_limits()
            return None
        return threadpoolctl.threadpool_limits(limits=n)
    finally:
        if release is not None:
            release(force=True)


def _numba_limit(n: int) -> Callable[[], None] | None:
    """Limit numba's parallel threads of this thread to ``n`` if its pool runs; the undo."""
    import sys

    parallel = sys.modules.get("numba.np.ufunc.parallel")
    if parallel is None or not getattr(parallel, "_is_initialized", False):
        return None
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
    return lambda: numba.set_num_threads(before)


def with_thread_limit(func: _F) -> _F:
    """``func`` with a keyword ``threads``: it runs inside :func:`numeric_threads` of that
    many threads (``None``: the caller's settings). Without ``threads``, a call made inside
    a :func:`numeric_threads` block (``hyst --threads 2`` runs the command in one) keeps that
    block's limit, any other runs on :data:`DEFAULT_THREADS`."""

    @functools.wraps(func)
    def limited(*args: Any, threads: Any = _UNSET, **kwargs: Any) -> Any:
        if threads is _UNSET:
            threads = getattr(_asked, "threads", None) or DEFAULT_THREADS
        with numeric_threads(threads):
            return func(*args, **kwargs)

    limited.__doc__ = _document_threads(func.__doc__ or "")
    sig = inspect.signature(func)
    params = list(sig.parameters.values())
    at = next((i for i, p in enumerate(params) if p.kind is p.VAR_KEYWORD), len(params))
    params.insert(at, inspect.Parameter("threads", inspect.Parameter.KEYWORD_ONLY,
                                        default=DEFAULT_THREADS, annotation="int | None"))
    cast(Any, limited).__signature__ = sig.replace(parameters=params)  # what help() shows
    return cast(_F, limited)


THREADS_DOC = """    threads : int or None, optional
        BLAS / OpenMP / numba threads during the call (default 1, fastest on a shared
        machine, or the limit of an enclosing :func:`core.threads.numeric_threads` block);
        ``None`` keeps the caller's settings. The caller's settings are restored when the
        call returns.
"""


def _document_threads(doc: str) -> str:
    """``doc`` with :data:`THREADS_DOC` at the end of its Parameters section."""
    at = doc.find("\n    Returns\n")
    if at < 0:
        return doc
    return doc[:at].rstrip("\n") + "\n" + THREADS_DOC + doc[at:]
