"""Diagnoses that several test modules read, each run once a session (a diagnosis of the
same recordings with the same options is the same result).

Each test gets its own deep copy (about 7 ms for the four-recording set), so a test that
changes the result it was given (a list appended to, an array written) changes only its
copy: the next test, in this module or another, reads the diagnosis as it was run. The
originals (``_..._original``) are for the check that this holds
(test_results_json.py::test_each_test_gets_its_own_copy_of_a_shared_diagnosis)."""

from __future__ import annotations

import copy

import pytest

from core.diagnosis import diagnose
from core.diagnosis.results import DiagnosisResult


@pytest.fixture(scope="session")
def _weak_rate_set_original() -> DiagnosisResult:
    """The diagnosis behind :func:`weak_rate_set_diagnosis`, run once; no test reads it
    but the check of the copies."""
    from benchmarks.diagnosis.generator import make_periodic_set

    return diagnose(make_periodic_set(0.0006, seed=201).records)


@pytest.fixture(scope="session")
def _resonance_and_drift_original() -> DiagnosisResult:
    """The diagnosis behind :func:`resonance_and_drift_diagnosis`, run once."""
    from benchmarks.diagnosis.generator import make_combo

    return diagnose(make_combo(("resonance", "drift"), "white1", 100).records)


@pytest.fixture
def weak_rate_set_diagnosis(_weak_rate_set_original: DiagnosisResult) -> DiagnosisResult:
    """``diagnose`` with its defaults on the four short periodic recordings of a weakly
    rate-dependent plant (``make_periodic_set(0.0006, seed=201)``: loop area 3 % larger at
    the fastest rate than at the slowest), a copy of its own for each test: read by
    test_diagnosis_multi.py (rule 5) and test_results_json.py (several recordings
    round-trip)."""
    return copy.deepcopy(_weak_rate_set_original)


@pytest.fixture
def resonance_and_drift_diagnosis(_resonance_and_drift_original: DiagnosisResult
                                  ) -> DiagnosisResult:
    """``diagnose`` with its defaults on the resonance + drift combination
    (``make_combo(("resonance", "drift"), "white1", 100)``), a copy of its own for each
    test: read by test_diagnosis_multi.py (rule 6) and test_results_json.py (two effects
    round-trip)."""
    return copy.deepcopy(_resonance_and_drift_original)
