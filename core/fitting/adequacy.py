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

__all__ = ["MISFIT_RATIO", "Misfit", "misfit", "noise_floor"]

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
        The time window (s; a tenth of a recording's held-out rows) with the largest RMS
        residual, and ``recording`` its recording's name.
    window_rmse : float
    recording : str
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

    @property
    def exceeds(self) -> bool:
        """Whether the RMSE is above :data:`MISFIT_RATIO` floors."""
        return self.ratio > MISFIT_RATIO

    def text(self, pct: float | None = None, advice: str = "") -> str:
        """The warning in words (``pct``: the RMSE in % of the output range; ``advice``: what
        to try, default another fit kind or the diagnosis)."""
        share = f" ({pct:.3g} % of range)" if pct is not None and np.isfinite(pct) else ""
        rec = f" of {self.recording}" if self.recording else ""
        return (
            f"the held-out RMSE {self.rmse:.4g}{share} is {self.ratio:.0f} times the "
            f"white-noise floor {self.floor:.3g}: this model misses structure in the data. "
            f"Largest residuals: at inputs {self.input_band[0]:.4g} to "
            f"{self.input_band[1]:.4g} (RMS {self.input_band_rmse:.3g}), on the "
            f"{self.branch} (RMS {self.branch_rmse:.3g}), and in t = {self.window[0]:.4g} to "
            f"{self.window[1]:.4g} s{rec} (RMS {self.window_rmse:.3g}). "
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

    Returns
    -------
    Misfit or None
        ``None`` with fewer than 10 held-out rows.
    """
    es, ue, de, ne, floors = [], [], [], [], []
    win = (0.0, 0.0, 0.0, "")
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
                       names[k] if k < len(names) else "")
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
                  (win[0], win[1]), win[2], win[3])
