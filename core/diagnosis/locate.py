"""LOCATE: conditional-mean maps of a residual and where an improvement concentrates.

The maps bin the residual over the coordinates of the missing-physics notes §2.1: time
windows, input level × branch direction, input rate, time since the last reversal, time since
the last step, and frequency (Welch PSD and input coherence).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .._typing import Float1D
from ..fitting.thresholds import reversal_indices
from ..recordings import Recording

__all__ = ["Coordinates", "coordinates", "residual_maps", "where_improved"]


class Coordinates:
    """Conditioning variables of one recording (all arrays of shape (N,))."""

    def __init__(self, rec: Recording) -> None:
        u, dt = rec.u, rec.dt
        span = float(np.ptp(u)) or 1.0
        k = max(1, int(round(0.002 / dt)))  # ~2 ms smoothing of the derivative
        us = np.convolve(u, np.ones(2 * k + 1) / (2 * k + 1), mode="same") if u.size > 4 * k else u
        self.rate = np.gradient(us, dt)
        tol = 1e-3 * span
        still = np.abs(self.rate) * dt < 1e-4 * span
        self.branch = np.where(still, 0, np.sign(self.rate)).astype(int)
        rev = reversal_indices(u, 0.01 * span)
        self.t = rec.t
        idx = np.searchsorted(rev, np.arange(u.size), side="right") - 1
        self.since_reversal = (np.arange(u.size) - rev[np.maximum(idx, 0)]) * dt
        # steps: the input moves by > 2 % of its range within 5 ms and then holds, or jumps
        # by > 2 % of its range in one sample
        w = max(1, int(round(0.005 / dt)))
        prev = np.concatenate((np.full(min(w, u.size), u[0]), u[:-w]))[: u.size]
        jump = np.abs(u - prev) > 0.02 * span
        one = np.abs(np.diff(u, prepend=u[0])) > 0.02 * span
        steps = np.flatnonzero((jump & still) | one)
        if steps.size:
            starts = steps[np.concatenate(([True], np.diff(steps) > w))]
        else:
            starts = np.zeros(0, dtype=np.int64)
        self.step_starts = starts
        ar = np.arange(u.size)
        if starts.size:
            sidx = np.searchsorted(starts, ar, side="right") - 1
            self.since_step = np.where(
                sidx >= 0, (ar - starts[np.maximum(sidx, 0)]) * dt, np.nan
            )
        else:
            self.since_step = np.full(u.size, np.nan)
        self.hold = still
        self.tol = tol
        self.holds = _holds_after_change(u, still, dt, span)


def _holds_after_change(u: Float1D, still: np.ndarray, dt: float, span: float,
                        min_s: float = 0.5, moved: float = 0.02, settle: float = 0.005
                        ) -> list[tuple[int, int, float]]:
    """Holds of at least ``min_s`` seconds that follow an input change (a step or a ramp).

    A hold is a run of still samples whose input stays within ``settle`` of the range from
    its final value (a slow ramp sampled fast can look still: the hold starts where the
    input has settled); it follows an input change when the input moved by more than
    ``moved`` of its range since the previous hold (or the first sample). Returns
    ``(start, length, sign of the change)`` per hold, the relaxation / creep test whatever
    the shape of the change before it.
    """
    out: list[tuple[int, int, float]] = []
    if u.size < 2:
        return out
    edges = np.flatnonzero(np.diff(np.r_[0, still.astype(np.int8), 0]))
    prev = float(u[0])
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        seg = u[a:b]
        off = np.abs(seg - seg[-1]) > settle * span
        h0 = a + (int(np.flatnonzero(off)[-1]) + 1 if off.any() else 0)
        n = int(b - h0)
        change = float(u[h0]) - prev
        if n * dt >= min_s and abs(change) > moved * span:
            out.append((int(h0), n, float(np.sign(change))))
        if n * dt >= min_s:
            prev = float(u[b - 1])
    return out


def coordinates(records: Sequence[Recording]) -> list[Coordinates]:
    """:class:`Coordinates` of every recording."""
    return [Coordinates(r) for r in records]


def _binned(x: Float1D, e: Float1D, edges: Float1D) -> list[dict[str, float]]:
    out = []
    idx = np.digitize(x, edges) - 1
    for i in range(edges.size - 1):
        m = idx == i
        if m.sum() < 5:
            continue
        out.append(
            {
                "lo": float(edges[i]),
                "hi": float(edges[i + 1]),
                "mean": float(e[m].mean()),
                "rms": float(np.sqrt(np.mean(e[m] ** 2))),
                "n": int(m.sum()),
            }
        )
    return out


def residual_maps(
    records: Sequence[Recording],
    residuals: Sequence[Float1D],
    coords: Sequence[Coordinates],
    masks: Sequence[np.ndarray],
) -> dict[str, Any]:
    """Conditional-mean maps of the residual over the rows in ``masks``.

    Returns
    -------
    dict
        ``time`` (per recording: windows with mean and RMS), ``input_branch`` (input bins ×
        ascending/descending), ``rate`` (|rate| bins), ``since_reversal`` and ``since_step``
        (log-spaced bins, seconds), ``spectrum`` (the strongest residual PSD lines with their
        input coherence).
    """
    out: dict[str, Any] = {"time": []}
    for rec, e in zip(records, residuals, strict=True):
        nw = 40
        edges = np.linspace(rec.t[0], rec.t[-1] + 1e-12, nw + 1)
        out["time"].append({"recording": rec.name, "windows": _binned(rec.t, e, edges)})
    U = np.concatenate([r.u[m] for r, m in zip(records, masks, strict=True)])
    E = np.concatenate([e[m] for e, m in zip(residuals, masks, strict=True)])
    B = np.concatenate([c.branch[m] for c, m in zip(coords, masks, strict=True)])
    R = np.concatenate([np.abs(c.rate[m]) for c, m in zip(coords, masks, strict=True)])
    TR = np.concatenate([c.since_reversal[m] for c, m in zip(coords, masks, strict=True)])
    TS = np.concatenate([c.since_step[m] for c, m in zip(coords, masks, strict=True)])
    if E.size == 0:
        return out
    ue = np.linspace(U.min(), U.max() + 1e-12, 13)
    out["input_branch"] = {
        "ascending": _binned(U[B > 0], E[B > 0], ue),
        "descending": _binned(U[B < 0], E[B < 0], ue),
    }
    if R.max() > 0:
        out["rate"] = _binned(R, E, np.quantile(R, np.linspace(0, 1, 11)) + np.arange(11) * 1e-12)
    dtmin = min(r.dt for r in records)
    le = np.geomspace(dtmin, max(TR.max(), 2 * dtmin), 13)
    out["since_reversal"] = _binned(np.maximum(TR, dtmin), E, le)
    ok = np.isfinite(TS)
    if ok.sum() > 10:
        le = np.geomspace(dtmin, max(TS[ok].max(), 2 * dtmin), 13)
        out["since_step"] = _binned(np.maximum(TS[ok], dtmin), E[ok], le)
    out["spectrum"] = _spectrum(records, residuals)
    return out


#: Records longer than this (samples) have their residual spectrum averaged over chunks of
#: Welch segments (:func:`_welch_in_chunks`); scipy's Welch and coherence on the whole record
#: hold about 48 bytes per sample of segments (193 MB at 4 million samples).
SPECTRUM_WHOLE = 2**20
#: Samples of the Welch segments of one chunk (at least one segment).
SPECTRUM_CHUNK = 2**20


def _welch_in_chunks(u: Float1D, e: Float1D, fs: float, nper: int
                     ) -> tuple[Float1D, Float1D, Float1D]:
    """Welch's power spectrum of ``e`` and the coherence of ``u`` and ``e`` (Hann window,
    ``nper``-sample segments overlapping by half, each detrended by its mean: scipy's
    defaults), each segment's periodogram averaged as scipy does, but over chunks of
    segments, so that at most :data:`SPECTRUM_CHUNK` samples of segments are held at once.
    Equal to ``scipy.signal.welch`` / ``coherence`` on the whole record to round-off."""
    import scipy.signal as ss

    step = nper - nper // 2
    n_seg = (e.size - nper) // step + 1
    per = max(1, SPECTRUM_CHUNK // nper)
    sums: list[Any] = [0.0, 0.0, 0.0]
    f = np.zeros(0)
    for a in range(0, n_seg, per):
        m = min(per, n_seg - a)
        sl = slice(a * step, (a + m - 1) * step + nper)
        f, pee = ss.welch(e[sl], fs=fs, nperseg=nper)
        _, puu = ss.welch(u[sl], fs=fs, nperseg=nper)
        _, pue = ss.csd(u[sl], e[sl], fs=fs, nperseg=nper)
        for i, v in enumerate((pee, puu, pue)):
            sums[i] = sums[i] + m * v
    pee, puu, pue = (v / n_seg for v in sums)
    return f, pee, np.abs(pue) ** 2 / puu / pee


def _spectrum(records: Sequence[Recording], residuals: Sequence[Float1D]) -> list[dict[str, float]]:
    import scipy.signal as ss

    if not all(r.has_time for r in records):
        return []  # no time axis: no frequency
    rec, e = max(zip(records, residuals, strict=True), key=lambda p: p[0].n_samples)
    fs = 1.0 / rec.dt
    nper = int(min(rec.n_samples // 4, 2 ** int(np.log2(max(16, rec.n_samples // 8)))))
    if nper < 16:
        return []
    if rec.n_samples <= SPECTRUM_WHOLE:
        f, P = ss.welch(e - e.mean(), fs=fs, nperseg=nper)
        _, C = ss.coherence(rec.u, e, fs=fs, nperseg=nper)
    else:
        f, P, C = _welch_in_chunks(rec.u, e - e.mean(), fs, nper)
    top = np.argsort(P[1:])[::-1][:6] + 1
    return [
        {"freq_hz": float(f[i]), "psd": float(P[i]), "coherence": float(C[i])}
        for i in sorted(top, key=lambda j: f[j])
    ]


def where_improved(
    records: Sequence[Recording],
    e_before: Sequence[Float1D],
    e_after: Sequence[Float1D],
    coords: Sequence[Coordinates],
) -> dict[str, Any]:
    """Where (time, input level, branch, time since reversal/step) the squared error dropped.

    Returns
    -------
    dict
        ``time_windows``: ``[recording, t0, t1, share]`` for the fewest 0.5 %-of-record windows
        holding half of the total squared-error reduction; ``input_range``: the input interval
        holding the middle 80 % of the reduction; ``branch``: share of the reduction on
        ascending / descending / hold samples; ``median_since_reversal_s`` and
        ``median_since_step_s``: reduction-weighted medians; ``summary``: one sentence.
    """
    rows = []
    wts_u, wts_b, wts_r, wts_s = [], [], [], []
    total = 0.0
    for rec, a, b, c in zip(records, e_before, e_after, coords, strict=True):
        d = a * a - b * b
        total += float(np.clip(d, 0, None).sum())
        nw = max(10, min(200, rec.n_samples // 50))
        edges = np.linspace(0, rec.n_samples, nw + 1).astype(int)
        for i in range(nw):
            s = float(d[edges[i] : edges[i + 1]].sum())
            rows.append((s, rec.name, float(rec.t[edges[i]]), float(rec.t[edges[i + 1] - 1])))
        pos = np.clip(d, 0, None)
        wts_u.append((rec.u, pos))
        wts_b.append((c.branch, pos))
        wts_r.append((c.since_reversal, pos))
        wts_s.append((c.since_step, pos))
    rows.sort(key=lambda r: -r[0])
    net = sum(r[0] for r in rows)
    sel, acc = [], 0.0
    for r in rows:
        if r[0] <= 0 or (net > 0 and acc >= 0.5 * net):
            break
        sel.append(r)
        acc += r[0]
    sel.sort(key=lambda r: (r[1], r[2]))
    merged: list[list[Any]] = []
    for s, name, t0, t1 in sel:
        if merged and merged[-1][0] == name and t0 - merged[-1][2] < 1.5 * (t1 - t0 + 1e-12):
            merged[-1][2] = t1
            merged[-1][3] += s / net if net > 0 else 0.0
        else:
            merged.append([name, t0, t1, s / net if net > 0 else 0.0])
    U = _joined([u for u, _ in wts_u])
    W = _joined([w for _, w in wts_u])
    Bb = _joined([b for b, _ in wts_b])
    out: dict[str, Any] = {"time_windows": [[m[0], round(m[1], 4), round(m[2], 4),
                                             round(m[3], 3)] for m in merged[:12]]}
    if W.sum() > 0:
        o = np.argsort(U)
        cw = np.cumsum(W[o]) / W.sum()
        i10, i90 = np.searchsorted(cw, 0.1), min(int(np.searchsorted(cw, 0.9)), U.size - 1)
        out["input_range"] = [float(U[o[i10]]), float(U[o[i90]])]
        del o, cw
        out["branch"] = {
            "ascending": float(W[Bb > 0].sum() / W.sum()),
            "descending": float(W[Bb < 0].sum() / W.sum()),
            "hold": float(W[Bb == 0].sum() / W.sum()),
        }
        out["median_since_reversal_s"] = _wmedian(_joined([x for x, _ in wts_r]), W)
        TS = _joined([x for x, _ in wts_s])
        ok = np.isfinite(TS)
        if ok.any() and W[ok].sum() > 0:
            out["median_since_step_s"] = _wmedian(TS[ok], W[ok])
    out["summary"] = _summary(out, total, all(r.has_time for r in records))
    return out


def _joined(parts: list[np.ndarray]) -> np.ndarray:
    """``parts`` end to end; the one part itself (not a copy) for one recording."""
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


def _wmedian(x: Float1D, w: Float1D) -> float:
    o = np.argsort(x)
    cw = np.cumsum(w[o])
    return float(x[o[min(np.searchsorted(cw, 0.5 * cw[-1]), x.size - 1)]])


def _summary(w: dict[str, Any], total: float, timed: bool = True) -> str:
    """:func:`where_improved`'s sentence; ``timed``: the recordings have a time axis (else
    its times are sample numbers and are said so)."""
    if total <= 0 or not w.get("time_windows"):
        return "no localised improvement"
    tw = w["time_windows"]
    unit = "s" if timed else "samples"
    parts = [
        "half of the error reduction lies in "
        + ", ".join(f"{n} {a:g}-{b:g} s" if timed else f"{n} samples {a:g}-{b:g}"
                    for n, a, b, _ in tw[:3])
        + (" ..." if len(tw) > 3 else "")
    ]
    if "input_range" in w:
        lo, hi = w["input_range"]
        parts.append(f"input {lo:.3g}..{hi:.3g}")
    br = w.get("branch", {})
    if br:
        k = max(br, key=br.get)
        parts.append(f"mostly {k} ({100 * br[k]:.0f} %)" if br[k] > 0.6 else "on both branches")
    if "median_since_reversal_s" in w:
        parts.append(f"median {w['median_since_reversal_s']:.3g} {unit} after a reversal")
    return "; ".join(parts)
