"""A lightly damped mode the input does not excite (core.diagnosis.residualpeak): said
untestable, with its frequency and the experiment that would decide, instead of nothing.

Synthetic: a slow sine through a friction-like (tanh) loop plus broadband "chatter" the base
cannot predict, with and without a 45 Hz mode on the output. Measured: the shipped 36 lb
friction damper (1 Hz tapered sine) with a 45 Hz mode applied to its measured output, the
unmodified recording as the null (benchmarks.diagnosis.measured)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from benchmarks.diagnosis import output_effects as oe
from benchmarks.diagnosis.measured import make_measured
from core.diagnosis.residualpeak import (
    FREQ_AGREE,
    LIGHT_DAMPING,
    fit_mode,
    peak_in,
    residual_peak,
    untestable_entry,
)
from core.fitting.cycles import line_hz
from core.recordings import Recording

DT = 1.0 / 1024


def _plant(seed: int, mode_hz: float | None) -> tuple[Recording, np.ndarray]:
    """A 1 Hz sine into a friction-like loop (its prediction) and the measured output: the
    loop plus unpredictable broadband chatter, through a 0.04-damped mode if given."""
    rng = np.random.default_rng(seed)
    t = np.arange(8192) * DT
    u = np.sin(2 * np.pi * t)
    yh = np.tanh(8 * np.gradient(u, DT) / (2 * np.pi))  # plateaus switching at reversals
    y = yh + 0.02 * rng.standard_normal(t.size)
    if mode_hz is not None:
        y = oe.mode(y, mode_hz, 0.04, DT)
    return Recording(t, u, y, "sim"), yh


def test_peak_found_only_with_the_mode() -> None:
    rec, yh = _plant(1, 45.0)
    pk = residual_peak([rec], [yh])
    assert pk is not None
    assert abs(pk.freq_hz - 45.0) <= FREQ_AGREE * 45.0
    assert pk.damping <= LIGHT_DAMPING + 0.05
    assert pk.halves == 2
    assert pk.driven < 0.5
    e = untestable_entry(pk)
    assert e.name == "resonance" and "no energy" in e.reason and "sweep" in e.experiment
    assert e.parameters == {"freq_hz": pk.freq_hz, "damping": pk.damping}
    assert e.to_dict() == {"name": e.name, "reason": e.reason, "experiment": e.experiment}
    # the same chatter without the mode: white, no peak
    rec0, yh0 = _plant(1, None)
    assert residual_peak([rec0], [yh0]) is None


def test_frequency_and_damping_from_the_peaks_shape() -> None:
    """A 45.3 Hz mode (damping 0.01) on three recordings of 32 s of a 1 Hz sine: the peak's
    bin (1 s segments) reads 45.0 Hz (0.3 Hz, 0.66 % off); the fit of the mode's shape to
    the records' finest spectra (Hann-tapered, between the input's harmonics) recovers
    45.3 Hz within 0.15 Hz and the damping within 30 %. The tolerance is three times the
    fit's own spread (0.086 Hz RMS over 12 single recordings, so about 0.05 Hz for three;
    the Cramer-Rao bound for white chatter, sqrt(zeta f / (2 pi T)) per recording, is
    0.047 Hz untapered); the width of a peak narrower than a bin is the window's."""
    recs, preds = [], []
    for seed in range(3):
        rng = np.random.default_rng(40 + seed)
        t = np.arange(32 * 1024) * DT
        u = np.sin(2 * np.pi * t)
        yh = np.tanh(8 * np.gradient(u, DT) / (2 * np.pi))
        y = oe.mode(yh + 0.02 * rng.standard_normal(t.size), 45.3, 0.01, DT)
        recs.append(Recording(t, u, y, f"s{seed}"))
        preds.append(yh)
    pk = residual_peak(recs, preds)
    assert pk is not None
    assert abs(pk.bin_hz - 45.3) > 0.15  # the one-bin estimate fails the tolerance
    assert abs(pk.freq_hz - 45.3) <= 0.15
    assert abs(pk.damping - 0.01) <= 0.3 * 0.01


def test_fit_mode_leaves_the_harmonics_out() -> None:
    """The lines of a periodic input's harmonics near the peak (the misfit the base repeats
    every cycle, amplified by the mode) are left out of the fit: a strong line at 46 Hz
    beside a 45.3 Hz mode does not move it (kept in, it pulls the fit towards 46 Hz)."""
    rng = np.random.default_rng(7)
    t = np.arange(16 * 1024) * DT
    e = oe.mode(0.02 * rng.standard_normal(t.size), 45.3, 0.02, DT)
    line = 0.2 * np.sin(2 * np.pi * 46.0 * t)
    fu = line_hz(np.sin(2 * np.pi * t), DT)
    assert abs(fu - 1.0) < 1e-4
    fits = [fit_mode([(x, DT, u1)], 46.0, 0.03)
            for x, u1 in ((e, fu), (e + line, fu), (e + line, 0.0))]  # last: harmonics kept in
    assert all(g is not None for g in fits)
    (f_clean, _), (f, _), (f_in, _) = fits  # type: ignore[misc]
    assert abs(f - f_clean) <= 0.02
    assert f_in - f_clean > 0.2


