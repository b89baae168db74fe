"""The residual spectrum of a long record averaged over chunks of Welch segments (issue 31:
bounded memory) against scipy's Welch and coherence on the whole record."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as ss

from core.diagnosis import locate


@pytest.mark.parametrize("chunk", [2**12, 2**14, 2**20])
def test_chunked_welch_and_coherence_equal_scipy_on_the_whole_record(monkeypatch, chunk):
    rng = np.random.default_rng(3)
    n, fs, nper = 200_003, 5000.0, 2**12
    t = np.arange(n) / fs
    u = np.sin(2 * np.pi * 3 * t) + 0.1 * rng.standard_normal(n)
    e = 0.02 * np.sin(2 * np.pi * 170 * t + 0.3) + 0.3 * u * 0.01 + 0.01 * rng.standard_normal(n)
    monkeypatch.setattr(locate, "SPECTRUM_CHUNK", chunk)
    f, P, C = locate._welch_in_chunks(u, e - e.mean(), fs, nper)
    f0, P0 = ss.welch(e - e.mean(), fs=fs, nperseg=nper)
    _, C0 = ss.coherence(u, e, fs=fs, nperseg=nper)
    np.testing.assert_array_equal(f, f0)
    np.testing.assert_allclose(P, P0, rtol=1e-10, atol=0)
    np.testing.assert_allclose(C, C0, rtol=1e-8, atol=1e-12)
