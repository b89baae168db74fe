"""Where a fit's fast leftover peaks across recordings at several input frequencies: at the
same frequency in hertz (a vibration of the device or its rig, or an interference) or at the
same multiple of the input frequency (a loop shape tied to the input's phase)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from core.diagnosis.adequacy import _physics_of
from core.fitting.entry import _left_text
from core.fitting.leftover import fast_across
from core.recordings import Recording

DT = 1e-3
F0S = (0.5, 1.0, 2.0)


def _plant(f0: float, ring_hz: float, seed: int = 0) -> tuple[np.ndarray, ...]:
    """Six cycles of an ``f0`` Hz sine, a friction-like prediction (plateaus while the input
    slides) and an output that rings at ``ring_hz`` once the plateau is reached, decaying over a
    tenth of the half cycle, plus noise."""
    t = np.arange(int(round(6 / f0 / DT))) * DT
    u = 0.5 * np.sin(2 * np.pi * f0 * t)
    pred = np.tanh(20 * np.gradient(u, DT) / (np.pi * f0))
    half = 0.5 / f0
    phase = np.mod(t - 0.7 * half, half)  # time since the plateau was reached
    ring = np.exp(-phase / (0.1 * half)) * np.sin(2 * np.pi * ring_hz * phase)
    noise = 0.002 * np.random.default_rng(seed).standard_normal(t.size)
    return u, pred + 0.2 * ring + noise, pred


def _across(ring: float | None) -> object:
    plants = [_plant(f0, ring if ring is not None else 60.0 * f0, k)
              for k, f0 in enumerate(F0S)]
    return fast_across([f"{f0} Hz" for f0 in F0S], [p[0] for p in plants],
                       [p[1] for p in plants], [p[2] for p in plants], [DT] * len(F0S))


def test_a_ringing_at_the_same_hertz_is_the_rigs_own_vibration() -> None:
    across = _across(45.0)
    assert across is not None
    assert all(abs(p - 45.0) < 3.0 for p in across.peak_hz)
    assert across.same_hz and not across.same_multiple
    assert min(across.flat_share) > 0.5
    assert ("at a fixed frequency (44.5-46 Hz) while the input frequency changes 4-fold: a "
            "vibration of the device or its rig, or an interference" in across.text())
    assert "loop shape" not in across.text()


def test_a_ringing_at_the_same_multiple_of_the_input_is_a_loop_shape() -> None:
    # 60 x the input frequency: 30, 60, 120 Hz (a ringing at the band's lower edge, 20 Hz, is
    # no interior peak: it cannot be told from a power falling with frequency)
    across = _across(None)
    assert across is not None
    assert all(abs(m - 60.0) < 3.0 for m in across.multiples)
    assert across.same_multiple and not across.same_hz
    assert "tied to the input's phase: a loop shape" in across.text()


def test_noise_above_a_slow_misfit_has_no_peak_to_compare() -> None:
    # the misfit is slow (a tenth of the loop height, at the input frequency) and the fast
    # part is white noise: its strongest bin is somewhere, at no frequency of the device
    plants = [_plant(f0, 45.0, k) for k, f0 in enumerate(F0S)]
    rng = np.random.default_rng(7)
    ys = [p[2] + 0.1 * np.sin(2 * np.pi * f0 * np.arange(p[0].size) * DT)
          + 0.05 * rng.standard_normal(p[0].size) for p, f0 in zip(plants, F0S, strict=True)]
    assert fast_across(["a", "b", "c"], [p[0] for p in plants], ys, [p[2] for p in plants],
                       [DT] * 3) is None


def test_a_recording_without_a_fast_part_is_left_out() -> None:
    plants = [_plant(f0, 45.0, k) for k, f0 in enumerate(F0S)]
    ys = [plants[0][2], plants[1][1], plants[2][1]]  # the 0.5 Hz one fitted exactly
    across = fast_across(["a", "b", "c"], [p[0] for p in plants], ys, [p[2] for p in plants],
                         [DT] * 3)
    assert across is not None and across.names == ("b", "c") and across.same_hz
    assert across.f0 == (1.0, 2.0)  # 2x apart: still compared


def test_one_input_frequency_or_no_fast_part_says_nothing() -> None:
    u, y, pred = _plant(1.0, 45.0)
    assert fast_across(["a", "b"], [u, u], [y, y], [pred, pred], [DT, DT]) is None
    quiet = [_plant(f0, 45.0) for f0 in F0S]
    assert fast_across(["a", "b", "c"], [p[0] for p in quiet], [p[2] for p in quiet],
                       [p[2] for p in quiet], [DT] * 3) is None


def _recordings() -> tuple[list[Recording], dict[int, np.ndarray]]:
    """The three plants ringing at 45 Hz as recordings, and their predictions by length."""
    recs, preds = [], {}
    for k, f0 in enumerate(F0S):
        u, y, pred = _plant(f0, 45.0, k)
        rec = Recording(u=u, y=y, t=np.arange(u.size) * DT, name=f"r{k}")
        recs.append(rec)
        preds[u.size] = pred
    return recs, preds


def test_the_fit_warning_says_it() -> None:
    recs, preds = _recordings()
    est = SimpleNamespace(predict=lambda u: preds[np.asarray(u).size], features_=object())
    text = _left_text(est, recs, [est.predict(r.u) for r in recs])
    assert "Across 3 recordings with the input at 0.5-2 Hz" in text
    assert "of that on the sliding plateaus" in text and "a vibration of the device" in text


def test_the_diagnosis_adequacy_text_says_it() -> None:
    recs, preds = _recordings()
    text = _physics_of(recs, SimpleNamespace(features_=None), [preds[r.u.size] for r in recs])
    assert "; across 3 recordings with the input at 0.5-2 Hz" in text
    assert "a vibration of the device or its rig, or an interference" in text


def _sawtooth_misfit(noise: float, seed: int) -> object:
    """Recordings at 1 and 2 Hz, three cycles each, whose misfit is a sawtooth tied to the
    input's phase (its harmonics' power falls with frequency) plus white noise."""
    from scipy.signal import sawtooth

    rng = np.random.default_rng(seed)
    us, es = [], []
    for f0 in (1.0, 2.0):
        t = np.arange(int(round(3 / f0 / DT))) * DT
        us.append(np.sin(2 * np.pi * f0 * t))
        es.append(0.05 * sawtooth(2 * np.pi * f0 * t) + noise * rng.standard_normal(t.size))
    zeros = [np.zeros_like(u) for u in us]
    return fast_across(["1 Hz", "2 Hz"], us, es, zeros, [DT, DT])


def test_a_misfit_falling_with_frequency_is_no_peak() -> None:
    # the band starts at 20 Hz in both recordings: a power falling with frequency is largest
    # at its lower edge in both, the same hertz by construction; it is no peak above the local
    # trend (without the rule: "peaks at 22.3, 20.7 Hz ... own vibration")
    for noise in (0.004, 0.008, 0.01):
        assert _sawtooth_misfit(noise, 0) is None


def test_white_noise_over_a_slow_misfit_rarely_gives_a_verdict() -> None:
    # three cycles at 1 and 2 Hz: white noise over a misfit at the input frequency. Without the
    # statistical threshold, 163 of 200 seeds gave a verdict (43 "vibration", 25 "loop shape");
    # with it, 0 of 200 (PEAK_ALPHA is 1 % a recording, and the halves must agree)
    verdicts = 0
    for seed in range(60):
        rng = np.random.default_rng(seed)
        us, ys, preds = [], [], []
        for f0 in (1.0, 2.0):
            t = np.arange(int(round(3 / f0 / DT))) * DT
            u = 0.5 * np.sin(2 * np.pi * f0 * t)
            pred = np.tanh(20 * np.gradient(u, DT) / (np.pi * f0))
            us.append(u)
            preds.append(pred)
            ys.append(pred + 0.1 * np.sin(2 * np.pi * f0 * t)
                      + 0.05 * rng.standard_normal(t.size))
        verdicts += fast_across(["a", "b"], us, ys, preds, [DT, DT]) is not None
    assert verdicts <= 1


def test_an_exact_triangle_input_does_not_crash() -> None:
    # |du| is the same on every row (0 at the vertices): no row moves the input more than the
    # 20th percentile, and there are no flat rows to name (this raised IndexError)
    from core.fitting.leftover import _flat_rows, leftover

    k = np.arange(6000)
    us = [np.abs(k % 1000 - 500) / 500.0, np.abs(k % 500 - 250) / 250.0]
    ys = [u + 0.01 * np.sin(2 * np.pi * 45.0 * k * DT) for u in us]
    assert not _flat_rows(us[0], us[0]).any()
    left = leftover(us[0], ys[0], us[0], DT)
    assert left is not None and left.flat_rows == 0.0
    across = fast_across(["1 Hz", "2 Hz"], us, ys, us, [DT, DT])
    assert across is None or across.flat_share == (0.0, 0.0)


def test_a_peak_in_one_half_of_a_record_only_is_not_compared() -> None:
    # the 45 Hz ringing stops halfway through every recording: the whole record shows it, its
    # second half does not, so it is no steady frequency of the device, the rig or the mains
    plants = [_plant(f0, 45.0, k) for k, f0 in enumerate(F0S)]
    ys = []
    for u, y, pred in plants:
        y = y.copy()
        y[u.size // 2:] = pred[u.size // 2:] + 0.002 * np.random.default_rng(3).standard_normal(
            u.size - u.size // 2)
        ys.append(y)
    assert fast_across(["a", "b", "c"], [p[0] for p in plants], ys, [p[2] for p in plants],
                       [DT] * 3) is None
