"""The cycles of a periodic input: where each one starts, and how long one lasts.

A measured periodic input is rarely a whole number of samples per period (a 1 Hz drive
sampled at 1,024.3 Hz), its turning points are blurred by noise on the flat tops of the
wave, and it often starts at rest and ramps in and out. The cycle starts are therefore
taken where the input rises steeply through its middle: an upward crossing of the median,
counted again only after the input has fallen :data:`REARM` of its range below it (so noise
at rest on the median gives no crossing). The period is the median spacing of those
crossings, which a few ramp-in or ramp-out cycles do not move.

:func:`input_cycles` is the one place that finds them: the leftover check of a fit
(:mod:`core.fitting.leftover`, cycles paired as the same input) and the cycle-to-cycle test
of a drift (:func:`core.diagnosis.periodic.repeated_cycles`) both read it.
:func:`fundamental_hz` is the one place that finds the input's strongest frequency (the
leftover's fast part, the residual peak of :mod:`core.diagnosis.residualpeak`), :func:`line_hz`
the one that reads it to a small fraction of a frequency bin, and :func:`harmonic_bins` the
one that says which bins of a spectrum lie on its harmonics (the leftover's split of its fast
part, the bins the mode fit of :mod:`core.diagnosis.residualpeak` leaves out).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._typing import Float1D

__all__ = ["LINE_BINS", "REARM", "InputCycles", "fundamental_hz", "harmonic_bins", "input_cycles",
           "line_hz", "repeating_run"]

#: How far (fraction of the input range) the input must fall below its median before the
#: next upward crossing counts.
REARM = 0.1
#: Bins either side of each harmonic of a periodic input that hold its line in a Hann-tapered
#: periodogram (the taper's main lobe): :func:`harmonic_bins`.
LINE_BINS = 2


@dataclass(frozen=True)
class InputCycles:
    """The cycles of an input (:func:`input_cycles`).

    Attributes
    ----------
    period : int
        Samples per cycle: the median spacing of the cycle starts.
    starts : ndarray of int, shape (K,)
        First sample of each cycle (an upward crossing of the input's median), every one
        with a whole period of samples after it; ``K >= 1``.
    """

    period: int
    starts: np.ndarray

    def spans(self) -> tuple[tuple[int, int], ...]:
        """``(start, stop)`` sample ranges, one period long each."""
        return tuple((int(a), int(a) + self.period) for a in self.starts)


def input_cycles(u: Float1D) -> InputCycles | None:
    """The cycles of ``u`` (module docstring), or ``None`` when it has fewer than two.

    Parameters
    ----------
    u : ndarray of shape (N,)
        Input samples (evenly sampled).

    Returns
    -------
    InputCycles or None
        The period (samples) and the start of every whole cycle; ``None`` when the input
        rises through its median fewer than twice or is constant.
    """
    u = np.asarray(u, dtype=np.float64)
    span = float(np.ptp(u)) if u.size else 0.0
    if u.size < 8 or not span > 0:
        return None
    mid = float(np.median(u))
    low = u < mid - REARM * span
    up = np.flatnonzero((u[:-1] < mid) & (u[1:] >= mid)) + 1
    # an upward crossing counts when the input was below the re-arm level since the last one
    seen_low = np.concatenate(([0], np.cumsum(low)))  # lows among u[:i]
    starts: list[int] = []
    for i in up:
        if seen_low[i] > (seen_low[starts[-1]] if starts else 0):
            starts.append(int(i))
    if len(starts) < 2:
        return None
    period = int(round(float(np.median(np.diff(starts)))))
    whole = np.array([a for a in starts if a + period <= u.size], dtype=np.int64)
    if period < 4 or whole.size < 1:
        return None
    return InputCycles(period, whole)


def repeating_run(u: Float1D, tol: float, start_tol: float) -> tuple[tuple[int, int], ...]:
    """The longest run of consecutive identical cycles of ``u`` (:func:`input_cycles`), as
    ``(start, stop)`` sample ranges one period long; empty without a whole cycle.

    Parameters
    ----------
    u : ndarray, shape (N,)
        Input samples.
    tol : float
        A cycle repeats the one before when their inputs' RMS difference is below this
        share of the input's range ...
    start_tol : float
        ... and it starts one period after it within this share of the period.
    """
    u = np.asarray(u, dtype=np.float64)
    cyc = input_cycles(u)
    if cyc is None:
        return ()
    span = float(np.ptp(u))
    period = cyc.period
    best: list[tuple[int, int]] = []
    run: list[tuple[int, int]] = []
    for a, b in cyc.spans():
        if run:
            p = run[-1][0]
            if abs(a - p - period) > start_tol * period or np.sqrt(
                    np.mean((u[a:b] - u[p:p + period]) ** 2)) > tol * span:
                run = []
        run.append((a, b))
        if len(run) > len(best):
            best = list(run)
    return tuple(best)


def fundamental_hz(u: Float1D, dt: float) -> float:
    """The input's strongest frequency: its periodogram's peak with the mean left out, Hz
    (0 for a constant input).

    Parameters
    ----------
    u : ndarray, shape (N,)
        Input samples, evenly spaced.
    dt : float
        Sample spacing (s).
    """
    u = np.asarray(u, dtype=np.float64)
    spec = np.abs(np.fft.rfft(u - u.mean()))
    spec[0] = 0.0
    return float(np.fft.rfftfreq(u.size, dt)[int(np.argmax(spec))])


def line_hz(u: Float1D, dt: float) -> float:
    """The input's fundamental, Hz, to a small fraction of a bin: the peak of the input's
    zoomed spectrum (its discrete-time Fourier transform, mean removed, Hann-tapered so the
    negative frequency's image does not shift it) within a bin of :func:`fundamental_hz`
    (0 for a constant input).

    Parameters
    ----------
    u, dt : ndarray of shape (N,), float
        Input samples, evenly spaced, and their spacing (s), as for :func:`fundamental_hz`.
    """
    from scipy.optimize import minimize_scalar
    from scipy.signal.windows import hann

    x = np.asarray(u, dtype=np.float64)
    x = x - x.mean()
    f1 = fundamental_hz(x, dt)
    if not f1 > 0:
        return 0.0
    t = np.arange(x.size) * dt
    x = x * hann(x.size, sym=False)
    bin_hz = 1.0 / (x.size * dt)

    def minus_amp(f: float) -> float:
        return -abs(complex(np.sum(x * np.exp(-2j * np.pi * f * t))))

    r = minimize_scalar(minus_amp, bounds=(max(f1 - bin_hz, 0.5 * f1), f1 + bin_hz),
                        method="bounded", options={"xatol": 1e-6 * bin_hz})
    return float(r.x)


def harmonic_bins(f: Float1D, fu: float) -> np.ndarray | None:
    """The bins of a Hann-tapered periodogram at frequencies ``f`` that hold the lines of the
    harmonics of ``fu`` Hz: within :data:`LINE_BINS` bins of a multiple of ``fu``; ``None``
    when the harmonics do not stand apart (``fu`` is 0 or under ``2 LINE_BINS + 2`` bins).

    Parameters
    ----------
    f : ndarray, shape (M,)
        The periodogram's frequencies (Hz), evenly spaced from 0 (``numpy.fft.rfftfreq``).
    fu : float
        The input's fundamental (Hz, :func:`line_hz`).

    Returns
    -------
    ndarray of bool, shape (M,), or None
    """
    f = np.asarray(f, dtype=np.float64)
    bin_hz = float(f[1] - f[0]) if f.size > 1 else 0.0
    if not fu > 0 or not bin_hz > 0 or fu < (2 * LINE_BINS + 2) * bin_hz:
        return None
    return np.asarray(np.abs(f / fu - np.round(f / fu)) * fu <= LINE_BINS * bin_hz)
