"""One numeric-library thread unless asked (issue 31): the library entry points limit the
BLAS pools during the call and give the caller its own settings back.

The reference is threadpoolctl's own report of the loaded pools (``threadpool_info``), read
inside the call (the diagnosis's progress callback, a probe in the fitting path) and after it.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest
import scipy.linalg  # noqa: F401  (its BLAS pool is loaded before the caller's limits are set)
from threadpoolctl import threadpool_info, threadpool_limits

import core.fitting.entry as fit_entry
from core.diagnosis import diagnose
from core.exceptions import ParameterError
from core.fitting import fit_recordings
from core.pi import PIModel
from core.recordings import Recording
from core.threads import check_threads, max_threads, numeric_threads, with_thread_limit

two_cpus = pytest.mark.skipif(max_threads() < 2, reason="needs two CPUs to tell 1 from 2")


def _blas_threads() -> set[int]:
    """Thread counts of every BLAS pool loaded in this process."""
    return {p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"}


def _recording(n: int = 3000) -> Recording:
    t = np.arange(n) * 1e-3
    u = 2.0 * np.sin(2 * np.pi * 2.0 * t) * np.exp(-t / 2.0)
    y = PIModel(0.5, np.linspace(0.1, 1.5, 6), np.full(6, 0.4))(u)
    y = y + 0.01 * np.random.default_rng(3).standard_normal(n)
    return Recording(t=t, u=u, y=y, name="probe")


@two_cpus
def test_diagnose_runs_on_one_thread_and_restores_the_callers_two():
    seen: list[set[int]] = []
    with threadpool_limits(limits=2):
        assert _blas_threads() == {2}
        diagnose(_recording(1500), effects=["drift"], n_operators=6, auto_resolution=False,
                 base="pi", progress=lambda f, m: seen.append(_blas_threads()))
        assert _blas_threads() == {2}  # the caller's setting is back
        assert seen and all(s == {1} for s in seen)
        seen.clear()
        diagnose(_recording(1500), effects=["drift"], n_operators=6, auto_resolution=False,
                 base="pi", threads=2, progress=lambda f, m: seen.append(_blas_threads()))
        assert seen and all(s == {2} for s in seen)
        assert _blas_threads() == {2}


@two_cpus
def test_fit_recordings_runs_on_one_thread_and_restores(monkeypatch):
    seen: list[set[int]] = []
    prepare = fit_entry.prepare

    def probe(*args, **kwargs):
        seen.append(_blas_threads())
        return prepare(*args, **kwargs)

    monkeypatch.setattr(fit_entry, "prepare", probe)
    with threadpool_limits(limits=2):
        fit_recordings(_recording(), "pi", n_operators=6)
        # (the fit reads its rows more than once: every read ran on one thread)
        assert seen and all(s == {1} for s in seen) and _blas_threads() == {2}
        # inside a block that asked for 2, a call without threads= keeps the block's limit
        with numeric_threads(2):
            fit_recordings(_recording(), "pi", n_operators=6)
        assert seen[-1] == {2}
        # threads=None: the caller's settings, untouched
        with threadpool_limits(limits=1):
            fit_recordings(_recording(), "pi", n_operators=6, threads=None)
            assert seen[-1] == {1}
        fit_recordings(_recording(), "pi", n_operators=6, threads=None)
        assert seen[-1] == {2}


@two_cpus
def test_calls_in_threads_restore_the_callers_setting_whatever_the_order():
    """Two calls overlap in threads of one process (the threaded batch): the one that leaves
    first must not restore the caller's 2 threads under the other, nor the last leave 1."""
    a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()
    inside_b: list[set[int]] = []

    @with_thread_limit
    def call_a() -> None:
        a_in.set()
        b_in.wait(10)

    @with_thread_limit
    def call_b() -> None:
        b_in.set()
        a_out.wait(10)
        inside_b.append(_blas_threads())

    def run_a() -> None:
        call_a()
        a_out.set()

    with threadpool_limits(limits=2):
        ta = threading.Thread(target=run_a)
        ta.start()
        a_in.wait(10)
        tb = threading.Thread(target=call_b)
        tb.start()
        ta.join(10)
        tb.join(10)
        assert inside_b == [{1}]  # still limited after the first call left
        assert _blas_threads() == {2}  # and the caller's setting is back after the last


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "2", None, max_threads() + 1])
def test_bad_thread_counts_are_refused_before_anything_changes(bad):
    before = _blas_threads()
    with pytest.raises(ParameterError, match="threads"):
        check_threads(bad)
    if bad is not None:  # None means "leave the caller's settings" in the entry points
        with pytest.raises(ParameterError, match="threads"), numeric_threads(bad):
            pass  # pragma: no cover - never entered
        with pytest.raises(ParameterError, match="threads"):
            fit_recordings(_recording(), "pi", n_operators=6, threads=bad)
    assert _blas_threads() == before


def test_an_exception_inside_still_restores():
    with threadpool_limits(limits=max_threads()):
        before = _blas_threads()
        with pytest.raises(RuntimeError), numeric_threads(1):
            assert _blas_threads() == {1}
            raise RuntimeError("boom")
        assert _blas_threads() == before