def test_fit_mode_says_when_it_fitted_nothing() -> None:
    """Too few bins in the band (a short record) is no fit: ``None``, not the starting
    values handed back as if they had been measured."""
    rng = np.random.default_rng(3)
    e = oe.mode(0.02 * rng.standard_normal(256), 45.3, 0.02, DT)
    assert fit_mode([(e, DT, 0.0)], 46.0, 0.03) is None


def test_broad_peak_is_not_a_mode() -> None:
    """Chatter through a well-damped (0.3) resonance peaks, but not like a light mode; chatter
    over an octave (30-60 Hz, flat) stands far above its surroundings, but is too wide for one."""
    import scipy.signal as ss

    rec, yh = _plant(2, None)
    wide = yh + oe.mode(rec.y - yh, 45.0, 0.3, DT)
    assert peak_in(wide - yh, DT, 5.0) is None
    assert residual_peak([Recording(rec.t, rec.u, wide, "w")], [yh]) is None
    sos = ss.butter(8, [30.0, 60.0], btype="bandpass", fs=1 / DT, output="sos")
    band = 0.001 * (rec.y - yh) + ss.sosfiltfilt(sos, rec.y - yh)
    assert peak_in(band, DT, 5.0) is None
    assert residual_peak([Recording(rec.t, rec.u, yh + band, "b")], [yh]) is None


def test_both_halves_must_show_it() -> None:
    """A mode in the first half only (an event in one stretch) is not confirmed by the other."""
    rec, yh = _plant(3, None)
    y = rec.y.copy()
    h = y.size // 2
    y[:h] = yh[:h] + oe.mode(rec.y[:h] - yh[:h], 45.0, 0.04, DT)
    assert peak_in(y[:h] - yh[:h], DT, 5.0) is not None
    assert residual_peak([Recording(rec.t, rec.u, y, "h")], [yh]) is None
    # a peak in each half, at 45 and at 30 Hz: not one mode
    y = y.copy()
    y[h:] = yh[h:] + oe.mode(rec.y[h:] - yh[h:], 30.0, 0.04, DT)
    assert peak_in(y[h:] - yh[h:], DT, 5.0) is not None
    assert residual_peak([Recording(rec.t, rec.u, y, "h")], [yh]) is None


def _halves_with_mode(seed: int, with_mode: tuple[bool, bool]) -> tuple[Recording, np.ndarray]:
    rec, yh = _plant(seed, None)
    y = rec.y.copy()
    h = y.size // 2
    for k, on in enumerate(with_mode):
        s = slice(0, h) if k == 0 else slice(h, None)
        if on:
            y[s] = yh[s] + oe.mode(rec.y[s] - yh[s], 45.0, 0.04, DT)
    return Recording(rec.t, rec.u, y, f"r{seed}"), yh


def test_two_thirds_of_the_halves_of_several_recordings() -> None:
    """Three recordings: the mode in 5 of 6 halves is found (one half's own misfit may hide
    it), in 3 of 6 it is not."""
    five = [_halves_with_mode(10 + i, m) for i, m in
            enumerate([(True, True), (True, True), (True, False)])]
    pk = residual_peak([r for r, _ in five], [p for _, p in five])
    assert pk is not None and (pk.halves, pk.of_halves) == (5, 6)
    three = [_halves_with_mode(10 + i, m) for i, m in
             enumerate([(True, True), (True, False), (False, False)])]
    assert residual_peak([r for r, _ in three], [p for _, p in three]) is None


def test_driven_band_is_left_to_the_candidate() -> None:
    """Where the base's prediction carries the band (the input excites the mode), the peak is
    not said untestable: the resonance candidate's own verdict stands."""
    rec, yh = _plant(4, 45.0)
    t = rec.t
    drive = 2.0 * np.sin(2 * np.pi * 45.0 * t)
    yh2 = yh + drive
    y2 = rec.y + oe.mode(drive, 45.0, 0.04, DT)
    assert residual_peak([Recording(t, rec.u, y2, "d")], [yh2]) is None


def test_a_suggested_resonance_is_not_also_untestable() -> None:
    """One statement about a resonance: when the search suggested one (an improvement that
    failed the significance rules, or the ringing after too few input steps), the input did
    test it, so the residual's peak adds no "untestable" entry that would contradict the
    suggestion; another suggested effect leaves the entry, with its fitted parameters."""
    from core.diagnosis.engine import _unexcited_mode

    rec, yh = _plant(1, 45.0)
    (said,) = _unexcited_mode([rec], [yh], [], ["resonance"], ["delay"])
    assert said.name == "resonance" and set(said.parameters) == {"freq_hz", "damping"}
    assert _unexcited_mode([rec], [yh], [], ["resonance"], ["delay", "resonance"]) == []
    assert _unexcited_mode([rec], [yh], [], ["delay"], []) == []  # resonance not tested


