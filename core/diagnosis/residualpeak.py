"""A lightly damped mode the input does not excite: a narrow peak in the residual's spectrum.

A mode after the hysteresis filters everything the output carries, the part the input
drives and the part the base misses (a friction damper's chatter, the noise). When the
input has no energy near the mode's frequency (a slow tapered sine, no steps), the part
the input drives there is smaller than the base's own misfit, so a mode fitted to the
base's prediction cannot improve the held-out rows, and the resonance candidate fails
every rule: the mode is *untestable* as a stage after the hysteresis. It is still seen as
a narrow peak in the residual's spectrum, where the base's misfit is amplified by about
``1 / (2 zeta)``, and the report says so, with the experiment that would decide (notes
§2.3, §4.2), instead of staying silent.

The peak counts only when it is found, narrow and prominent, in at least two thirds of the
halves of the recordings (both halves of a single one), each half on its own, at frequencies
that agree within :data:`FREQ_AGREE`, and where the input drives little of that band: what such a
mode adds to the base's prediction there is under :data:`MAX_DRIVEN` of the residual's RMS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..fitting.cycles import fundamental_hz, harmonic_bins, line_hz
from ..fitting.spectrum import periodogram
from ..recordings import Recording
from .eventresponse import kind_prediction
from .specs import Untestable

__all__ = ["FIT_BAND", "FREQ_AGREE", "LIGHT_DAMPING", "MAX_DRIVEN", "MIN_SHARE", "ResidualPeak",
           "fit_mode", "peak_in", "residual_peak", "untestable_entry"]

#: Largest damping ratio of a peak counted as a lightly damped mode: its equivalent width
#: (:func:`peak_in`) is at most ``2 * LIGHT_DAMPING * f`` (plus 1.5 frequency bins, what the
#: window spreads a line over) and its peak stands at least
#: ``1 / (2 * LIGHT_DAMPING)**2`` (39) above the median of the band [f / 2, 2 f], what such a
#: mode does to a broadband excitation. The friction damper's own residual (its chatter)
#: peaks 25-50x above it, 0.1-0.2 wide.
LIGHT_DAMPING = 0.08
#: Smallest share of the halves of the recordings the peak must be found in (and at least
#: two): with one recording, both halves.
MIN_SHARE = 2.0 / 3.0
#: Largest relative spread of the peak frequencies found in the halves of the recordings.
FREQ_AGREE = 0.1
#: Largest share of the residual's RMS near the peak that the mode, acting on the base's
#: prediction, would explain for it to be called undriven (its MSE at most a quarter of it).
MAX_DRIVEN = 0.5
#: Lowest peak frequency searched, in multiples of the input's dominant frequency.
_ABOVE_INPUT = 5.0
#: Longest Welch segment, s, and fewest segments per half recording.
_SEGMENT_S = 1.0
_MIN_SEGMENTS = 3
#: The band of :func:`fit_mode`: ``[f / FIT_BAND, FIT_BAND * f]`` around the peak's bin,
#: three half-power half-widths either side of the widest mode counted (damping
#: :data:`LIGHT_DAMPING`): the peak's shoulders and the background beside them.
FIT_BAND = 1.0 + 3.0 * LIGHT_DAMPING
#: Fewest periodogram bins in the band for a residual to enter :func:`fit_mode`.
_MIN_FIT_BINS = 8


@dataclass(frozen=True)
class ResidualPeak:
    """A lightly damped peak in the residual's spectrum that the input does not excite.

    Attributes
    ----------
    freq_hz : float
        The mode's natural frequency, Hz, fitted to the peak's shape in the recordings'
        finest spectra (:func:`fit_mode`).
    damping : float or None
        The mode's damping ratio from the same fit; None when only a bound is known
        (``damping_below``).
    prominence : float
        Smallest ratio of the peak's power spectral density to the median of [f/2, 2f].
    input_share : float
        The input's RMS in [f/1.5, 1.5 f] as a share of its range (largest recording).
    driven : float
        What the mode adds to the base's prediction in that band (the part the input
        drives), RMS over the residual's there (largest recording).
    halves : int
        Independent halves it was found in.
    of_halves : int
        Halves searched.
    bin_hz : float
        Median of the peak bins of the halves (1 s Welch segments), Hz: where the peak was
        found, and the centre of the bands of ``input_share`` and ``driven``.
    damping_below : float or None
        An upper bound of the damping ratio, None when ``damping`` is known: the damping
        whose half-power width ``2 * zeta * f`` is two frequency bins of the longest record
        (``1 / (T f)``, ``T`` its length in s) when the fitted peak is narrower than that
        (a line, or a mode lighter than the record resolves); the halves' equivalent-width
        estimate (:func:`peak_in`, with ``freq_hz`` their median bin) when the fit of the
        peak's shape leaves the light modes (damping above :data:`LIGHT_DAMPING`).
    resolved_by_record : bool
        ``damping_below`` is the record's resolution (else the halves' width, or unused).
    """

    freq_hz: float
    damping: float | None
    prominence: float
    input_share: float
    driven: float
    halves: int
    of_halves: int
    bin_hz: float
    damping_below: float | None = None
    resolved_by_record: bool = False

    def __post_init__(self) -> None:
        if (self.damping is None) == (self.damping_below is None):
            raise ValueError("a peak has either a damping or a bound of it")


def _psd(x: np.ndarray, dt: float, nseg: int) -> tuple[np.ndarray, np.ndarray]:
    """Welch power spectral density of ``x`` (Hann windows of ``nseg`` samples, half overlap)."""
    from scipy.signal import welch

    f, p = welch(np.asarray(x, dtype=np.float64), fs=1.0 / dt, nperseg=nseg)
    return f, p


def _band_rms(x: np.ndarray, dt: float, lo: float, hi: float) -> float:
    """RMS of ``x`` (mean removed) between ``lo`` and ``hi`` Hz (periodogram)."""
    n = x.size
    f = np.fft.rfftfreq(n, dt)
    spec = np.abs(np.fft.rfft(x - x.mean())) ** 2
    m = (f >= lo) & (f <= hi)
    return float(np.sqrt(2.0 * np.sum(spec[m])) / n)


def peak_in(e: np.ndarray, dt: float, fmin: float) -> tuple[float, float, float] | None:
    """The most prominent peak of residual ``e`` above ``fmin`` Hz when it is a lightly damped
    mode's: prominent, and narrow by its equivalent width (its area above the median of
    [f/2, 2 f] over its height, times 2 / pi: a mode's half-power width, a flat band's
    width times 2 / pi).

    Parameters
    ----------
    e : ndarray, shape (n,)
        Residual samples (output units).
    dt : float
        Sample interval, s.
    fmin : float
        Lowest frequency searched, Hz (the highest is a quarter of the sampling rate).

    Returns
    -------
    (freq_hz, damping, prominence) or None
        None when no peak is both narrow (damping <= :data:`LIGHT_DAMPING`) and prominent.
    """
    nseg = int(min(round(_SEGMENT_S / dt), e.size // (_MIN_SEGMENTS // 2 + 1)))
    if nseg < 32:
        return None
    f, p = _psd(e, dt, nseg)
    df = float(f[1] - f[0])
    fmax = 0.25 / dt
    m = np.flatnonzero((f >= max(fmin, 4 * df)) & (f <= fmax))
    if m.size < 3:
        return None
    # the height over three bins: the largest of many estimated bins is biased upwards
    ps = np.convolve(p, np.ones(3) / 3.0, mode="same")
    i = int(m[np.argmax(ps[m])])
    f0 = float(f[i])
    local = (f >= f0 / 2) & (f <= 2 * f0)
    med = float(np.median(p[local]))
    prom = float(ps[i] / max(med, 1e-300))
    # equivalent width: the peak's area above the surroundings' median over its height; a
    # mode's (Lorentzian) half-power width w has area (pi / 2) w height, a flat band of
    # width w has w height (robust to the ragged top of an estimated spectrum); a line
    # spread by the window over three bins has about 1.5 bins
    area = float(np.sum(np.clip(p[local] - med, 0.0, None))) * df
    width = 2.0 * area / (np.pi * max(float(ps[i]) - med, 1e-300))
    zeta = width / (2.0 * f0)
    # written as what a peak must meet, so a NaN (a non-finite residual) meets nothing
    if not (zeta <= LIGHT_DAMPING + 1.5 * df / (2.0 * f0)
            and prom >= 1.0 / (2.0 * LIGHT_DAMPING) ** 2):
        return None
    return f0, zeta, prom


def _mode_shape(f: np.ndarray, fn: float, zeta: float) -> np.ndarray:
    """``|H(f)|**2`` of a unit-gain second-order mode at ``fn`` Hz with damping ``zeta``."""
    r = f / fn
    return 1.0 / ((1.0 - r * r) ** 2 + (2.0 * zeta * r) ** 2)


def fit_mode(residuals: list[tuple[np.ndarray, float, float]], f0: float, zeta0: float
             ) -> tuple[float, float] | None:
    """Frequency and damping of a mode seen as a peak near ``f0`` Hz, from the shape of the
    peak in the finest spectrum each residual gives.

    Each residual's periodogram over ``[f0 / FIT_BAND, FIT_BAND * f0]`` is modelled as the
    mode's ``|H(f)|**2`` times a smooth background, ``c_i (f / f0)**g_i`` (the broadband
    misfit the mode filters: its own level and slope per residual), and the frequency and
    damping shared by all residuals maximise the Whittle likelihood (a periodogram's bins
    are independent and exponentially distributed about the spectrum; the level ``c_i`` is
    profiled out). Under a periodic input the bins on the input's harmonics are left out
    (:func:`~core.fitting.cycles.harmonic_bins`): they hold lines (the periodic misfit and
    what the input drives through the mode), not the filtered broadband misfit whose shape
    is the mode's. A peak read from one bin of an averaged spectrum is off by up to half a
    bin (0.5 Hz with 1 s segments), pulled towards a strong harmonic near it, and widened
    by the window; the fit uses every bin of the peak between the harmonics, at the
    record's own resolution.

    Parameters
    ----------
    residuals : list of (ndarray, float, float)
        Residual samples (output units), their sample interval (s) and the input's
        fundamental (Hz, :func:`~core.fitting.cycles.line_hz`; 0 for none), one per recording.
    f0, zeta0 : float
        Starting frequency (Hz) and damping (the peak's bin and equivalent width).

    Returns
    -------
    (freq_hz, damping) : tuple of float, or None
        The natural frequency (Hz) and damping ratio; None when no residual has
        :data:`_MIN_FIT_BINS` bins in the band or the fit leaves it (nothing was fitted:
        the starting values are what is known).
    """
    from scipy.optimize import minimize

    bands = []
    for e, dt, fu in residuals:
        f, p = periodogram(e, dt)
        m = (f >= f0 / FIT_BAND) & (f <= FIT_BAND * f0) & (f > 0)
        lines = harmonic_bins(f, fu)
        if lines is not None:  # the harmonics stand apart
            m &= ~lines
        if int(m.sum()) >= _MIN_FIT_BINS:
            bands.append((f[m], p[m]))
    if not bands:
        return None

    def nll(th: np.ndarray) -> float:
        fn, zeta = float(th[0]), float(np.exp(th[1]))
        out = 0.0
        for k, (f, p) in enumerate(bands):
            s = _mode_shape(f, fn, zeta) * (f / f0) ** th[2 + k]
            out += f.size * math.log(max(float(np.mean(p / s)), 1e-300)) + float(
                np.sum(np.log(s)))
        return out

    lo, hi = f0 / FIT_BAND, FIT_BAND * f0
    best = None
    for start in (f0 * (1 - zeta0), f0, f0 * (1 + zeta0)):
        th0 = np.array([start, math.log(min(max(zeta0, 1e-3), 0.3)), *([0.0] * len(bands))])
        r = minimize(nll, th0, method="Nelder-Mead",
                     options={"xatol": 1e-5, "fatol": 1e-7, "maxiter": 4000})
        if np.isfinite(r.fun) and lo < r.x[0] < hi and (best is None or r.fun < best.fun):
            best = r
    if best is None:
        return None
    return float(best.x[0]), float(min(np.exp(best.x[1]), 1.0))


def residual_peak(records: list[Recording], pred: list[np.ndarray]) -> ResidualPeak | None:
    """A lightly damped peak in the residual ``y - pred`` that the input does not excite.

    Found in at least :data:`MIN_SHARE` of the halves of the recordings (and two), each half
    on its own, at frequencies that agree within :data:`FREQ_AGREE`, at least
    :data:`_ABOVE_INPUT` times above the input's dominant frequency, where what such a mode
    adds to the base's prediction (the part the input drives) is less than
    :data:`MAX_DRIVEN` of the residual's RMS in [f/1.5, 1.5 f].

    Parameters
    ----------
    records : list of Recording
        Recordings with a time axis.
    pred : list of ndarray, shape (n_i,)
        The model's prediction of each recording's output.

    Returns
    -------
    ResidualPeak or None
    """
    found: list[tuple[float, float, float]] = []
    n_parts = 0
    for rec, p in zip(records, pred, strict=True):
        if not rec.has_time or rec.t.size < 64:
            return None
        dt = float(rec.t[1] - rec.t[0])
        fmin = _ABOVE_INPUT * fundamental_hz(rec.u, dt)
        e = np.asarray(rec.y, dtype=np.float64) - np.asarray(p, dtype=np.float64)
        half = e.size // 2
        for part in (e[:half], e[half:]):
            n_parts += 1
            pk = peak_in(part, dt, fmin)
            if pk is not None:
                found.append(pk)
    if len(found) < max(2, math.ceil(MIN_SHARE * n_parts)):
        return None
    freqs = np.array([f for f, _, _ in found])
    f0 = float(np.median(freqs))
    if np.max(np.abs(freqs - f0)) > FREQ_AGREE * f0:
        return None
    zeta = min(z for _, z, _ in found)  # the closest to the mode's own (widths are bounds)
    share, driven = 0.0, 0.0
    for rec, p in zip(records, pred, strict=True):
        dt = float(rec.t[1] - rec.t[0])
        u, yh = np.asarray(rec.u, dtype=np.float64), np.asarray(p, dtype=np.float64)
        e = np.asarray(rec.y, dtype=np.float64) - yh
        share = max(share, _band_rms(u, dt, f0 / 1.5, 1.5 * f0) / max(float(np.ptp(u)), 1e-300))
        # what such a mode adds to the base's prediction: the part of the band the input drives
        added = kind_prediction("resonance", (f0, zeta), yh, dt) - yh
        driven = max(driven, _band_rms(added, dt, f0 / 1.5, 1.5 * f0)
                     / max(_band_rms(e, dt, f0 / 1.5, 1.5 * f0), 1e-300))
    if driven >= MAX_DRIVEN:
        return None  # the input drives the band: the resonance candidate's own verdict stands
    zeta_bins = float(np.median([z for _, z, _ in found]))
    got = fit_mode([(np.asarray(r.y, dtype=np.float64) - np.asarray(p, dtype=np.float64),
                     float(r.t[1] - r.t[0]), line_hz(r.u, float(r.t[1] - r.t[0])))
                    for r, p in zip(records, pred, strict=True)],
                   f0, zeta_bins)
    prom = min(pr for _, _, pr in found)
    fn, zn = got if got is not None else (f0, float("nan"))
    if not zn <= LIGHT_DAMPING:
        # no shape was fitted (too few bins between the harmonics), or the fit leaves the
        # light modes (a line on a harmonic the fit leaves out, a peak not fitted by one
        # light mode): only the halves' bin and width are known, the width a bound (the
        # window widens it); wider than a light mode's, no mode is said
        if not zeta_bins <= LIGHT_DAMPING:
            return None
        return ResidualPeak(f0, None, prom, share, driven, len(found), n_parts, f0,
                            damping_below=zeta_bins)
    # a half-power width 2 zeta fn under two bins of the longest record (1 / T apart) is
    # the taper's spread of a line, not the mode's: only a bound is known
    longest = max(float(r.t.size) * float(r.t[1] - r.t[0]) for r in records)
    floor = 1.0 / (longest * fn)
    if zn < floor:
        return ResidualPeak(fn, None, prom, share, driven, len(found), n_parts, f0,
                            damping_below=floor, resolved_by_record=True)
    return ResidualPeak(fn, zn, prom, share, driven, len(found), n_parts, f0)


def untestable_entry(pk: ResidualPeak) -> Untestable:
    """The ``untestable`` entry of the report for peak ``pk``: the resonance, the reason
    and the deciding experiment in words, and its fitted ``freq_hz`` (Hz) and ``damping``
    as the entry's parameters, or ``damping_below`` (its bound, :attr:`ResidualPeak.
    damping_below`) when the damping is not known."""
    f = pk.freq_hz
    params: dict[str, float]
    if pk.damping is not None:
        damping = f"damping about {pk.damping:.2g},"
        params = {"freq_hz": f, "damping": pk.damping}
    else:
        assert pk.damping_below is not None
        damping = (f"damping below {pk.damping_below:.2g}, "
                   + ("narrower than the record resolves;" if pk.resolved_by_record
                      else "by its width, its shape not fitted by one light mode;"))
        params = {"freq_hz": f, "damping_below": pk.damping_below}
    return Untestable(
        "resonance",
        (f"a lightly damped peak at about {f:.3g} Hz ({damping} "
         f"{pk.prominence:.3g}x the spectrum around it) is in the residual of {pk.halves} "
         f"of {pk.of_halves} halves of the recordings, each on its own, but the input has "
         f"no energy there ({100 * pk.input_share:.2g} % of its range between "
         f"{pk.bin_hz / 1.5:.3g} and {1.5 * pk.bin_hz:.3g} Hz; such a mode acting on the "
         f"model's prediction explains {100 * pk.driven:.2g} % of the residual's RMS "
         "there), so a mode after the hysteresis cannot be told from the output's own "
         "unmodelled vibration or an interference at that frequency"),
        (f"input steps with rests before them, or a sine sweep through {f / 2:.3g}-"
         f"{2 * f:.3g} Hz at a small amplitude: a mode rings at its frequency after each "
         "step and peaks in the output over input there"),
        params,
    )
