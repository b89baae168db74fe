"""A single staircase recording of a plant without any hidden effect claims nothing
(issue 16, failure 4): before, 2 of 18 seeds (white 0.1 um, coloured) got ``drift`` with 15
operators; a single record shorter than a minute cannot tell a drift from slow sensor noise."""

from __future__ import annotations

import pytest

from benchmarks.diagnosis.generator import make_single_staircase
from core.diagnosis import diagnose
from core.diagnosis.effects.drift import SINGLE_DRIFT_S


@pytest.mark.parametrize(("noise", "seed"), [("white2", 2), ("coloured", 1)])
def test_single_staircase_null_claims_nothing(noise: str, seed: int) -> None:
    sc = make_single_staircase(None, noise, seed)
    assert sc.records[0].t[-1] - sc.records[0].t[0] < SINGLE_DRIFT_S
    res = diagnose(sc.records, n_operators=15)
    assert res.effects == []
    drift = [u for u in res.untestable if u.name == "drift"]
    assert drift and "slow sensor noise" in drift[0].reason
