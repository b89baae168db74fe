"""One recording on a batch worker: a recording too long for the worker's memory is refused
up front, in words, by the measured model of ``hyst fit`` / ``hyst diagnose`` (issue 31)."""

from __future__ import annotations

import numpy as np

from app.batch import single
from app.batch.options import DiagnoseOptions, FitOptions
from app.services.runs.cost import DIAGNOSE, FIT


def _content(n: int) -> bytes:
    t = np.arange(n) * 1e-3
    rows = "".join(f"{a:.3f},{np.sin(7 * a):.6f},{np.cos(7 * a):.6f}\n" for a in t)
    return ("t,u,y\n" + rows).encode()


def test_the_refusal_names_the_file_both_sizes_and_what_fits():
    content = _content(2000)  # 2,001 lines
    allowed = DIAGNOSE.peak_bytes(1000)
    msg = single.memory_refusal_here("diagnose", "long.csv", content, allowed=allowed)
    assert msg is not None
    assert msg.startswith("long.csv holds about 2,001 samples; diagnosing it would need about")
    need = DIAGNOSE.base_bytes + DIAGNOSE.bytes_per_sample * 2001
    assert f"{need / 1e6:.0f} MB of memory" in msg
    assert f"a batch worker has {allowed / 1e6:.0f} MB available" in msg
    assert "at most about 1,000 samples here" in msg
    # the fit's model is its own, and what fits is not refused
    fit = single.memory_refusal_here("fit", "long.csv", content, allowed=FIT.peak_bytes(1000))
    assert fit is not None and "fitting it would need" in fit
    assert single.memory_refusal_here("diagnose", "long.csv", content,
                                      allowed=DIAGNOSE.peak_bytes(2001)) is None


def test_a_refused_recording_fails_before_any_work(monkeypatch):
    called = []
    monkeypatch.setattr(single, "worker_memory", lambda: FIT.peak_bytes(500))
    monkeypatch.setattr(single, "_fit", lambda *a: called.append(a))
    monkeypatch.setattr(single, "_diagnose", lambda *a: called.append(a))
    for kind, opts in (("fit", FitOptions()), ("diagnose", DiagnoseOptions())):
        out = single.run_recording(kind, "long.csv", _content(2000), opts)
        assert not out.ok and out.samples == 0 and out.parameter_set == ""
        assert "long.csv holds about 2,001 samples" in out.error
        assert "available; use a shorter part of the recording" in out.error
    assert called == []


def test_the_worker_memory_is_what_the_machine_has_for_it():
    free = single.worker_memory()
    assert free is None or free > 0
