"""``hyst diagnose`` on long recordings (issue 31): samples counted before reading, a
refusal up front with the memory it would need, and the time left on the progress lines."""

from __future__ import annotations

import resource
import time

import numpy as np
import pytest

from app.cli import main
from app.commands import _scale
from app.commands._scale import (
    DIAGNOSE,
    CostModel,
    EtaProgress,
    allowed_memory,
    check_memory,
    count_samples,
)
from app.services.runs.inputs import CommandError


def _csv(path, n: int, trailing_newline: bool = True):
    t = np.arange(n) * 1e-3
    rows = "\n".join(f"{a:.3f},{np.sin(a):.6f},{np.cos(a):.6f}" for a in t)
    path.write_text("t,u,y\n" + rows + ("\n" if trailing_newline else ""), encoding="utf-8")
    return path


def test_count_samples_counts_the_lines_of_every_file(tmp_path):
    a = _csv(tmp_path / "a.csv", 1234)
    b = _csv(tmp_path / "b.csv", 77, trailing_newline=False)
    # the reference: numpy's own reading of the rows, plus each file's header line
    ref = sum(np.loadtxt(p, delimiter=",", skiprows=1).shape[0] + 1 for p in (a, b))
    assert count_samples([a, b], chunk=100) == ref == 1234 + 77 + 2
    assert count_samples([tmp_path / "missing.csv"]) == 0  # the reader says why later
    assert count_samples([tmp_path]) == 0  # a folder
    assert count_samples(["/dev/zero"]) == 0  # endless, not a regular file: not read


def test_the_refusal_gives_both_sizes_and_what_fits():
    model = CostModel(base_bytes=400e6, bytes_per_sample=1e3, base_cpu_s=1.0,
                      cpu_s_per_sample=1e-5)
    assert check_memory(1_000_000, model, "x.csv", allowed=int(2e9)) == pytest.approx(1.4e9)
    with pytest.raises(CommandError) as exc:
        check_memory(10_000_000, model, "x.csv", allowed=int(2e9))
    msg = str(exc.value)
    assert "10,000,000 samples" in msg and "10.4 GB" in msg and "2.0 GB available" in msg
    assert "at most about 1,600,000 samples" in msg  # (2e9 - 4e8) / 1e3


def test_allowed_memory_is_within_the_process_limits(monkeypatch):
    free = allowed_memory()
    assert free is None or free > 0
    real = resource.getrlimit
    monkeypatch.setattr(resource, "getrlimit", lambda lim: (
        (123_000_000, resource.RLIM_INFINITY) if lim == resource.RLIMIT_AS else real(lim)))
    assert allowed_memory() <= 123_000_000


def test_hyst_diagnose_refuses_up_front_what_cannot_fit(tmp_path, monkeypatch, capsys):
    src = _csv(tmp_path / "long.csv", 3000)
    monkeypatch.setattr(_scale, "allowed_memory", lambda: int(DIAGNOSE.base_bytes) // 2)
    t0 = time.perf_counter()
    assert main(["diagnose", str(src), "-q"]) == 2
    err = capsys.readouterr().err
    assert "hyst diagnose: error:" in err and "3,001 samples" in err
    assert "would need about" in err and "available" in err
    assert time.perf_counter() - t0 < 5  # refused before reading or fitting anything


def test_progress_lines_carry_the_time_left():
    lines: list[str] = []
    p = EtaProgress("diagnose", expected_s=100.0, sink=lines.append)
    p(" 10 % baseline: 25 operators")
    assert lines[-1].endswith("(about 2 min left)")
    p.t0 -= 95.0  # 95 s later
    p(" 50 % round 2: fitting lag")
    assert lines[-1].endswith("(about 5 s left)")
    p.t0 -= 10.0
    p(" 80 % round 3: fitting drift")
    assert lines[-1].endswith("(taking longer than the 2 min estimated)")
    p("100 % done")
    assert lines[-1].endswith("100 % done")
    p("read piezo: 50001 samples")  # not a step of the diagnosis
    assert lines[-1].endswith("50001 samples")
    quiet: list[str] = []
    EtaProgress("diagnose", 100.0, quiet=True, sink=quiet.append)("10 % x")
    assert quiet == []
