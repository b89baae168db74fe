"""Diagnoses that several test modules read, each run once a session (a diagnosis of the
same recordings with the same options is the same result; the tests only read it)."""

from __future__ import annotations

import pytest

from core.diagnosis import diagnose
from core.diagnosis.results import DiagnosisResult


@pytest.fixture(scope="session")
def weak_rate_set_diagnosis() -> DiagnosisResult:
    """``diagnose`` with its defaults on the four short periodic recordings of a weakly
    rate-dependent plant (``make_periodic_set(0.0006, seed=201)``: loop area 3 % larger at
    the fastest rate than at the slowest): read by test_diagnosis_multi.py (rule 5) and
    test_results_json.py (several recordings round-trip)."""
    from benchmarks.diagnosis.generator import make_periodic_set

    return diagnose(make_periodic_set(0.0006, seed=201).records)


@pytest.fixture(scope="session")
def resonance_and_drift_diagnosis() -> DiagnosisResult:
    """``diagnose`` with its defaults on the resonance + drift combination
    (``make_combo(("resonance", "drift"), "white1", 100)``): read by test_diagnosis_multi.py
    (rule 6) and test_results_json.py (two effects round-trip)."""
    from benchmarks.diagnosis.generator import make_combo

    return diagnose(make_combo(("resonance", "drift"), "white1", 100).records)
