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
  fundamental frequency, and the frequency where that part peaks. Under a periodic input
  (its harmonics a few frequency bins apart: :func:`core.fitting.cycles.harmonic_bins`) that
  part is split in two. A rate-independent base misses the same loop shape in every cycle,
  so what it leaves repeats with the input and its power lies on the input's harmonics,
  however sharp the shape (a corner at the slip rounded off gives harmonics far above
  :data:`FAST`); only power between them (or a peak that stays at one frequency in hertz
  when the input frequency changes: :func:`fast_across`) points to dynamics the base lacks,
  ringing or chatter. The harmonics' part is what their bins hold above the between bins'
  mean power (the broadband part under them), the rest is between. A ringing that restarts
  alike every cycle (at each slip) repeats too and lands on harmonics as well: one recording
  cannot tell it from a loop shape, recordings at other input frequencies can
  (:func:`fast_across`). On the four friction damper recordings the stop-operator base of
  ``hyst fit`` leaves 38-82 % of its residual's power above 10 times the input's: 24-42 % on
  the harmonics (the strongest the 11th at 0.25 Hz, the slow part that repeats at the slip;
  the 12th and 14th at 1 Hz; the 25th at 2 Hz) and 12-51 % between them (near 39-53 Hz).
* **Whose frequency** (:func:`fast_across`, several recordings whose input frequencies
  differ by :data:`ACROSS_RATIO` or more): the residual's peak above :data:`FAST` times the
  highest input frequency, in each recording. A peak is an interior local maximum of the
  smoothed Hann periodogram (:func:`core.fitting.spectrum.periodogram`) standing above the
  local trend around it (the smoothed power over ``[f / 2, 2 f]``) by more than white noise
  reaches over the band's bins (:data:`PEAK_ALPHA`), found again in both halves of the record:
  a misfit whose power falls with frequency peaks at the band's lower edge in every recording,
  the same hertz by construction, and is no peak. A peak at a fixed frequency in hertz while
  the input's changes is a vibration of the device or its rig, or an interference (the mains):
  not tied to the input's phase; a peak at the same multiple of the input frequency is tied to
  the input's phase: a loop shape the base misses. On the friction damper at 30 lb (0.25, 1
  and 2 Hz) the stop-operator base of ``hyst fit`` leaves fast parts strongest near 39, 48 and
  43 Hz, but the 2 Hz recording's first half shows a broad hump there, not a peak: nothing is
  said.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._typing import Float1D
from ..recordings import Recording
from .cycles import fundamental_hz, harmonic_bins, input_cycles, line_hz
from .spectrum import periodogram

__all__ = ["ACROSS_RATIO", "FAST", "FLAT_SLOPE", "MIN_BAND_SHARE", "MIN_SMOOTH_BINS",
           "OSCILLATION", "PART", "PEAK_ALPHA", "SAME_INPUT", "SAME_PEAK", "SMOOTH",
           "SMOOTH_HARMONICS", "FastAcross", "Leftover", "LeftOnRecordings", "fast_across",
           "leftover", "leftover_on"]

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
#: ... and, under a periodic input, its part on the input's harmonics and its part between
#: them are each named (with their peak) from this share of the residual's power on.
PART = 0.1
#: :func:`fast_across` compares recordings whose input frequencies span at least this factor.
ACROSS_RATIO = 2.0
#: Peaks whose frequencies (or multiples of the input frequency) span at most this factor
#: count as the same.
SAME_PEAK = 1.3
#: :func:`fast_across` says something only when the band above :data:`FAST` times the highest
#: input frequency holds at least this share of every recording's residual power.
MIN_BAND_SHARE = 0.05
#: The band's periodogram is smoothed over this share of its lower edge before its peak is
#: read (a peak, not one bin of a line spectrum) ...
SMOOTH = 0.05
#: ... and over at least this many bins ...
MIN_SMOOTH_BINS = 8
#: ... and at least this many spacings of the input's harmonics, so that a misfit tied to the
#: input's phase (a comb of harmonic lines) is read as its envelope, not as its lines.
SMOOTH_HARMONICS = 2
#: A peak stands above the local trend: the geometric mean of the medians of the smoothed
#: power over ``[f / 2, f / SAME_PEAK]`` and ``[SAME_PEAK f, 2 f]``, by more than white
#: noise's smoothed power reaches once in ``1 / PEAK_ALPHA`` records over all the band's bins
#: (the chi-square quantile at ``1 - PEAK_ALPHA / bins`` for the smoothing's degrees of
#: freedom, Bonferroni over the bins).
PEAK_ALPHA = 0.01
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
    fast_harmonic : float
        Share of the residual's power that the fast part holds on the input's harmonics,
        above the broadband level between them (module docstring); NaN when the harmonics
        do not stand apart (no periodic input, or too short a recording).
    harmonic : int
        The fast part's strongest harmonic of the input (its order; 0 without the split).
    harmonic_hz : float
        That harmonic's frequency (Hz; NaN without the split).
    between_peak : float
        Frequency (Hz) where the fast part peaks between the input's harmonics (NaN without
        the split).
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
    fast_harmonic: float = float("nan")
    harmonic: int = 0
    harmonic_hz: float = float("nan")
    between_peak: float = float("nan")

    @property
    def fast_between(self) -> float:
        """Share of the residual's power that the fast part holds between the input's
        harmonics (NaN without the split)."""
        return self.fast_share - self.fast_harmonic

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
        if self.fast_share < OSCILLATION:
            return out
        if np.isnan(self.fast_harmonic):
            return out + (f", strongest near {self.fast_peak:.3g} Hz (an oscillation no "
                          "rate-independent base follows)")
        parts = []
        if self.fast_harmonic >= PART or self.fast_harmonic >= self.fast_between:
            parts.append(f"{100 * self.fast_harmonic:.0f} % on the input's harmonics, strongest at "
                         f"{self.harmonic_hz:.3g} Hz (the {_ordinal(self.harmonic)} harmonic "
                         "of the input: a shape tied to the input's phase that the base "
                         "misses, or a ringing that restarts alike every cycle; recordings "
                         "at other input frequencies tell them apart)")
        if self.fast_between >= PART or self.fast_between > self.fast_harmonic:
            where = "them" if parts else "the input's harmonics"
            parts.append(f"{100 * self.fast_between:.0f} % between {where}, strongest near "
                         f"{self.between_peak:.3g} Hz (an oscillation no rate-independent "
                         "base follows)")
        return out + ": " + ", ".join(parts)


