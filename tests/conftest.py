"""Shared fixtures."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"


#: Resident bytes of a ``hyst diagnose`` process when its diagnosis starts (the shipped piezo
#: recording, 50,001 samples, one thread; read from ``/proc/self/statm`` where the diagnosis
#: builds its cache: 214.5 MB with numpy 2.4.6, scipy 1.17.1, numba 0.68.1; the 209-224 MB
#: of docs/pages/diagnose.md, "Scale", at 25k-100k samples).
CLI_RESIDENT_BYTES = 215e6


@pytest.fixture(scope="session", autouse=True)
def _diagnosis_cache_budget_of_the_command_line():
    """The tests run the path the command line runs: a diagnosis's caches get the budget a
    lean ``hyst diagnose`` process gets (:data:`CLI_RESIDENT_BYTES` resident at its start,
    tens of MB at test sizes), not the one of this pytest process, whose imports (the app,
    plotly, viser, ...) already hold more than issue 31's target, which would leave a
    budget of 0 and every bank, level segment and projection recomputed. The caches do not
    change the findings (same summaries with and without; the base-choice ratios of the
    report agree to 4e-10 relative, the order of a few sums differs). The budget rule itself
    and the no-cache path keep their own tests (test_cache_budget.py,
    test_structure_memory.py), which set their own budgets with ``monkeypatch`` (undone to
    this one after each test)."""
    from core.diagnosis import cache_budget as cb
    from core.diagnosis import context as cx

    def budget(n_samples: int) -> float:
        return cb.cache_budget(n_samples, resident=CLI_RESIDENT_BYTES)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(cx, "cache_budget", budget)
        yield


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


# CI runs property tests with a fixed derandomized seed so a submission's result is
# reproducible; locally hypothesis explores new examples every run.
try:
    from hypothesis import settings as _hyp_settings

    _hyp_settings.register_profile("ci", derandomize=True, print_blob=True)
    if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
        _hyp_settings.load_profile("ci")
except ImportError:  # pragma: no cover - hypothesis is a dev dependency
    pass
