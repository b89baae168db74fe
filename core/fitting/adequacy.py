"""Whether a fit reaches the noise: the held-out error against the white-noise floor.

A fit whose held-out RMSE is more than :data:`MISFIT_RATIO` times the white-noise floor of
its own held-out residual misses structure in the data, whatever its % of range looks like.
:func:`misfit_warning` says so in words, with where the residual is largest: the fifth of
the input range, the branch (rising or falling input; just after a reversal or further on)
and the time window (a tenth of the held-out rows of a recording).

The floor is the RMS of the residual's first differences over ``sqrt(2)`` (white noise
differences to ``sqrt(2)`` times its RMS, a smooth misfit differences to almost nothing),
the estimate the diagnosis uses (:func:`core.diagnosis.stats.noise_floor`), but never below
:data:`RESOLUTION` of the held-out output range (a good sensor's resolution), so a
noise-free simulation is not flagged for a misfit at round-off level.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._typing import Float1D
from ..recordings import Recording

__all__ = ["MISFIT_RATIO", "RATE_RESIDUAL_RATIO", "RATE_SPAN", "RATE_WIDTH_SHARE", "Misfit",
           "misfit", "noise_floor", "rate_trend", "rate_words"]

#: A held-out RMSE above this many white-noise floors gets a warning.
MISFIT_RATIO = 5.0
#: The smallest floor, as a share of the held-out output range.
RESOLUTION = 1e-4
#: Share of the travel between two reversals counted as "just after a reversal".
AFTER_REVERSAL = 0.2


def noise_floor(e: Float1D) -> float:
    """White-noise level (output units, RMS) from first differences of the residual ``e``
    (shape ``(N,)``, consecutive samples); 0 for fewer than 3 samples."""
    if e.size < 3:
        return 0.0
    return float(np.std(np.diff(e)) / np.sqrt(2.0))


@dataclass(frozen=True)
class Misfit:
    """The held-out error against the noise floor, and where the residual is largest.

    Attributes
    ----------
    rmse, floor : float
        Held-out RMSE and white-noise floor (output units; at least :data:`RESOLUTION` of
        the held-out output range).
    ratio : float
        ``rmse / floor`` (``inf`` for a zero floor).
    input_band : tuple of float
        The fifth of the held-out input range with the largest RMS residual (input units).
    input_band_rmse : float
    branch : str
        The branch with the largest RMS residual (``"rising input, just after a reversal"``,
        ``"falling input, further from the reversal"``, ...).
    branch_rmse : float
    window : tuple of float
        The window (a tenth of a recording's held-out rows) with the largest RMS residual:
        its first and last time (s), or sample numbers when ``timed`` is false, and
        ``recording`` its recording's name.
    window_rmse : float
    recording : str
    timed : bool
        Whether that recording has a time axis (else ``window`` holds sample numbers,
        counted from 0 in the recording).
    """

    rmse: float
    floor: float
    ratio: float
    input_band: tuple[float, float]
    input_band_rmse: float
    branch: str
    branch_rmse: float
    window: tuple[float, float]
    window_rmse: float
    recording: str
    timed: bool = True

    @property
    def exceeds(self) -> bool:
        """Whether the RMSE is above :data:`MISFIT_RATIO` floors."""
        return self.ratio > MISFIT_RATIO

    def text(self, pct: float | None = None, advice: str = "",
             units: dict[str, str] | None = None) -> str:
        """The warning in words (``pct``: the RMSE in % of the output range; ``advice``: what
        to try, default another fit kind or the diagnosis; ``units``: the recording's
        ``"input"`` and ``"output"`` units, named after the numbers)."""
        share = f" ({pct:.3g} % of range)" if pct is not None and np.isfinite(pct) else ""
        rec = f" of {self.recording}" if self.recording else ""
        ui = f" {units['input']}" if units and units.get("input") else ""
        uo = f" {units['output']}" if units and units.get("output") else ""
        where = (f"t = {self.window[0]:.4g} to {self.window[1]:.4g} s" if self.timed else
                 f"samples {self.window[0]:.0f} to {self.window[1]:.0f} (counted from 0; "
                 "no time axis)")
        return (
            f"the held-out RMSE {self.rmse:.4g}{uo}{share} is {self.ratio:.0f} times the "
            f"white-noise floor {self.floor:.3g}{uo}: this model misses structure in the data. "
            f"Largest residuals: at inputs {self.input_band[0]:.4g} to "
            f"{self.input_band[1]:.4g}{ui} (RMS {self.input_band_rmse:.3g}{uo}), on the "
            f"{self.branch} (RMS {self.branch_rmse:.3g}{uo}), and in {where}{rec} (RMS "
            f"{self.window_rmse:.3g}{uo}). "
            + (advice or "Another fit kind (--model auto chooses one the way the diagnosis "
                         "does) or hyst diagnose may explain it")
        )


def _rms(e: Float1D) -> float:
    return float(np.sqrt(np.mean(e * e))) if e.size else 0.0


def _branches(u: Float1D) -> tuple[np.ndarray, np.ndarray]:
    """Direction (+1 / -1; 0 before the first move) and "just after a reversal" of each
    sample of ``u``: within :data:`AFTER_REVERSAL` of the travel to the next reversal."""
    du = np.diff(u, prepend=u[0])
    d = np.sign(du)
    # carry the last direction over flat samples
    idx = np.where(d != 0, np.arange(d.size), 0)
    np.maximum.accumulate(idx, out=idx)
    d = d[idx]
    near = np.zeros(u.size, dtype=bool)
    rev = np.flatnonzero(np.diff(d) != 0) + 1
    edges = np.concatenate(([0], rev, [u.size]))
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        if b - a < 2:
            continue
        travel = np.abs(u[a:b] - u[a])
        near[a:b] = travel <= AFTER_REVERSAL * max(float(travel.max()), 1e-300)
    return d, near


def misfit(
    ts: Sequence[Float1D], us: Sequence[Float1D], ys: Sequence[Float1D],
    preds: Sequence[Float1D], masks: Sequence[np.ndarray], names: Sequence[str] = (),
    timed: Sequence[bool] = (),
) -> Misfit | None:
    """The held-out error against its noise floor and where the residual is largest.

    Parameters
    ----------
    ts, us, ys, preds : sequence of ndarray of shape (N_i,)
        Time (s), input, measured and predicted output of each recording.
    masks : sequence of bool ndarray of shape (N_i,)
        Held-out rows.
    names : sequence of str, optional
        Recording names (for the time window).
    timed : sequence of bool, optional
        Whether each recording has a time axis (default: all do); without one its ``ts``
        are sample numbers and the window is said in samples.

    Returns
    -------
    Misfit or None
        ``None`` with fewer than 10 held-out rows.
    """
    es, ue, de, ne, floors = [], [], [], [], []
    win: tuple[float, float, float, str, bool] = (0.0, 0.0, 0.0, "", True)
    for k, (t, u, y, p, m) in enumerate(zip(ts, us, ys, preds, masks, strict=True)):
        if not m.any():
            continue
        e = y - p
        d, near = _branches(u)
        # the floor from consecutive held-out rows only
        runs = np.split(np.flatnonzero(m), np.flatnonzero(np.diff(np.flatnonzero(m)) > 1) + 1)
        for r in runs:
            if r.size >= 3:
                floors.append((r.size - 1, noise_floor(e[r])))
        rows = np.flatnonzero(m)
        for chunk in np.array_split(rows, min(10, rows.size)):
            v = _rms(e[chunk])
            if chunk.size and v > win[2]:
                win = (float(t[chunk[0]]), float(t[chunk[-1]]), v,
                       names[k] if k < len(names) else "",
                       bool(timed[k]) if k < len(timed) else True)
        es.append(e[m])
        ue.append(u[m])
        de.append(d[m])
        ne.append(near[m])
    if not es or sum(x.size for x in es) < 10:
        return None
    e, u, d, near = (np.concatenate(x) for x in (es, ue, de, ne))
    rmse = _rms(e)
    w = sum(n for n, _ in floors)
    floor = float(np.sqrt(sum(n * f * f for n, f in floors) / w)) if w else 0.0
    yr = float(np.ptp(np.concatenate([y[m] for y, m in zip(ys, masks, strict=True)])))
    floor = max(floor, RESOLUTION * yr)
    lo, hi = float(u.min()), float(u.max())
    edges = np.linspace(lo, hi, 6)
    band, band_rms = (lo, hi), 0.0
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        sel = (u >= a) & (u <= b)
        v = _rms(e[sel])
        if sel.sum() >= 3 and v > band_rms:
            band, band_rms = (float(a), float(b)), v
    branch, branch_rms = "", 0.0
    for dv, dname in ((1, "rising input"), (-1, "falling input")):
        for nv, nname in ((True, "just after a reversal"), (False, "further from the reversal")):
            sel = (d == dv) & (near == nv)
            v = _rms(e[sel])
            if sel.sum() >= 3 and v > branch_rms:
                branch, branch_rms = f"{dname} branch, {nname}", v
    ratio = rmse / floor if floor > 0 else float("inf")
    return Misfit(rmse, floor, ratio, band, band_rms, branch or "whole record", branch_rms,
                  (win[0], win[1]), win[2], win[3], win[4])


#: Across recordings with a time axis, the misfit is said to change with the input's rate
#: when their mean input speeds span at least this factor and either the residual's RMS
#: rises with the speed, the fastest recording's at least :data:`RATE_RESIDUAL_RATIO`
#: times the slowest's, or the loops' width misfit moves one way with the speed by at least
#: :data:`RATE_WIDTH_SHARE` of the pooled residual RMS. Friction damper at 30 lb (0.25 / 1
#: / 2 Hz, mean speeds 0.37 / 1.5 / 3.4 in/s, held-out rows of the diagnosis's stop base):
#: RMS 0.21 / 0.24 / 0.67 kip, width misfit +0.012 / -0.040 / -0.107 kip.
RATE_SPAN = 2.0
#: See :data:`RATE_SPAN`.
RATE_RESIDUAL_RATIO = 1.5
#: See :data:`RATE_SPAN`.
RATE_WIDTH_SHARE = 0.25


def rate_trend(records: Sequence[Recording], pred: Sequence[Float1D],
               rows: Sequence[np.ndarray]) -> tuple[tuple[str, float, float, float], ...]:
    """``(recording, mean input speed, residual RMS, width misfit)`` of each recording with a
    time axis on ``rows`` (input units per second, output units, output units), slowest
    first, when the misfit changes with the speed (:data:`RATE_SPAN`): a rate-independent
    base cannot follow it. The width misfit is the mean of the residual times the sign of
    the input's velocity: how much wider (> 0) the measured loop is than the model's, half
    its width; it falls with the speed where friction weakens with the sliding speed
    (Stribeck) and rises where a viscous force adds to it. Empty otherwise."""
    pts = []
    for r, p, m in zip(records, pred, rows, strict=True):
        if not r.has_time or m.sum() < 20:
            continue
        v = np.gradient(r.u, r.t)
        e = (r.y - p)[m]
        pts.append((float(np.mean(np.abs(v[m]))), float(np.sqrt(np.mean(e * e))),
                    float(np.mean(e * np.sign(v[m]))), r.name))
    if len(pts) < 2:
        return ()
    pts.sort()
    speeds, res, width = (np.array([p[i] for p in pts]) for i in range(3))
    if not (speeds[0] > 0 and speeds[-1] >= RATE_SPAN * speeds[0]):
        return ()
    pooled = float(np.sqrt(np.mean(res ** 2)))
    rising = res[-1] >= RATE_RESIDUAL_RATIO * res[0] and bool(np.all(np.diff(res) > 0))
    dw = np.diff(width)
    moving = (abs(width[-1] - width[0]) >= RATE_WIDTH_SHARE * pooled
              and (bool(np.all(dw > 0)) or bool(np.all(dw < 0))))
    if not (rising or moving):
        return ()
    return tuple((name, s, rr, w) for s, rr, w, name in pts)


def rate_words(records: Sequence[Recording],
               trend: tuple[tuple[str, float, float, float], ...]) -> str:
    """:func:`rate_trend`'s points in words, in the recordings' units (``""`` without)."""
    if not trend:
        return ""
    units = records[0].units
    ui, uo = units.get("input") or "input units", units.get("output") or "output units"
    each = ", ".join(f"{rr:.3g} {uo} on {name} (mean speed {s:.3g} {ui}/s, loop "
                     f"{abs(w):.3g} {uo} {'wider' if w >= 0 else 'narrower'} than the model's)"
                     for name, s, rr, w in trend)
    w0, w1 = trend[0][3], trend[-1][3]
    how = ("the loops narrow as the input speeds up: friction that weakens with the sliding "
           "speed (Stribeck)" if w1 < w0 else
           "the loops widen as the input speeds up: a viscous force")
    return (f"the misfit changes with the input's rate (RMS {each}): {how}, or chatter that "
            "grows with the speed; rate-dependent physics, which a rate-independent base "
            "does not follow")
