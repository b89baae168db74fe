"""The loop's change from cycle to cycle under a repeated input, against the benchmark's
pinched element with and without its degradation (the generator is the reference)."""

from __future__ import annotations

import numpy as np

from benchmarks.diagnosis.families import make_base
from core.fitting.cyclechange import cycle_change, cycle_change_of
from core.pi import PIModel
from core.recordings import Recording

NOISE = 0.2


def _rec(plant, drift: float = 0.0, seed: int = 2) -> Recording:
    # 12 identical full-stroke cycles at 2 Hz from rest
    t = np.arange(0, 6.0, 5e-4)
    u = 75.0 - 75.0 * np.cos(2 * np.pi * 2.0 * t)
    y = plant(u) + drift * t + NOISE * np.random.default_rng(seed).standard_normal(t.size)
    return Recording(t, u, y, "cycles")


def test_a_degrading_element_shrinks_from_cycle_to_cycle() -> None:
    plant = make_base("bouc-wen-baber-noori", delta_nu=0.0005, delta_eta=0.0005)
    c = cycle_change_of(_rec(plant), NOISE)
    assert c is not None and c.changes
    assert c.per_cycle_pct < 0 and c.area_per_cycle_pct < 0
    # the generator's own loop sizes, noise-free, one 0.5 s input period (1000 samples)
    # each after the first two: the measured change per cycle is theirs
    rec = _rec(plant)
    clean = plant(rec.u)
    ptp = np.array([np.ptp(clean[k * 1000:(k + 1) * 1000]) for k in range(2, 12)])
    true_pct = 100 * np.polyfit(np.arange(ptp.size), ptp, 1)[0] / ptp.mean()
    assert abs(c.per_cycle_pct - true_pct) < 0.3 * abs(true_pct)
    assert "softening / degrading" in c.text()


def test_the_same_element_without_degradation_repeats_its_loop() -> None:
    c = cycle_change_of(_rec(make_base("bouc-wen-baber-noori")), NOISE)
    assert c is not None and not c.changes and c.text() == ""


def test_a_drift_moves_the_mean_not_the_shape() -> None:
    # a PI plant (repeats exactly) with a drift of 2 output units per second: the mean
    # moves from cycle to cycle, the loop's size does not
    plant = PIModel(0.3, [5.0, 20.0, 40.0], [0.4, 0.3, 0.2])
    c = cycle_change_of(_rec(plant, drift=2.0), NOISE)
    assert c is not None and not c.changes
    assert abs(c.mean_per_cycle - 1.0) < 0.1  # 2 units/s over a 0.5 s cycle


def test_no_repeated_cycles_no_test() -> None:
    t = np.arange(0, 3.0, 1e-3)
    u = 75.0 - 75.0 * np.exp(-t) * np.cos(2 * np.pi * t)
    assert cycle_change([Recording(t, u, u.copy(), "decaying")], NOISE) is None


def test_without_a_time_axis_the_cycles_are_given_by_their_samples() -> None:
    from dataclasses import replace

    plant = make_base("bouc-wen-baber-noori", delta_nu=0.0005, delta_eta=0.0005)
    rec = _rec(plant)
    said = cycle_change_of(replace(rec, t=np.arange(rec.n_samples, dtype=float),
                                   has_time=False), NOISE).text()
    assert "cycles from sample " in said and "t = " not in said
    assert "cycles from t = " in cycle_change_of(rec, NOISE).text()
