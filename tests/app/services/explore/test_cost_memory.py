"""Issue 18, item 3: the priced memory of every registered type bounds its measured peak.

Memory, unlike time, is deterministic, so this is a unit test: every type of the model zoo
(plus the diagnosis's chains and their inverses, and a rate-dependent PI with many
operators, whose play outputs are a ``(samples, operators)`` matrix) simulates a moderate
input under :mod:`tracemalloc`, and the traced peak (numpy reports its buffers) must not
exceed the price summed over the model tree (:meth:`core.base.Model.cost`, as
``app.services.explore.cost.check_model`` sums it).
``benchmarks/bench_cost_memory.py`` checks the same at the explorer's 200,000-sample limit.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from app.services.explore.cost import priced_run
from core.base import Model
from core.stages import RateDependentPI
from tests.core.model_zoo import DIAGNOSED, DT, ZOO, traced_peak

#: Samples of the measured runs: large enough that sample arrays dominate fixed overheads.
N = 20_000
#: The stated factor: the traced peak is at most the priced memory times this.
FACTOR = 1.0

MODELS: dict[str, Model] = {
    **ZOO, **DIAGNOSED,
    # the diagnosed chains' inverses (the Inverse view of a diagnosed session), priced from
    # each inverse type's own cost
    **{f"{name} inverse": m.inverse() for name, m in DIAGNOSED.items()},
    "rate x20": RateDependentPI(1.0, np.linspace(0.1, 2.0, 20), np.full(20, 0.02), 2e-5),
}


@pytest.mark.parametrize("name", sorted(MODELS))
def test_priced_memory_bounds_the_traced_peak(name: str) -> None:
    m = MODELS[name]
    u = 3.0 * np.sin(np.linspace(0.0, 40.0 * np.pi, N))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        peak = traced_peak(m, u, DT)
    priced = priced_run(m, N, DT).memory
    assert peak > 0.9 * u.nbytes  # the output at least: the trace sees numpy's buffers
    assert peak <= FACTOR * priced, f"{name}: traced peak {peak:,} B > priced {priced:,.0f} B"
