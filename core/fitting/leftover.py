"""What a fitted base leaves, in words: deterministic or noise, where, and how fast.

A misfit far above the white-noise floor (:mod:`core.fitting.adequacy`) is either structure
the base cannot follow or noise the floor underestimates. :func:`leftover` tells them apart
on one recording with a time axis, without a second model:

* **Repeats with the input.** Cycles of the input (:func:`core.fitting.cycles.input_cycles`:
  from an upward crossing of its median, one period long) whose inputs agree to
  :data:`SAME_INPUT` of the input's range are paired; a deterministic residual is the
  same in both (correlation near 1), noise is not. The RMS difference of the paired
  residuals over ``sqrt(2)`` is the part that does not repeat.
* **Where.** The rows where the fitted branch is flat (its slope ``|dy/du|`` below
  :data:`FLAT_SLOPE` of its 90th percentile: the sliding plateaus of a friction loop, the
  saturated ends of a piezo's) against the rows where it rises.
* **How fast.** The share of the residual's power above :data:`FAST` times the input's
  fundamental frequency, and the frequency where that part peaks: ringing or chatter that
  no rate-independent base can follow.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._typing import Float1D
from .cycles import fundamental_hz, input_cycles

__all__ = ["FAST", "FLAT_SLOPE", "OSCILLATION", "SAME_INPUT", "Leftover", "leftover"]

#: Two input cycles count as the same input when their RMS difference is below this share
#: of the input's range.
SAME_INPUT = 0.01
#: A row is on a flat stretch of the fitted branch when its slope is below this share of the
#: slope's 90th percentile (rows that move the input).
FLAT_SLOPE = 0.2
#: The residual's fast part: above this many times the input's fundamental frequency.
FAST = 10.0
#: The fast part is called an oscillation (with its peak frequency) from this share of the
#: residual's power on.
OSCILLATION = 0.2


@dataclass(frozen=True)
class Leftover:
    """What a fit leaves on one recording (:func:`leftover`).

    Attributes
    ----------
    residual_pct : float
        RMS residual in % of the output range.
    pairs : int
        Input cycles paired as the same input.
    repeat_corr : float
        Mean correlation of the residual between paired cycles (NaN without pairs).
    not_repeating_pct : float
        RMS of the residual's difference between paired cycles over ``sqrt(2)``, in % of the
        output range: the part that does not repeat (NaN without pairs).
    flat_rows, flat_energy : float
        Share of the rows on flat stretches of the fitted branch and the share of the
        residual's energy there.
    f0 : float
        The input's fundamental frequency (Hz).
    fast_share : float
        Share of the residual's power above :data:`FAST` x ``f0``.
    fast_peak : float
        Frequency (Hz) where that fast part peaks.
    """

    residual_pct: float
    pairs: int
    repeat_corr: float
    not_repeating_pct: float
    flat_rows: float
    flat_energy: float
    f0: float
    fast_share: float
    fast_peak: float

    @property
    def deterministic(self) -> bool:
        """The residual repeats between cycles of the same input (correlation >= 0.7)."""
        return self.pairs > 0 and self.repeat_corr >= 0.7

    def text(self, flat_words: str = "the flat stretches of the branches") -> str:
        """The leftover in words."""
        out = f"what is left ({self.residual_pct:.2f} % of range) "
        if self.pairs:
            out += (f"{'repeats' if self.deterministic else 'does not repeat'} between input "
                    f"cycles with the same input (correlation {self.repeat_corr:.2f} over "
                    f"{self.pairs} pair(s); only {self.not_repeating_pct:.2f} % of range "
                    "differs between them)" + (": it is deterministic, not noise"
                                               if self.deterministic else ""))
        else:
            out += "cannot be checked for repetition (no two input cycles are the same)"
        if self.flat_rows >= 0.05:
            out += (f"; {100 * self.flat_energy:.0f} % of its energy lies on {flat_words} "
                    f"({100 * self.flat_rows:.0f} % of the rows)")
        out += (f"; {100 * self.fast_share:.0f} % of its power is above {FAST:g} x the input's "
                f"{self.f0:.3g} Hz")
        if self.fast_share >= OSCILLATION:
            out += (f", strongest near {self.fast_peak:.3g} Hz (an oscillation no "
                    "rate-independent base follows)")
        return out


def leftover(u: Float1D, y: Float1D, pred: Float1D, dt: float) -> Leftover | None:
    """What ``pred`` leaves of ``y`` (module docstring), or ``None`` when the recording has
    fewer than two input cycles.

    Parameters
    ----------
    u, y, pred : ndarray of shape (N,)
        Input, measured and fitted output of one recording (evenly sampled).
    dt : float
        Sample spacing (s).
    """
    u, y, pred = (np.asarray(a, dtype=np.float64) for a in (u, y, pred))
    n = u.size
    if n < 16 or not dt > 0:
        return None
    e = y - pred
    yr = float(np.ptp(y)) or 1.0
    f = np.fft.rfftfreq(n, dt)
    f0 = fundamental_hz(u, dt)
    if f0 <= 0 or 2.0 / f0 > n * dt:
        return None
    cycles = input_cycles(u)
    T = cycles.period if cycles is not None else 0
    starts = cycles.starts if cycles is not None else np.zeros(0, dtype=np.int64)
    ur = float(np.ptp(u)) or 1.0
    corr, diff = [], []
    for i, a in enumerate(starts):
        for b in starts[i + 1:]:
            if b - a < T // 2:  # overlapping windows are not two cycles
                continue
            if np.sqrt(np.mean((u[a:a + T] - u[b:b + T]) ** 2)) < SAME_INPUT * ur:
                ea, eb = e[a:a + T], e[b:b + T]
                if np.std(ea) > 0 and np.std(eb) > 0:
                    corr.append(float(np.corrcoef(ea, eb)[0, 1]))
                    diff.append(float(np.sqrt(np.mean((ea - eb) ** 2) / 2.0)))
    du = np.abs(np.gradient(u))
    moving = du > np.percentile(du, 20)
    slope = np.abs(np.gradient(pred)) / np.maximum(du, 1e-300)
    flat = moving & (slope < FLAT_SLOPE * np.percentile(slope[moving], 90))
    energy = float(e @ e) or 1.0
    power = np.abs(np.fft.rfft((e - e.mean()) * np.hanning(n))) ** 2
    power[0] = 0.0
    fast = f > FAST * f0
    total = float(power.sum()) or 1.0
    peak = float(f[int(np.argmax(np.where(fast, power, 0.0)))]) if fast.any() else float("nan")
    return Leftover(
        residual_pct=100.0 * float(np.sqrt(np.mean(e * e))) / yr,
        pairs=len(corr),
        repeat_corr=float(np.mean(corr)) if corr else float("nan"),
        not_repeating_pct=100.0 * float(np.mean(diff)) / yr if diff else float("nan"),
        flat_rows=float(flat.mean()),
        flat_energy=float(e[flat] @ e[flat]) / energy,
        f0=f0,
        fast_share=float(power[fast].sum()) / total,
        fast_peak=peak,
    )
