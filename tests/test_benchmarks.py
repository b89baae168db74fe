"""Benchmark scripts keep running (smoke test in quick mode; no timing is asserted here)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
#: bench_batch.py starts two LocalClusters and fits its recordings three times; a smoke run
#: needs every step once, not --quick's 20 recordings (~45 s): 4 recordings in 2 rounds.
SCRIPTS = ["bench_kernels.py", "bench_fit.py", "bench_app_latency.py",
           pytest.param("bench_batch.py", marks=pytest.mark.slow)]
ARGS = {"bench_batch.py": ["--count", "4", "--rounds", "2"]}


@pytest.mark.parametrize("script", SCRIPTS)
def test_benchmark_runs_in_quick_mode(script: str) -> None:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / script), *ARGS.get(script, ["--quick"])],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-4000:]
    assert "target" in proc.stdout  # every script reports its targets
