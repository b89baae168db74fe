"""Does the priced memory bound the measured peak memory? (issue 18, item 3)

Every registered model type prices its run's peak memory (:attr:`core.base.RunCost.memory`,
output array included, input excluded: the caller holds it), summed over the model tree as
:func:`app.services.explore.cost.check_model` does. This benchmark simulates every type of
``tests/core/model_zoo.py``, the chains the diagnosis writes and their inverses, and the
scaled-up instances of
``bench_cost.py`` on :data:`N` samples (the explorer's sample limit) and measures the peak of
``simulate`` with :mod:`tracemalloc` (numpy reports its array buffers to it). The price is a
bound when every ``peak / priced`` ratio is at most 1; the exit status says whether it is.

Memory is deterministic, so one run is enough (no repeats, no single-threading needed)::

    PYTHONPATH=. .venv/bin/python benchmarks/bench_cost_memory.py

Not seen by tracemalloc: buffers allocated inside numba-compiled kernels (none of the
model kernels allocate sample-length arrays; they write into arrays allocated by numpy).
"""

from __future__ import annotations

import sys
import warnings

import numpy as np

from app.services.explore.cost import priced_run
from benchmarks.bench_cost import _scaled, diagnosed_inverses
from core.base import Model
from tests.core.model_zoo import DIAGNOSED, DT, ZOO, traced_peak

#: Samples of the measured runs (the explorer's ``Limits.max_samples``).
N = 200_000


def measure(n: int = N, models: dict[str, Model] | None = None) -> dict[str, tuple[int, float]]:
    """``name -> (measured peak bytes, priced bytes)`` for every model."""
    u = 3.0 * np.sin(np.linspace(0.0, 40.0 * np.pi, n))
    if models is None:
        models = {**ZOO, **DIAGNOSED, **_scaled(), **diagnosed_inverses()}
    out: dict[str, tuple[int, float]] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, m in models.items():
            out[name] = (traced_peak(m, u, DT), priced_run(m, n, DT).memory)
    return out


def main() -> int:
    rows = measure()
    for name, (peak, priced) in sorted(rows.items(), key=lambda kv: -kv[1][0] / kv[1][1]):
        print(f"{name:<28} peak {peak / 1e6:8.2f} MB  priced {priced / 1e6:8.2f} MB  "
              f"ratio {peak / priced:5.2f}")
    worst = max(rows, key=lambda k: rows[k][0] / rows[k][1])
    ratio = rows[worst][0] / rows[worst][1]
    ok = ratio <= 1.0
    print(f"worst: {worst} peak / priced = {ratio:.2f} ({'within' if ok else 'ABOVE'} 1)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
