"""The cycles of a measured periodic input (core.fitting.cycles).

A measured drive is rarely a whole number of samples per period, starts at rest with noise
on the median, and ramps in and out; its turning points are blurred by noise on the flat
tops. The reference is the generator's own period and cycle starts."""

from __future__ import annotations

import numpy as np
import pytest

from core.fitting.cycles import harmonic_bins, input_cycles


def _drive(fs: float, f: float, cycles: int, seed: int, ramp: int = 1) -> np.ndarray:
    """0.5 s at rest (noise on zero), ``ramp`` cycle(s) of growing amplitude, ``cycles`` of a
    sine of amplitude 1 at ``f`` Hz, ``ramp`` of falling amplitude, 0.5 s at rest; noise 1 %
    of the amplitude everywhere. Sampled at ``fs`` Hz (not a whole number of samples per
    period)."""
    rng = np.random.default_rng(seed)
    rest = int(0.5 * fs)
    t = np.arange(int((cycles + 2 * ramp) * fs / f)) / fs
    env = np.clip(np.minimum(t, t[-1] - t) * f / ramp, 0.0, 1.0)
    u = np.concatenate([np.zeros(rest), env * np.sin(2 * np.pi * f * t), np.zeros(rest)])
    return u + 0.01 * rng.standard_normal(u.size)


@pytest.mark.parametrize(("fs", "f"), [(1024.3, 1.0), (1000.0, 0.977), (5000.0, 2.0)])
def test_the_period_and_the_starts_follow_the_drive(fs: float, f: float) -> None:
    u = _drive(fs, f, cycles=6, seed=3)
    cyc = input_cycles(u)
    assert cyc is not None
    true_period = fs / f
    assert abs(cyc.period - true_period) <= 1.0
    # one start per rising zero crossing of the full-amplitude and ramp cycles, none at rest
    rest = int(0.5 * fs)
    assert np.all(cyc.starts > rest) and np.all(cyc.starts < u.size - rest)
    # the starts in the full-amplitude cycles sit on the sine's rising zero crossings
    # (within 1 % of a period), one per cycle; the ramp cycles' crossings move with noise
    full = cyc.starts[(cyc.starts > rest + 0.5 * true_period)
                      & (cyc.starts < u.size - rest - 1.5 * true_period)]
    assert full.size >= 5
    phase = ((full - rest) / true_period) % 1.0
    assert np.all(np.minimum(phase, 1.0 - phase) < 0.01)
    assert np.all(np.abs(np.diff(full) - true_period) <= 0.01 * true_period)


def test_a_single_rise_is_no_cycle() -> None:
    rng = np.random.default_rng(0)
    assert input_cycles(np.zeros(100)) is None
    # one noisy rise from rest to a hold: noise at rest on the median starts nothing
    step = np.concatenate([np.zeros(500), np.ones(500)]) + 0.01 * rng.standard_normal(1000)
    assert input_cycles(step) is None


def test_harmonic_bins_hold_the_lines_and_need_the_harmonics_apart() -> None:
    """At 8 bins per harmonic, the bins within 2 of each multiple of the fundamental are on
    the harmonics and those half way between are not; at 1 bin per harmonic there is no
    split (``None``)."""
    f = np.fft.rfftfreq(8000, 1e-3)  # 0.125 Hz bins
    on = harmonic_bins(f, 1.0)
    assert on is not None
    assert on[f == 37.0].all() and on[np.isclose(f, 37.25)].all()
    assert not on[f == 37.5].any() and not on[np.isclose(f, 37.375)].any()
    assert harmonic_bins(np.fft.rfftfreq(1000, 1e-3), 1.0) is None
    assert harmonic_bins(f, 0.0) is None
