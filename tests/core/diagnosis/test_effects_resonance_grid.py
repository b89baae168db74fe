"""The search grid of a lightly damped mode (core/diagnosis/effects/resonance.py; issue 30,
round 5): fine enough that a mode between grid points is not stepped over."""

from __future__ import annotations

import numpy as np
import pytest

from core.diagnosis import diagnose
from core.diagnosis.effects import resonance


def test_grid_neighbours_at_most_the_ratio_apart() -> None:
    for fmin, fmax in ((3.3, 3500.0), (2.0, 17.5), (100.0, 140.0)):
        fs = resonance.grid_frequencies(fmin, fmax)
        assert fs[0] == pytest.approx(fmin) and fs[-1] == pytest.approx(fmax)
        assert fs.size >= 7
        assert np.max(fs[1:] / fs[:-1]) <= resonance.GRID_RATIO * (1 + 1e-12)


@pytest.fixture(scope="module")
def pinched_with_a_mode() -> list:
    """A pinched structural element (Bouc-Wen-Baber-Noori; the bases of the diagnosis miss
    its loops by 3-5 % of range) with a 200 Hz mode after it, the benchmark's four
    recordings (development seed 500)."""
    from benchmarks.diagnosis.families import make_family

    return make_family("bouc-wen-baber-noori", "resonance", "large", seed=500).records


@pytest.mark.slow
def test_a_mode_between_grid_points_is_found_under_a_large_base_misfit(
        pinched_with_a_mode, monkeypatch) -> None:
    """Measured on the development set with the 7-point grid (3.3 Hz - 3.5 kHz, neighbours a
    factor 3.2 apart): nothing named, the search ended at 2.7 kHz with damping 0.7 (its
    points at 114 and 357 Hz lie outside the mode's basin, about 150-300 Hz here)."""
    res = diagnose(pinched_with_a_mode, effects=["resonance"])
    assert [e.name for e in res.effects] == ["resonance"]
    assert res.effects[0].parameters["freq_hz"] == pytest.approx(200.0, rel=0.1)
    # with the coarse grid the same diagnosis misses it: the grid is what finds it
    monkeypatch.setattr(resonance, "grid_frequencies",
                        lambda fmin, fmax: np.geomspace(fmin, fmax, 7))
    assert [e.name for e in diagnose(pinched_with_a_mode, effects=["resonance"]).effects] == []
