"""What a fit leaves: repeating (deterministic) or not, where, and how fast."""

from __future__ import annotations

import numpy as np

from core.fitting.leftover import leftover

DT = 1e-3


def _plant(seed: int, ring: float, noise: float) -> tuple[np.ndarray, ...]:
    """A 1 Hz input whose amplitude rises and falls (cycles 2 and 6, 3 and 5 are the same
    input), a friction-like output that saturates (flat plateaus), and a prediction that
    misses a 40 Hz ringing on the plateau after every transition (phase-locked to the
    input) plus noise."""
    t = np.arange(8000) * DT
    amp = 0.3 + 0.2 * np.sin(np.pi * np.floor(t) / 8.0)  # constant within each cycle
    u = amp * np.sin(2 * np.pi * t)
    # +-1 plateaus while the input slides, steep transitions at its reversals
    pred = np.tanh(20 * np.gradient(u, DT) / (2 * np.pi * amp))
    # time since the plateau was reached, 0.1 s after every reversal (each half cycle)
    phase = np.mod(t - 0.35, 0.5)
    rng = np.random.default_rng(seed)
    y = (pred + ring * np.exp(-phase / 0.1) * np.sin(2 * np.pi * 40 * phase) * (phase < 0.35)
         + noise * rng.standard_normal(t.size))
    return u, y, pred


def test_a_ringing_the_base_misses_repeats_lives_on_the_plateaus_and_is_fast() -> None:
    u, y, pred = _plant(0, 0.2, 0.005)
    left = leftover(u, y, pred, DT)
    assert left is not None
    assert left.f0 == 1.0
    assert left.pairs >= 2 and left.deterministic and left.repeat_corr > 0.9
    assert abs(left.fast_peak - 40.0) < 2.0 and left.fast_share > 0.8
    assert left.flat_energy > 0.8 and 0.3 < left.flat_rows < 0.95
    assert left.not_repeating_pct < 0.5 * left.residual_pct
    assert "repeats between input cycles" in left.text() and "deterministic" in left.text()


def test_noise_does_not_repeat() -> None:
    u, y, pred = _plant(1, 0.0, 0.05)
    left = leftover(u, y, pred, DT)
    assert left is not None and left.pairs >= 2
    assert not left.deterministic and abs(left.repeat_corr) < 0.2
    assert "does not repeat" in left.text()
    assert (left.fast_share >= 0.2) == ("strongest near" in left.text())
    # about the whole residual differs between the paired cycles
    assert left.not_repeating_pct > 0.8 * left.residual_pct


def test_too_short_a_record_says_nothing() -> None:
    u, y, pred = _plant(2, 0.2, 0.0)
    assert leftover(u[:1500], y[:1500], pred[:1500], DT) is None