def _ordinal(k: int) -> str:
    """``1st``, ``2nd``, ``3rd``, ``11th``, ``22nd``..."""
    end = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{end}"


def _flat_rows(u: Float1D, pred: Float1D) -> np.ndarray:
    """The rows that move the input where the fitted branch is flat (module docstring)."""
    du = np.abs(np.gradient(u))
    moving = du > np.percentile(du, 20)
    if not moving.any():  # |du| constant (a triangle input): no slope stands out as flat
        return np.zeros(u.size, dtype=bool)
    slope = np.abs(np.gradient(pred)) / np.maximum(du, 1e-300)
    return moving & (slope < FLAT_SLOPE * np.percentile(slope[moving], 90))


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
    flat = _flat_rows(u, pred)
    energy = float(e @ e) or 1.0
    power = periodogram(e, dt)[1]
    power[0] = 0.0
    fast = f > FAST * f0
    total = float(power.sum()) or 1.0
    peak = float(f[int(np.argmax(np.where(fast, power, 0.0)))]) if fast.any() else float("nan")
    on, k, k_hz, between = _split(f, power, fast, u, dt)
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
        fast_harmonic=on / total,
        harmonic=k,
        harmonic_hz=k_hz,
        between_peak=between,
    )


def _split(f: np.ndarray, power: np.ndarray, fast: np.ndarray, u: Float1D, dt: float
           ) -> tuple[float, int, float, float]:
    """The fast part's power on the input's harmonics above the between bins' mean power,
    its strongest harmonic (order and Hz) and the between bins' peak (Hz); ``(NaN, 0, NaN,
    NaN)`` when the harmonics do not stand apart or the fast part lacks bins on or between
    them."""
    nan = float("nan")
    lines = harmonic_bins(f, fu := line_hz(u, dt))
    if lines is None:
        return nan, 0, nan, nan
    on, off = fast & lines, fast & ~lines
    if not on.any() or not off.any():
        return nan, 0, nan, nan
    level = float(power[off].mean())
    order = np.round(f / fu).astype(np.int64)
    per = np.bincount(order[on], weights=power[on] - level)
    k = int(np.argmax(per))
    return (max(float(power[on].sum()) - level * int(on.sum()), 0.0), k, k * fu,
            float(f[off][int(np.argmax(power[off]))]))


