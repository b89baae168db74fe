"""The README's piezo diagnosis against a plain ``hyst fit`` of the same file, same run.

Targets (issue 8): the diagnosis ``hyst diagnose piezo_150V_1Hz.csv --train 3.3:7 --test 7:9``
in <= 10 s on an idle machine, and <= 6 times the wall time of ``hyst fit piezo_150V_1Hz.csv``
(default options: n chosen by cross-validation) measured in the same process, so that the
ratio survives other jobs on the machine. Both read the shipped copy of the file through
``core.csvio``; numba kernels are warmed up first.

::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnosis/bench_piezo_ratio.py [--repeat 1]

Prints wall times, their ratio and the load average before and after.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from core.csvio import read_csv  # noqa: E402
from core.datasets import DATA_DIR  # noqa: E402
from core.diagnosis import diagnose  # noqa: E402
from core.fitting import PIRegressor  # noqa: E402

FILE = DATA_DIR / "piezo" / "piezo_150V_1Hz.csv"
TARGET_S, TARGET_RATIO = 10.0, 6.0


def plain_fit() -> float:
    """``hyst fit FILE``: read, fit PI (n by cross-validation, last 20 % held out)."""
    t0 = time.perf_counter()
    (rec,) = read_csv(FILE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        PIRegressor(initial_memory="exclude").fit(rec.u, rec.y)
    return time.perf_counter() - t0


def diagnosis(progress: bool) -> float:
    """``hyst diagnose FILE --train 3.3:7 --test 7:9`` (default options)."""
    t0 = time.perf_counter()

    def say(frac: float, msg: str) -> None:
        if progress:
            print(f"  [{time.perf_counter() - t0:6.1f} s] {100 * frac:3.0f} % {msg}",
                  file=sys.stderr)

    diagnose(FILE, train=(3.3, 7.0), test=(7.0, 9.0), progress=say)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--progress", action="store_true", help="print the diagnosis' progress")
    a = ap.parse_args()
    load0 = os.getloadavg()
    (rec,) = read_csv(FILE)
    diagnose(rec.window(3.3, 3.9), effects=["lag"], n_operators=5, auto_resolution=False)
    fits, diags = [], []
    for _ in range(a.repeat):
        fits.append(plain_fit())
        diags.append(diagnosis(a.progress))
    load1 = os.getloadavg()
    f, d = float(np.median(fits)), float(np.median(diags))
    print(f"hyst fit (plain PI, n by CV): {f:.2f} s")
    print(f"hyst diagnose --train 3.3:7 --test 7:9: {d:.2f} s (target <= {TARGET_S:g} s idle)")
    print(f"ratio diagnosis / fit: {d / f:.1f} (target <= {TARGET_RATIO:g})")
    print(f"load average before {load0[0]:.2f}, after {load1[0]:.2f} (2 cores)")


if __name__ == "__main__":
    main()
