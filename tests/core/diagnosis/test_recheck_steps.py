"""Acceptance rule 18 in the recheck of output dynamics (core.diagnosis.recheck): on the
shipped piezo recording (one input step, one rate: rule 15 keeps delay, lag and mode open),
the look-alike named first is the one its step shows, the others stay ambiguous, and the
finding says where the evidence came from. The references are the applied effects
(benchmarks.diagnosis.measured, development sizes)."""

from __future__ import annotations

import pytest

from benchmarks.diagnosis.measured import make_measured
from core.diagnosis import diagnose

DYNAMICS = ("delay", "lag", "resonance")


def _dynamics(case: str):
    res = diagnose(make_measured(case).records)
    return [e for e in res.effects if e.name in DYNAMICS]


@pytest.mark.slow
def test_a_dead_time_is_named_delay_and_stays_ambiguous_with_lag() -> None:
    # fails without rule 18: the 2 ms dead time was named lag (2.45 ms), flagged with delay
    (f,) = _dynamics("dev/measured/piezo/delay/large")
    assert f.name == "delay"
    assert "lag" in f.ambiguous_with
    # truth 2 ms plus the recording's own response to its step (~0.35 ms)
    assert f.parameters["delay_s"] == pytest.approx(2.35e-3, abs=0.25e-3)
    (words,) = [c for c in f.caveats if c.startswith("output dynamics after the input events")]
    assert "step at 3.26 s" in words and "dead time" in words and "suggestive" in words


@pytest.mark.slow
def test_a_lag_stays_lag_and_the_null_gets_no_dynamic_name() -> None:
    (f,) = _dynamics("dev/measured/piezo/lag/large")
    assert f.name == "lag" and "delay" in f.ambiguous_with
    assert _dynamics("dev/measured/piezo/null") == []
