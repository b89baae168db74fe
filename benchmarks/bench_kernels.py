"""Kernel speed: ns per operator-update for the PI output and the operator matrix.

Measures, single-threaded, in one run:

* ``pi_output_fast`` (reassociated sum) and ``pi_output_strict`` (sequential sum), n = 25,
  N = 1e6, into a reused output buffer, with read-only thresholds/weights as the models pass
  them;
* ``play_matrix`` (N x n operator outputs) into a reused, already touched buffer;
* ``pi_batch`` with S = 8 parameter sets;
* ``PIModel.simulate`` (validation + allocation + fast kernel);
* the numpy per-sample loop of ``core.reference`` on a shorter record, scaled per update,
  as the baseline of the ratios;
* the first-call time of a fresh process: ``import core`` and the first PI evaluation with a
  warm numba cache (median of 3 subprocesses).

Targets (docs/pages/architecture.md, shared/notes/perf-baseline.md): PI output <= 1 ns/update and
>= 100x the numpy loop; first call <= 1.5 s. Input as in perf-baseline: a decaying 5 Hz
sine plus 37 Hz and 211 Hz components plus 1 % noise; ``r_i = i/n * 0.9 max|u|``.

Run: ``.venv/bin/python benchmarks/bench_kernels.py [--quick]`` (``--quick``: N = 1e5).
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from core import kernels  # noqa: E402
from core.pi import PIModel  # noqa: E402
from core.reference import pi_output_reference  # noqa: E402
from core.validation import frozen  # noqa: E402

TARGET_NS = 1.0
TARGET_RATIO = 100.0
TARGET_FIRST_CALL_S = 1.5

FIRST_CALL = """
import time
t0 = time.perf_counter()
import numpy as np
import core
from core.pi import PIModel
m = PIModel(0.72, [0.45, 0.9, 1.35], [0.6, 0.48, 0.36])
y = m(np.sin(np.linspace(0.0, 6.0, 1000)))
print(time.perf_counter() - t0)
"""


def test_input(N: int, seed: int = 0) -> np.ndarray:
    """Decaying 5 Hz sine + 37 Hz + 211 Hz + 1 % noise, sampled at 10 kHz."""
    t = np.arange(N) / 10_000.0
    rng = np.random.default_rng(seed)
    u = (np.exp(-t / max(t[-1], 1e-9)) * np.sin(2 * np.pi * 5 * t)
         + 0.3 * np.sin(2 * np.pi * 37 * t) + 0.1 * np.sin(2 * np.pi * 211 * t))
    return u + 0.01 * rng.standard_normal(N)


def first_call_seconds(runs: int = 3) -> tuple[float, float]:
    """Median (in-process time, process wall time) of fresh interpreters, cache warm."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-c", FIRST_CALL]
    subprocess.run(cmd, cwd=ROOT, env=env, check=True, capture_output=True)  # warm the cache
    inner, wall = [], []
    for _ in range(runs):
        t0 = time.perf_counter()
        out = subprocess.run(cmd, cwd=ROOT, env=env, check=True, capture_output=True,
                             text=True)
        wall.append(time.perf_counter() - t0)
        inner.append(float(out.stdout.strip().splitlines()[-1]))
    return statistics.median(inner), statistics.median(wall)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="N = 1e5 instead of 1e6")
    args = ap.parse_args()
    n = 25
    N = 100_000 if args.quick else 1_000_000
    N_np = 5_000 if args.quick else 20_000
    S, N_batch = 8, (20_000 if args.quick else 100_000)
    reps = 5 if args.quick else 7

    u = test_input(N)
    # read-only parameter arrays, as the models pass them (PIModel freezes its arrays)
    r = frozen(np.arange(1, n + 1) / n * 0.9 * np.max(np.abs(u)))
    w = frozen(np.random.default_rng(1).uniform(0.0, 1.0, n))
    p0 = 0.7
    y = np.empty(N)
    Y = np.empty((N, n))
    Y.fill(0.0)  # touch the buffer once so page faults are not timed

    model = PIModel(p0, r, w)
    ub = u[:N_batch]
    R = frozen(np.tile(r, (S, 1)) * np.linspace(0.8, 1.2, S)[:, None])
    W = frozen(np.tile(w, (S, 1)))
    P0 = frozen(np.full(S, p0))
    out_b = np.empty((S, N_batch))
    u_np = u[:N_np]
    # (label, callable, samples, updates per sample); timed round-robin so that machine
    # noise (frequency changes, neighbours) hits every case alike
    cases: list[tuple[str, Callable[[], object], int, int]] = [
        (f"PI output, fast (reassoc)   N={N:.0e} n={n}",
         lambda: kernels.pi_output_fast(u, r, w, p0, np.zeros(n), y), N, n),
        (f"PI output, strict           N={N:.0e} n={n}",
         lambda: kernels.pi_output_strict(u, r, w, p0, np.zeros(n), y), N, n),
        (f"operator matrix, reused buf N={N:.0e} n={n}",
         lambda: kernels.play_matrix(u, r, np.zeros(n), Y), N, n),
        (f"PI batch S={S}               N={N_batch:.0e} n={n}",
         lambda: kernels.pi_batch(ub, R, W, P0, np.zeros((S, n)), out_b), N_batch, S * n),
        (f"PIModel.simulate (alloc)    N={N:.0e} n={n}", lambda: model.simulate(u), N, n),
        (f"numpy per-sample loop       N={N_np:.0e} n={n}",
         lambda: pi_output_reference(u_np, r, w, p0, np.zeros(n)), N_np, n),
    ]
    for _, fn, _, _ in cases:
        fn()  # warm-up: compilation, first touch
    times: list[list[float]] = [[] for _ in cases]
    for _ in range(reps):
        for i, (_, fn, _, _) in enumerate(cases):
            t0 = time.perf_counter()
            fn()
            times[i].append(time.perf_counter() - t0)
    med = [statistics.median(ts) for ts in times]
    rows = [(name, m / (samples * ops) * 1e9) for (name, _, samples, ops), m in
            zip(cases, med, strict=True)]
    ns_np = rows[-1][1]

    print(f"kernel benchmark (numba {'on' if kernels.NUMBA_ENABLED else 'OFF'}, "
          f"NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}, median of {reps}, round-robin)")
    print(f"{'case':<46}{'ns/update':>11}{'x numpy':>10}{'ms/call':>10}")
    for (name, ns), m in zip(rows, med, strict=True):
        print(f"{name:<46}{ns:>11.3f}{ns_np / ns:>10.0f}{m * 1e3:>10.2f}")
    inner, wall = first_call_seconds()
    print(f"first call in a fresh process (import core + first PI evaluation, warm cache): "
          f"{inner:.3f} s in-process, {wall:.3f} s process wall time")
    fast_ns = rows[0][1]
    ok = [
        (f"PI output <= {TARGET_NS:g} ns/update", fast_ns <= TARGET_NS),
        (f"PI output >= {TARGET_RATIO:g}x numpy loop", ns_np / fast_ns >= TARGET_RATIO),
        (f"first call <= {TARGET_FIRST_CALL_S:g} s", inner <= TARGET_FIRST_CALL_S),
    ]
    for name, good in ok:
        print(f"target {name}: {'met' if good else 'MISSED'}")


if __name__ == "__main__":
    main()