@pytest.mark.slow
def test_friction_damper_mode_said_untestable() -> None:
    """36 lb damper: the 45 Hz mode is neither named nor silent; the null says nothing new."""
    from core.diagnosis import diagnose

    res = diagnose(make_measured("dev/measured/friction-36lb/resonance/mid").records)
    assert "resonance" not in [e.name for e in res.effects]
    said = [u for u in res.untestable if u.name == "resonance"]
    assert len(said) == 1
    m = re.search(r"about ([0-9.]+) Hz", said[0].reason)
    assert m is not None
    hz = float(m.group(1))
    assert abs(hz - 45.0) <= FREQ_AGREE * 45.0  # the applied mode's frequency
    null = diagnose(make_measured("dev/measured/friction-36lb/null").records)
    assert not null.effects
    assert "resonance" not in [u.name for u in null.untestable]


def test_a_non_finite_residual_shows_no_peak() -> None:
    """A residual with one NaN (a prediction that went non-finite) has no finite width or
    prominence: it is no mode (before, both comparisons were false for NaN and it passed as
    one, with damping NaN)."""
    rec, yh = _plant(3, None)
    e = rec.y - yh
    e[100] = np.nan
    assert peak_in(e, DT, 5.0) is None


def _line_plant(input_hz: float, seconds: float = 8.0) -> tuple[Recording, np.ndarray]:
    """A sine of ``input_hz`` into the friction-like loop, broadband chatter and a pure
    50 Hz line (an interference: no width at all) on the output."""
    rng = np.random.default_rng(1)
    t = np.arange(int(seconds / DT)) * DT
    u = np.sin(2 * np.pi * input_hz * t)
    yh = np.tanh(8 * np.gradient(u, DT) / (2 * np.pi * input_hz))
    y = yh + 0.02 * rng.standard_normal(t.size) + 0.05 * np.sin(2 * np.pi * 50.0 * t)
    return Recording(t, u, y, "line"), yh


def test_a_line_narrower_than_the_record_gets_a_bound_not_a_damping() -> None:
    """A pure 50 Hz line over 8 s (0.125 Hz bins): the fit of its shape gives a half-power
    width under two bins (0.25 Hz), the taper's spread of a line, so the damping is only
    bounded, by 1 / (T f) = 0.0025; the text says so and gives no value, the entry's
    parameters hold the bound, not a damping (before: "damping about 0.0014")."""
    rec, yh = _line_plant(0.7)
    pk = residual_peak([rec], [yh])
    assert pk is not None and abs(pk.freq_hz - 50.0) < 0.05
    assert pk.damping is None and pk.resolved_by_record
    assert pk.damping_below == pytest.approx(1.0 / (8.0 * pk.freq_hz))
    e = untestable_entry(pk)
    assert "damping below 0.0025, narrower than the record resolves" in e.reason
    assert "damping about" not in e.reason
    assert dict(e.parameters) == {"freq_hz": pk.freq_hz, "damping_below": pk.damping_below}


def test_a_fit_that_leaves_the_light_modes_falls_back_to_the_width() -> None:
    """The same line on a harmonic of a 1 Hz input: the fit leaves the harmonics out, sees
    no peak and ends at a damping above LIGHT_DAMPING (0.12, at 59 Hz); the peak is not
    given that damping, nor the fit's frequency, but the halves' bin (50 Hz) and their width
    as a bound under LIGHT_DAMPING."""
    rec, yh = _line_plant(1.0)
    pk = residual_peak([rec], [yh])
    assert pk is not None and pk.freq_hz == pk.bin_hz == 50.0
    assert pk.damping is None and not pk.resolved_by_record
    assert pk.damping_below is not None and pk.damping_below <= LIGHT_DAMPING
    e = untestable_entry(pk)
    assert f"damping below {pk.damping_below:.2g}, by its width" in e.reason
    assert "damping about" not in e.reason


def test_a_resolved_mode_keeps_its_fitted_damping() -> None:
    """A 45.3 Hz mode of damping 0.01 over 8 s: half-power width 0.91 Hz, over seven bins,
    resolved; its damping is reported as a value, within 30 %."""
    rng = np.random.default_rng(1)
    t = np.arange(8192) * DT
    u = np.sin(2 * np.pi * t)
    yh = np.tanh(8 * np.gradient(u, DT) / (2 * np.pi))
    y = oe.mode(yh + 0.02 * rng.standard_normal(t.size), 45.3, 0.01, DT)
    pk = residual_peak([Recording(t, u, y, "m")], [yh])
    assert pk is not None and pk.damping is not None and pk.damping_below is None
    assert abs(pk.damping - 0.01) <= 0.3 * 0.01
    assert f"damping about {pk.damping:.2g}," in untestable_entry(pk).reason


def test_a_peak_has_a_damping_or_a_bound() -> None:
    from core.diagnosis.residualpeak import ResidualPeak

    with pytest.raises(ValueError):
        ResidualPeak(45.0, None, 50.0, 0.0, 0.1, 2, 2, 45.0)
    with pytest.raises(ValueError):
        ResidualPeak(45.0, 0.01, 50.0, 0.0, 0.1, 2, 2, 45.0, damping_below=0.02)
