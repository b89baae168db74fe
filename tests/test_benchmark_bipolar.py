"""The bipolar development recordings (benchmarks/diagnosis/bipolar.py) do what they are for:
inputs through 0 V within ±150 V that grow in amplitude, the stress-strain plants driven
into both yield directions with clockwise, pinched loops, the scenarios built as the plant
plus noise plus the hidden effect, and their cases registered in the development set with
a class of their own. Fast: no diagnosis runs here."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.bipolar import (
    BIPOLAR_RECORDINGS,
    SIGNAL_SEED,
    bipolar_signals,
    make_bipolar,
)
from benchmarks.diagnosis.families import STROKE, family_signals, make_base
from benchmarks.diagnosis.sealed import SEALED_CASES, SEALED_SEEDS
from benchmarks.diagnosis.sets import CLASSES, DEV_CASES, build, case_class


def signed_area(u: np.ndarray, y: np.ndarray) -> float:
    """Shoelace area of the closed path (u, y): > 0 counter-clockwise, < 0 clockwise."""
    return float(0.5 * (np.dot(u, np.roll(y, -1)) - np.dot(y, np.roll(u, -1))))


def _signals() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    return {n: (t, u) for n, t, u in bipolar_signals()}


def test_recordings_swing_both_ways_within_the_range() -> None:
    sig = _signals()
    assert tuple(sig) == BIPOLAR_RECORDINGS
    for name, (t, u) in sig.items():
        assert np.all(np.diff(t) > 0), name
        assert np.max(np.abs(u)) <= 150.0 + 1e-9, name
        # through 0 V both ways by at least a fifth of the range
        assert u.min() < -30.0 and u.max() > 30.0, name
        assert u[0] == pytest.approx(0.0, abs=1e-9), name  # from the virgin state
    # the development set's own recordings are all unipolar: these are a new excitation
    assert all(u.min() >= 0.0 for _, _, u in family_signals())


def test_growing_recording_grows_cycle_by_cycle_and_reversals_hold() -> None:
    sig = _signals()
    t, u = sig["growing"]
    # peaks of the positive half-cycles, in order: never smaller, five distinct amplitudes
    up = np.flatnonzero((u[1:-1] > u[:-2]) & (u[1:-1] >= u[2:]) & (u[1:-1] > 0)) + 1
    peaks = u[up]
    assert np.all(np.diff(peaks) > -1e-6)
    assert len(np.unique(np.round(peaks))) == 5 and peaks[-1] == pytest.approx(150.0, rel=1e-3)
    t, u = sig["reversals"]
    still = np.abs(np.diff(u)) < 1e-12
    # at least four holds of a second or more
    runs = np.diff(np.flatnonzero(np.diff(np.r_[0, still.astype(int), 0])))[::2]
    assert np.sum(runs * (t[1] - t[0]) >= 1.0) >= 4
    # reversals change sign: the targets alternate around 0 V
    d = np.sign(np.diff(u[~np.r_[still, False]]))
    assert np.sum(d[1:] != d[:-1]) >= 10
    assert SIGNAL_SEED not in SEALED_SEEDS and 0 <= SIGNAL_SEED < 2000


def test_steel_yields_both_ways_with_clockwise_loops() -> None:
    t, u = _signals()["growing"]
    mp = make_base("menegotto-pinto")
    stress = mp.stress(mp.strain_max * u / 150.0)  # MPa
    assert stress.max() > 0.95 * mp.fy and stress.min() < -0.95 * mp.fy
    last = slice(u.size - int(round(1 / 2.5 / (t[1] - t[0]))), u.size)  # the last cycle
    assert signed_area(u[last], stress[last]) < 0.0


def test_pinched_element_is_pinched_on_the_bipolar_cycle() -> None:
    t, u = _signals()["growing"]
    el = make_base("bouc-wen-baber-noori")
    x = el.x_max * u / 150.0
    f = el.force(x)
    n = int(round(1 / 2.5 / (t[1] - t[0])))
    xl, fl = x[-n:], f[-n:]
    k = np.diff(fl) / np.diff(xl)
    # the secant stiffness where the force crosses 0 against the one just after the reversal
    # at the top of the cycle (largest displacement)
    top = int(np.argmax(xl))
    after = k[top + 2: top + 8]
    cross = k[np.flatnonzero(np.diff(np.sign(fl)) != 0)]
    assert cross.size >= 2
    assert np.max(np.abs(cross)) < 0.35 * np.min(np.abs(after))
    assert signed_area(xl, fl) < 0.0  # clockwise


def test_null_is_the_plant_plus_the_stated_noise_and_a_delay_shifts_it() -> None:
    null = make_bipolar("bouc-wen-1", None, seed=500)
    delayed = make_bipolar("bouc-wen-1", "delay", seed=500)
    p = make_base("bouc-wen-1")
    for rn, rd in zip(null.records, delayed.records, strict=True):
        y0 = p(rn.u, dt=float(rn.t[1] - rn.t[0]))
        e = rn.y - y0
        assert np.std(e) == pytest.approx(0.002 * STROKE, rel=0.05), rn.name
        # the noise depends on the seed only: the difference is the delayed clean output
        # minus the clean output, here against linear interpolation at t - 1 ms
        ref = np.interp(rn.t - 1e-3, rn.t, y0, left=y0[0]) - y0
        np.testing.assert_allclose(rd.y - rn.y, ref, atol=1e-6 * STROKE, err_msg=rn.name)
    assert null.extras["excitation"] == "bipolar"


def test_bipolar_cases_are_development_cases_of_their_own_class() -> None:
    cases = [c for c in DEV_CASES if c.startswith("dev/family-bipolar")]
    bases = {"menegotto-pinto", "bouc-wen-baber-noori", "bouc-wen-1"}
    assert {c.split("/")[2] for c in cases} == bases
    groups = {b: [c for c in cases if c.split("/")[2] == b] for b in bases}
    for b, cs in groups.items():
        # four effects, two nulls, five single recordings
        assert sum("/large/" in c for c in cs) == 4, b
        assert sum("/null/" in c for c in cs) == 2, b
        assert sum(c.startswith("dev/family-bipolar-single/") for c in cs) == 5, b
    assert {case_class(c) for c in cases} == {"bipolar non-PI base",
                                              "single-recording bipolar null"}
    assert {"bipolar non-PI base", "single-recording bipolar null"} <= set(CLASSES)
    assert not set(cases) & set(SEALED_CASES)
    sc = build("dev/family-bipolar-single/menegotto-pinto/reversals/500")
    assert [r.name for r in sc.records] == ["reversals"]
    assert min(sc.records[0].u) < 0.0
    with pytest.raises(ValueError, match="unknown recording"):
        build("dev/family-bipolar-single/menegotto-pinto/slow/500")
