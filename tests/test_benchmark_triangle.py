"""The growing-triangle development recording (benchmarks/diagnosis/triangle.py) is what it
is for: one input rate throughout, the amplitude stepping up every two cycles, so that each
rising branch from a negative peak is visited twice, the second time going on to a larger
peak; its cases are development cases of a class of their own. Fast: no diagnosis runs."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.families import STROKE, make_base
from benchmarks.diagnosis.sealed import SEALED_CASES
from benchmarks.diagnosis.sets import CLASSES, DEV_CASES, build, case_class
from benchmarks.diagnosis.triangle import (
    TRIANGLE_AMPLITUDES,
    TRIANGLE_BASES,
    TRIANGLE_RATE,
    growing_triangle,
)


def test_one_rate_and_amplitudes_growing_every_two_cycles() -> None:
    t, u = growing_triangle()
    assert u[0] == 0.0 and u[-1] == pytest.approx(0.0)
    rate = np.abs(np.diff(u)) / np.diff(t)
    # every step at the one rate (a reversal sample's step is the same length on a
    # triangle whose legs are whole numbers of samples)
    assert np.allclose(rate, TRIANGLE_RATE, rtol=1e-9)
    d = np.sign(np.diff(u))
    peaks = u[1:-1][d[1:] != d[:-1]]
    amps = np.repeat(TRIANGLE_AMPLITUDES, 4) * np.tile([1.0, -1.0], 2 * len(TRIANGLE_AMPLITUDES))
    np.testing.assert_allclose(peaks, amps)
    # the rising branch from each negative peak but the last: twice, the second longer
    lows = np.flatnonzero(d[1:] > d[:-1]) + 1  # samples of the negative peaks
    legs = np.diff(np.r_[lows, u.size - 1])
    assert np.all(legs[1:-1:2] > legs[0:-2:2])


def test_triangle_cases_are_development_cases_of_their_own_class() -> None:
    cases = [c for c in DEV_CASES if c.startswith("dev/family-triangle/")]
    assert {c.split("/")[2] for c in cases} == set(TRIANGLE_BASES)
    assert sum("/null/" in c for c in cases) == 2 * len(TRIANGLE_BASES)
    assert sum("/drift/large/" in c for c in cases) == len(TRIANGLE_BASES)
    assert {case_class(c) for c in cases} == {"growing-triangle non-PI base"} <= set(CLASSES)
    assert not set(cases) & set(SEALED_CASES)
    null = build("dev/family-triangle/preisach/null/500")
    drift = build("dev/family-triangle/preisach/drift/large/500")
    assert [r.name for r in null.records] == ["triangle"]
    r = null.records[0]
    e = r.y - make_base("preisach")(r.u, dt=float(r.t[1] - r.t[0]))
    assert np.std(e) == pytest.approx(0.002 * STROKE, rel=0.05)
    # the drift case is the null plus the drift (the same noise), and its size is said
    dy = drift.records[0].y - r.y
    assert drift.concealment_pct == pytest.approx(np.max(np.abs(dy)) / STROKE * 100)
    assert null.concealment_pct == 0.0 and drift.concealment_pct > 0.5
