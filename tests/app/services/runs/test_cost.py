"""The up-front refusal model of a diagnosis against its measured peaks (issue 31)."""

from __future__ import annotations

import pytest

from app.services.runs.cost import DIAGNOSE

#: Peak resident memory of ``hyst diagnose FILE --json`` (one thread, /usr/bin/time; tilings
#: of the shipped piezo recording, the caches under their byte budget, main eb930e0;
#: docs/pages/diagnose.md "Scale", round 4): (samples, bytes)
MEASURED = [(25_000, 297e6), (50_001, 348e6), (100_000, 380e6), (400_000, 492e6),
            (1_000_000, 547e6), (4_000_000, 1299e6), (10_000_000, 2907e6)]


@pytest.mark.parametrize(("n", "peak"), MEASURED)
def test_the_diagnosis_model_is_above_every_measured_peak(n, peak) -> None:
    """The model never admits what would not fit: it predicts at least the measured peak
    plus 50 MB (the machine's load moved single peaks by a few tens of MB)."""
    assert DIAGNOSE.peak_bytes(n) >= peak + 50e6


def test_the_diagnosis_model_is_not_far_above_the_measurements() -> None:
    """Nor does it refuse what fits: it is within 250 MB + 20 % of the measured peak at every
    size (900 MB + 0.3 kB per sample, the model before the caches' budget, was 600 MB over
    at 25k and 1 GB over at 10M)."""
    for n, peak in MEASURED:
        assert DIAGNOSE.peak_bytes(n) <= 250e6 + 1.2 * peak, n
