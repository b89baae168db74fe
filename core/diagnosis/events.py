"""Input events of a recording: the steps and reversals after which output dynamics show.

A delay, a lag or a lightly damped mode leaves its signature after each thing the input
does: a dead time after a reversal, an exponential approach after a step, a ringing at its
own frequency. One recording is evidence for such a stage only when the signature shows
after several independent events, not in one place (the first loading from rest, one step).
This module cuts a recording into event windows: from each event to the next.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..fitting.thresholds import reversal_indices
from ..recordings import Recording

__all__ = ["QUIET_SHARE", "REVERSAL_TOL", "STEP_SAMPLES", "STEP_SHARE", "Excitation",
           "event_starts", "event_windows", "excitation", "step_starts"]

#: Smallest travel of the input (fraction of its range) that makes a reversal an event.
REVERSAL_TOL = 0.1
#: Smallest input change (fraction of its range) within :data:`STEP_SAMPLES` samples that
#: makes a step an event.
STEP_SHARE = 0.05
#: Samples within which a step's change must happen (a step ramped over a few samples).
STEP_SAMPLES = 10
#: Largest input change (fraction of its range) over the :data:`STEP_SAMPLES` samples before
#: a step: a step starts from rest.
QUIET_SHARE = 0.01


def _moving(u: np.ndarray) -> tuple[np.ndarray, float]:
    """``u`` as float64 and its range; the range is 0 when the input has too few samples
    (3) or does not move."""
    u = np.asarray(u, dtype=np.float64)
    span = float(np.ptp(u)) if u.size >= 3 else 0.0
    return u, max(span, 0.0)


def step_starts(u: np.ndarray) -> np.ndarray:
    """Sample indices where a step starts (the first sample after its first sample-to-sample
    change of at least half its largest one): a change of at least :data:`STEP_SHARE` of the
    input range within :data:`STEP_SAMPLES` samples, from an input held still
    (:data:`QUIET_SHARE`) over the samples before.

    Parameters
    ----------
    u : ndarray, shape (n,)
        Input samples.

    Returns
    -------
    ndarray of int
    """
    u, span = _moving(u)
    if span == 0.0:
        return np.zeros(0, dtype=np.int64)
    n = u.size
    k = min(STEP_SAMPLES, n - 1)
    fast = np.abs(u[k:] - u[:-k]) >= STEP_SHARE * span
    fast = np.concatenate([fast, np.zeros(k, dtype=bool)])
    first = np.flatnonzero(fast & ~np.concatenate([[False], fast[:-1]]))
    # the window that flags a step opens up to k samples before it
    du = np.abs(np.diff(u))
    out = [s + 1 + int(np.argmax(du[s : s + k] >= 0.5 * du[s : s + k].max())) for s in first]
    # a step leaves a rest: the input held still (QUIET_SHARE of its range) before it; a fast
    # stretch of a sine or a triangle is not a step
    return np.array([i for i in out if i - 1 >= k and float(np.ptp(u[i - 1 - k : i])) <= (
        QUIET_SHARE * span)], dtype=np.int64)


def event_starts(u: np.ndarray) -> np.ndarray:
    """Sample indices where an event starts: each large reversal, and the start of each
    step (:func:`step_starts`).

    Parameters
    ----------
    u : ndarray, shape (n,)
        Input samples.

    Returns
    -------
    ndarray of int
        Sorted, unique indices in ``[0, n)``; the first sample is not an event.
    """
    u, span = _moving(u)
    if span == 0.0:
        return np.zeros(0, dtype=np.int64)
    n = u.size
    rv = reversal_indices(u, REVERSAL_TOL * span)
    starts = step_starts(u)
    ev = np.union1d(rv, starts)
    return ev[(ev > 0) & (ev < n - 1)].astype(np.int64)


def event_windows(rec: Recording) -> list[tuple[int, int]]:
    """``(start, stop)`` sample ranges from each event to the next (the last to the end).

    Events closer than :data:`STEP_SAMPLES` samples to the one before are merged into it
    (a step ramped over a few samples is one event).
    """
    ev = event_starts(rec.u)
    if ev.size == 0:
        return []
    keep = [int(ev[0])]
    for e in ev[1:]:
        if e - keep[-1] >= STEP_SAMPLES:
            keep.append(int(e))
    bounds = [*keep, rec.n_samples]
    return [(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if b > a]


@dataclass(frozen=True)
class Excitation:
    """What the input of some recordings can tell apart output dynamics stages with.

    Attributes
    ----------
    steps : int
        Input steps (:func:`step_starts`) in all the recordings: after a step a dead time
        shows no response, a lag an immediate smooth one, a mode its ringing.
    rate_ratio : float
        Longest over shortest time between large reversals (median per recording, over the
        recordings; 1 for one rate): at several excitation rates a lag's phase saturates
        while a delay's grows with frequency.
    """

    steps: int
    rate_ratio: float


def excitation(records: Sequence[Recording]) -> Excitation:
    """The :class:`Excitation` of ``records`` (each with its own input)."""
    steps, spans = 0, []
    for r in records:
        steps += int(step_starts(r.u).size)
        span = float(np.ptp(r.u))
        if span <= 0:
            continue
        rv = reversal_indices(np.asarray(r.u, dtype=np.float64), REVERSAL_TOL * span)
        d = np.diff(r.t[rv[rv > 0]]) if rv.size > 2 else np.zeros(0)
        d = d[d > 0]
        if d.size:
            # within a recording: the spread of its half-periods (a sweep, a multisine)
            spans += [float(np.quantile(d, 0.1)), float(np.quantile(d, 0.9))]
    ratio = max(spans) / min(spans) if spans else 1.0
    return Excitation(steps, float(ratio))
