"""Masing's rule on the recordings: the branch after the first reversal against the first
loading doubled, checked against plants built elsewhere (the benchmark's generators)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.families import family_signals, make_base
from core.fitting.masing import MASING_SHARE, masing
from core.pi import PIModel
from core.recordings import Recording

NOISE = 0.2


def _records(plant, seed: int = 1) -> list[Recording]:
    rng = np.random.default_rng(seed)
    out = []
    for name, t, u in family_signals()[:3]:  # slow, fast, decaying: first loading from rest
        y = plant(u)
        out.append(Recording(t, u, y + NOISE * rng.standard_normal(y.size), name))
    return out


def test_a_pi_plant_follows_masing_exactly() -> None:
    # the PI's reversal branch is its first loading doubled (Masing's rule holds exactly for
    # play operators): the departure is the noise, far below the rule
    plant = PIModel(0.3, [5.0, 20.0, 40.0], [0.4, 0.3, 0.2])
    m = masing(_records(plant), NOISE)
    assert len(m.checks) == 3
    assert not m.non_masing and m.text() == ""
    assert m.departure_pct < 0.2 * 100 * MASING_SHARE


@pytest.mark.parametrize("base", ["maxwell-slip", "bouc-wen-1"])
def test_masing_like_plants_are_not_called_non_masing(base: str) -> None:
    m = masing(_records(make_base(base)), NOISE)
    assert m.checks and not m.non_masing


def test_menegotto_pinto_steel_is_non_masing_and_said_so() -> None:
    # Menegotto-Pinto: transition curvature R0 = 20 on the first loading, rounded after a
    # plastic excursion (R falls with it): the reversal branch is far from the doubled
    # first loading
    m = masing(_records(make_base("menegotto-pinto")), NOISE)
    assert m.non_masing and not m.pinched
    assert m.departure_pct > 100 * MASING_SHARE
    said = m.text({"input": "V", "output": "um"})
    assert said.startswith("non-Masing")
    assert "changes with the size of the previous excursion" in said
    assert " V of input travel" in said


def test_the_same_steel_without_its_curvature_change_is_not_non_masing() -> None:
    # the reference the test must be able to fail on: with cR1 = 0 the curvature is R0 on
    # every branch, and the steel's branches are Masing's (kinematic hardening, one shape)
    m = masing(_records(make_base("menegotto-pinto", cr1=0.0)), NOISE)
    assert not m.non_masing


def test_a_pinched_element_is_non_masing_and_pinched() -> None:
    m = masing(_records(make_base("bouc-wen-baber-noori")), NOISE)
    assert m.non_masing and m.pinched
    assert "pinched" in m.text()


def test_a_recording_that_starts_on_its_steady_loop_is_not_tested() -> None:
    # the input starts at the top of a repeated cycle: the first loading is a piece of the
    # steady loop, not a virgin curve, and Masing's rule cannot be read from it
    plant = make_base("menegotto-pinto")
    t = np.arange(0, 4.0, 1e-3)
    u = 75.0 + 75.0 * np.cos(2 * np.pi * t)
    warm = np.concatenate([75.0 + 75.0 * np.cos(2 * np.pi * np.arange(0, 2.0, 1e-3) + np.pi),
                           u])
    y = plant(warm)[-u.size:]
    m = masing([Recording(t, u, y, "steady")], NOISE)
    assert m.checks == () and not m.non_masing


def test_without_a_time_axis_the_reversal_is_given_by_its_sample() -> None:
    from dataclasses import replace

    recs = [replace(r, t=np.arange(r.n_samples, dtype=float), has_time=False)
            for r in _records(make_base("menegotto-pinto"))]
    said = masing(recs, NOISE).text({"input": "V", "output": "um"})
    assert "after the reversal at sample " in said and "t = " not in said