@dataclass(frozen=True)
class FastAcross:
    """The residual's fast peak compared across recordings (:func:`fast_across`).

    Attributes
    ----------
    names : tuple of str
        The recordings compared.
    f0 : tuple of float
        Each one's input frequency (Hz).
    band_hz : float
        The band's lower edge: :data:`FAST` times the highest input frequency (Hz).
    share : tuple of float
        Share of each residual's power in the band.
    peak_hz : tuple of float
        Where the band's smoothed power peaks in each recording (Hz).
    flat_share : tuple of float
        Share of the band's energy on the flat rows of the fitted branch, per recording.
    """

    names: tuple[str, ...]
    f0: tuple[float, ...]
    band_hz: float
    share: tuple[float, ...]
    peak_hz: tuple[float, ...]
    flat_share: tuple[float, ...]

    @property
    def multiples(self) -> tuple[float, ...]:
        """Each peak as a multiple of its recording's input frequency."""
        return tuple(p / f for p, f in zip(self.peak_hz, self.f0, strict=True))

    @property
    def same_hz(self) -> bool:
        """The peaks span at most :data:`SAME_PEAK` in hertz while the multiples do not."""
        return _span(self.peak_hz) <= SAME_PEAK < _span(self.multiples)

    @property
    def same_multiple(self) -> bool:
        """The peaks span at most :data:`SAME_PEAK` as multiples of the input frequency."""
        return _span(self.multiples) <= SAME_PEAK

    def text(self, flat_words: str = "the flat stretches of the branches") -> str:
        """The comparison in words."""
        peaks = ", ".join(f"{p:.3g}" for p in self.peak_hz)
        mult = ", ".join(f"{m:.3g}" for m in self.multiples)
        out = (f"across {len(self.names)} recordings with the input at "
               f"{_range(self.f0, '.3g')} Hz, what is left above {self.band_hz:.3g} Hz "
               f"({_range([100 * s for s in self.share], '.0f')} % of its power"
               + (f", {_range([100 * s for s in self.flat_share], '.0f')} % of that on "
                  f"{flat_words}"
                  if min(self.flat_share) >= 0.5 else "")
               + f") peaks at {peaks} Hz ({mult} x the input frequency)")
        if self.same_hz:
            return out + (f": at a fixed frequency ({_range(self.peak_hz, '.3g')} Hz) while the "
                          f"input frequency changes {_span(self.f0):.2g}-fold: a vibration of "
                          "the device or its rig, or an interference, not tied to the input's "
                          "phase")
        if self.same_multiple:
            return out + (": the same multiple of the input frequency, tied to the input's "
                          "phase: a loop shape the base misses")
        return out + ": neither the same frequency nor the same multiple of the input's"


def _span(x: tuple[float, ...] | list[float]) -> float:
    return float(max(x) / min(x)) if min(x) > 0 else float("inf")


def _range(x: tuple[float, ...] | list[float], fmt: str) -> str:
    lo, hi = format(min(x), fmt), format(max(x), fmt)
    return lo if lo == hi else f"{lo}-{hi}"


def _hann_dof(m: int) -> float:
    """Degrees of freedom of the mean of ``m`` adjacent bins of a Hann-tapered periodogram of
    white noise (neighbouring bins correlate: ``|X_k X_{k+1}|^2`` 4/9, ``k+2`` 1/36)."""
    c = {0: 1.0, 1: 4.0 / 9.0, 2: 1.0 / 36.0}
    return 2.0 * m * m / sum(c.get(abs(i - j), 0.0) for i in range(m) for j in range(m))


def _peaks(e: np.ndarray, dt: float, f0: float, band: float) -> list[tuple[float, float]]:
    """Where the residual ``e``'s smoothed periodogram above ``band`` Hz has an interior local
    maximum standing above its local trend (:data:`PEAK_ALPHA`): (Hz, smoothed power) each.

    The smoothing spans :data:`SMOOTH` of ``band``, :data:`MIN_SMOOTH_BINS` bins and
    :data:`SMOOTH_HARMONICS` spacings of the input's harmonics (``f0``), whichever is widest,
    and a candidate's window lies inside the band (no bins from below it)."""
    from scipy.stats import chi2

    f, power = periodogram(e, dt)
    if f.size < 4:
        return []
    bin_hz = float(f[1])
    m = max(MIN_SMOOTH_BINS, int(np.ceil(SMOOTH * band / bin_hz)),
            int(np.ceil(SMOOTH_HARMONICS * f0 / bin_hz)))
    m += 1 - m % 2  # odd: centred
    h = m // 2
    if f.size < m + 2:
        return []
    c = np.concatenate(([0.0], np.cumsum(power)))
    smooth = np.full(f.size, np.nan)
    smooth[h:f.size - h] = (c[m:] - c[:-m]) / m  # windows wholly inside the spectrum
    cand = np.flatnonzero((f - h * bin_hz > band) & np.isfinite(smooth))
    if cand.size == 0:
        return []
    dof = _hann_dof(m)
    limit = float(chi2.ppf(1.0 - PEAK_ALPHA / cand.size, dof) / chi2.median(dof))
    out = []
    for i in cand:
        if smooth[i] < np.nanmax(smooth[max(0, i - m):i + m + 1]):
            continue  # not a local maximum over its own width
        below = smooth[int(np.ceil(i / 2)):int(i / SAME_PEAK) + 1]
        above = smooth[int(np.ceil(SAME_PEAK * i)):2 * i + 1]
        below, above = below[np.isfinite(below)], above[np.isfinite(above)]
        if below.size < m or above.size < m:
            continue  # not interior: no trend on one side
        trend = float(np.sqrt(np.median(below) * np.median(above)))
        if smooth[i] > limit * trend:
            out.append((float(f[i]), float(smooth[i])))
    return out


