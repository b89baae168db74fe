"""The fast part of what a fit leaves, split on the input's harmonics and between them: a
sharp loop shape the base misses (the same every cycle) lies on the harmonics and is not an
oscillation; a vibration at its own frequency lies between them and is."""

from __future__ import annotations

import numpy as np

from core.fitting.leftover import leftover

DT = 1e-3


def _base(seed: int) -> tuple[np.ndarray, ...]:
    """A 1 Hz input whose amplitude rises and falls, over 8 s, a friction-like prediction
    (+-1 plateaus, steep transitions at the reversals), the time since the last reversal
    (s) and a noise of 0.2 % of the output range."""
    t = np.arange(8000) * DT
    amp = 0.3 + 0.2 * np.sin(np.pi * np.floor(t) / 8.0)  # constant within each cycle
    u = amp * np.sin(2 * np.pi * t)
    pred = np.tanh(20 * np.gradient(u, DT) / (2 * np.pi * amp))
    since = np.mod(t - 0.25, 0.5)  # reversals at 0.25 s and 0.75 s of every cycle
    return t, u, pred, since, 0.004 * np.random.default_rng(seed).standard_normal(t.size)


def test_a_sharp_shape_missed_every_cycle_is_on_the_harmonics_not_an_oscillation() -> None:
    """A short overshoot of the output just after every reversal (5 ms, the same every
    cycle, a corner the base rounds off): most of its power is far above 10x the input's
    frequency, all of it on the input's harmonics."""
    t, u, pred, since, noise = _base(0)
    sign = np.sign(np.gradient(u, DT))
    y = pred + 0.3 * sign * np.exp(-(((since - 0.02) / 0.005) ** 2)) + noise
    left = leftover(u, y, pred, DT)
    assert left is not None and left.deterministic
    assert left.fast_share > 0.5
    assert left.fast_harmonic > 0.9 * left.fast_share
    assert left.harmonic > 10 and abs(left.harmonic_hz - left.harmonic) < 0.01
    text = left.text()
    assert "oscillation" not in text
    assert f"the {left.harmonic}th harmonic of the input" in text
    assert "a shape tied to the input's phase that the base misses" in text


def test_a_vibration_between_the_harmonics_is_still_an_oscillation() -> None:
    """A 37.5 Hz vibration on the plateaus, at its own frequency (half way between the
    input's 37th and 38th harmonics), is called an oscillation, peaking near 37.5 Hz."""
    t, u, pred, since, noise = _base(1)
    y = pred + 0.1 * np.sin(2 * np.pi * 37.5 * t) * (since > 0.1) + noise
    left = leftover(u, y, pred, DT)
    assert left is not None
    assert left.fast_between > 0.5 and left.fast_harmonic < 0.2 * left.fast_share
    assert abs(left.between_peak - 37.5) < 0.5
    text = left.text()
    assert ("% between the input's harmonics, strongest near 37.5 Hz (an oscillation no "
            "rate-independent base follows)") in text
    assert "harmonic of the input" not in text


def test_broadband_noise_is_not_put_on_the_harmonics() -> None:
    """White noise fills the harmonics' bins as much as the bins between them: its part on
    the harmonics (above the level between them) is about nothing, although those bins are
    most of the band's."""
    t, u, pred, since, _ = _base(2)
    y = pred + 0.05 * np.random.default_rng(3).standard_normal(t.size)
    left = leftover(u, y, pred, DT)
    assert left is not None and left.fast_share > 0.8
    assert abs(left.fast_harmonic) < 0.05
    assert "harmonic of the input" not in left.text()
