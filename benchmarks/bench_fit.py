"""Fitting speed and memory: streamed normal equations vs NNLS on the full design matrix.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_fit.py [--quick]``

Cases (n = 25 operators, input: decaying 5 Hz sine + 37 Hz + 211 Hz + 1 % noise, as in
``shared/notes/perf-baseline.md`` §5; output: a known PI model + noise):

1. ``stream``: :func:`core.fitting.gram.stream_gram` + :func:`solve_constrained` (the weight
   solve of every fit) at N = 1e6 — target ≤ 0.3 s and ≤ 100 MB peak above baseline.
2. ``regressor``: the full ``PIRegressor(n_operators=25).fit`` at N = 1e6, including the
   second (evaluation) pass with the inverse-model checks that fill ``report_``.
3. ``ratio``: the same weight solve against ``scipy.optimize.nnls`` on the full matrix
   ``[u, Y]`` (built with the numba play kernel), both at N = 2e5 in this run.

Each measurement runs in a fresh subprocess (so ``ru_maxrss`` is that case's own peak):
the data and a warm-up fit on 1e4 samples (numba, scipy import) come first, then the
baseline is recorded and the timed call runs. Times are the median of ``--repeat`` calls.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import resource
import subprocess
import sys
import time
import tracemalloc

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

N_OPS = 25


def make_data(N: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Input and output of a known PI model with 1 % noise (see module docstring)."""
    from core.pi import PIModel

    g = np.random.default_rng(seed)
    t = np.linspace(0.0, 10.0, N)
    u = (np.exp(-0.2 * t) * np.sin(2 * np.pi * 5 * t) + 0.2 * np.sin(2 * np.pi * 37 * t)
         + 0.1 * np.sin(2 * np.pi * 211 * t))
    u = u + 0.01 * g.normal(size=N)
    r = 0.9 * np.abs(u).max() * np.arange(1, N_OPS + 1) / N_OPS
    w = 0.5 * np.exp(-np.arange(N_OPS) / 8.0)
    w[::4] = 0.0
    y = PIModel(0.4, r, w)(u) + 1e-3 * g.normal(size=N)
    return u, y


def _maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def child(case: str, N: int, repeat: int) -> dict[str, float]:
    """Run one case in this process and return timings and memory."""
    from core.fitting.gram import Segment, solve_constrained, stream_gram
    from core.fitting.pi import PIRegressor
    from core.fitting.thresholds import place_thresholds

    u, y = make_data(N)
    uw, yw = make_data(10_000, seed=1)
    r = place_thresholds([u], N_OPS)
    lower = np.r_[-np.inf, 1e-4, np.zeros(N_OPS)]

    def stream() -> np.ndarray:
        G = stream_gram([Segment(u, y)], r)[0]
        return solve_constrained(lower, gram=G).theta

    def regressor() -> np.ndarray:
        est = PIRegressor(n_operators=N_OPS, validation=0.2).fit(u, y)
        return np.r_[est.p0_, est.weights_]

    def full_nnls() -> np.ndarray:
        import scipy.optimize

        from core import kernels

        A = np.empty((N, N_OPS + 1))
        Y = np.empty((N, N_OPS))
        kernels.play_matrix(u, r, np.full(N_OPS, u[0]), Y)
        A[:, 0] = u
        A[:, 1:] = Y
        return scipy.optimize.nnls(A, y - 1e-4 * u)[0]

    fn = {"stream": stream, "regressor": regressor, "nnls": full_nnls}[case]
    # warm-up on small data (compile, imports)
    PIRegressor(n_operators=N_OPS).fit(uw, yw)
    importlib.import_module("scipy.optimize")

    base = _maxrss_mb()
    times = []
    tracemalloc.start()
    peak_tm = 0.0
    for _ in range(repeat):
        tracemalloc.reset_peak()
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
        peak_tm = max(peak_tm, tracemalloc.get_traced_memory()[1] / 2**20)
    tracemalloc.stop()
    # one untraced run for the time (tracemalloc slows allocation-heavy code)
    t0 = time.perf_counter()
    fn()
    times.append(time.perf_counter() - t0)
    return {
        "case": case,
        "N": N,
        "time_s": float(np.median(times)),
        "time_min_s": float(np.min(times)),
        "tracemalloc_peak_mb": peak_tm,
        "maxrss_above_baseline_mb": _maxrss_mb() - base,
    }


def run_case(case: str, N: int, repeat: int) -> dict[str, float]:
    out = subprocess.run(
        [sys.executable, __file__, "--child", case, str(N), str(repeat)],
        check=True,
        capture_output=True,
        text=True,
        env={**os.environ, "OPENBLAS_NUM_THREADS": "1"},
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="smaller N (2e5 / 5e4), fewer repeats")
    p.add_argument("--child", nargs=3, metavar=("CASE", "N", "REPEAT"), help=argparse.SUPPRESS)
    a = p.parse_args()
    if a.child:
        print(json.dumps(child(a.child[0], int(a.child[1]), int(a.child[2]))))
        return
    big, small, rep = (200_000, 50_000, 3) if a.quick else (1_000_000, 200_000, 5)
    print(f"n = {N_OPS} operators, OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}")
    rows = [
        run_case("stream", big, rep),
        run_case("regressor", big, rep),
        run_case("stream", small, rep),
        run_case("nnls", small, max(1, rep // 2)),
    ]
    print(f"{'case':<10} {'N':>9} {'median s':>9} {'min s':>8} {'tracemalloc MB':>15} "
          f"{'maxrss+ MB':>11}")
    for r in rows:
        print(f"{r['case']:<10} {r['N']:>9} {r['time_s']:>9.4f} {r['time_min_s']:>8.4f} "
              f"{r['tracemalloc_peak_mb']:>15.2f} {r['maxrss_above_baseline_mb']:>11.1f}")
    s_big, reg, s_small, nn = rows
    print(f"ratio at N={small}: nnls(full A) time / streamed Gram time = "
          f"{nn['time_s'] / s_small['time_s']:.1f} (streamed is that many times faster); "
          f"memory {nn['tracemalloc_peak_mb']:.1f} MB vs {s_small['tracemalloc_peak_mb']:.2f} MB")
    ok_t = s_big["time_s"] <= 0.3
    ok_m = max(s_big["maxrss_above_baseline_mb"], s_big["tracemalloc_peak_mb"]) <= 100
    print(f"target at N={big}: weight solve <= 0.3 s: {'OK' if ok_t else 'MISSED'}; "
          f"peak memory <= 100 MB above baseline: {'OK' if ok_m else 'MISSED'}")


if __name__ == "__main__":
    main()