def fast_across(names: list[str], us: list[Float1D], ys: list[Float1D], preds: list[Float1D],
                dts: list[float]) -> FastAcross | None:
    """Where the residual's fast part peaks in each recording (module docstring), or ``None``
    when fewer than two recordings are left to compare or their input frequencies span less
    than :data:`ACROSS_RATIO`. A recording is compared when it has an input frequency and its
    residual has a fast part: the band holds :data:`MIN_BAND_SHARE` of its power or more
    (one without is left out); the comparison is dropped when one compared shows no peak
    there: the strongest interior local maximum of the smoothed periodogram standing above its
    local trend (:data:`PEAK_ALPHA`) in the whole record, with such a maximum within
    :data:`SAME_PEAK` of it in each of the record's halves (noise and a misfit whose power falls
    with frequency have none).

    Parameters
    ----------
    names : list of str
        The recordings' names.
    us, ys, preds : list of ndarray of shape (N_k,)
        Input, measured and fitted output of each recording (evenly sampled).
    dts : list of float
        Each recording's sample spacing (s).
    """
    rows = []
    for name, u, y, pred, dt in zip(names, us, ys, preds, dts, strict=True):
        u, y, pred = (np.asarray(a, dtype=np.float64) for a in (u, y, pred))
        f0 = fundamental_hz(u, dt) if u.size >= 16 and dt > 0 else 0.0
        if f0 > 0:
            rows.append((name, u, y - pred, pred, dt, f0))
    if not rows:
        return None
    band = FAST * max(r[5] for r in rows)
    kept, share, peak, flat_share = [], [], [], []
    for row in rows:
        _, u, e, pred, dt, f0 = row
        n = e.size
        f, power = periodogram(e, dt)
        power[0] = 0.0
        inside = f > band
        total = float(power.sum())
        if not inside.any() or total <= 0 or power[inside].sum() < MIN_BAND_SHARE * total:
            continue  # no fast part to compare
        found = _peaks(e, dt, f0, band)
        if not found:
            return None
        at = max(found, key=lambda p: p[1])[0]  # the strongest
        for half in (e[:n // 2], e[n // 2:]):
            if not any(_span([at, p[0]]) <= SAME_PEAK for p in _peaks(half, dt, f0, band)):
                return None  # not in both halves
        kept.append(row)
        share.append(float(power[inside].sum()) / total)
        peak.append(at)
        fast = np.fft.irfft(np.where(np.fft.rfftfreq(n, dt) > band, np.fft.rfft(e - e.mean()),
                                     0.0), n)
        flat = _flat_rows(u, pred)
        flat_share.append(float(fast[flat] @ fast[flat]) / (float(fast @ fast) or 1.0))
    if len(kept) < 2 or _span([r[5] for r in kept]) < ACROSS_RATIO:
        return None
    return FastAcross(tuple(r[0] for r in kept), tuple(r[5] for r in kept), band,
                      tuple(share), tuple(peak), tuple(flat_share))


@dataclass(frozen=True)
class LeftOnRecordings:
    """What a fit leaves on a set of recordings (:func:`leftover_on`).

    Attributes
    ----------
    name : str
        The recording :attr:`leftover` describes (the longest evenly sampled one with a time
        axis), ``""`` without one.
    leftover : Leftover or None
        :func:`leftover` on it.
    across : FastAcross or None
        :func:`fast_across` over all the evenly sampled recordings with a time axis.
    """

    name: str
    leftover: Leftover | None
    across: FastAcross | None


def leftover_on(recs: Sequence[Recording], preds: Sequence[Float1D]) -> LeftOnRecordings:
    """:func:`leftover` on the longest evenly sampled recording with a time axis and
    :func:`fast_across` over all of those (spectra need even sampling in time).

    Parameters
    ----------
    recs : sequence of Recording
        The recordings.
    preds : sequence of ndarray of shape (N_k,)
        The fit's prediction of each one's output.
    """
    timed = [(r, np.asarray(p, dtype=np.float64)) for r, p in zip(recs, preds, strict=True)
             if r.has_time and r.is_uniform]
    if not timed:
        return LeftOnRecordings("", None, None)
    rec, pred = max(timed, key=lambda rp: rp[0].n_samples)
    return LeftOnRecordings(
        rec.name, leftover(rec.u, rec.y, pred, rec.dt),
        fast_across([r.name for r, _ in timed], [r.u for r, _ in timed],
                    [r.y for r, _ in timed], [p for _, p in timed], [r.dt for r, _ in timed]))
