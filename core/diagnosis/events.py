"""Input events of a recording: the steps and reversals after which output dynamics show.

A delay, a lag or a lightly damped mode leaves its signature after each thing the input
does: a dead time after a reversal, an exponential approach after a step, a ringing at its
own frequency. One recording is evidence for such a stage only when the signature shows
after several independent events, not in one place (the first loading from rest, one step).
This module cuts a recording into event windows: from each event to the next.
"""

from __future__ import annotations

import numpy as np

from ..fitting.thresholds import reversal_indices
from ..recordings import Recording

__all__ = ["REVERSAL_TOL", "STEP_SHARE", "STEP_SAMPLES", "event_starts", "event_windows"]

#: Smallest travel of the input (fraction of its range) that makes a reversal an event.
REVERSAL_TOL = 0.1
#: Smallest input change (fraction of its range) within :data:`STEP_SAMPLES` samples that
#: makes a step an event.
STEP_SHARE = 0.05
#: Samples within which a step's change must happen (a step ramped over a few samples).
STEP_SAMPLES = 10


def event_starts(u: np.ndarray) -> np.ndarray:
    """Sample indices where an event starts: each large reversal, and the start of each
    step (a change of at least :data:`STEP_SHARE` of the input range within
    :data:`STEP_SAMPLES` samples, after a sample where the input was not already moving so).

    Parameters
    ----------
    u : ndarray, shape (n,)
        Input samples.

    Returns
    -------
    ndarray of int
        Sorted, unique indices in ``[0, n)``; the first sample is not an event.
    """
    u = np.asarray(u, dtype=np.float64)
    n = u.size
    span = float(np.ptp(u)) if n else 0.0
    if n < 3 or span <= 0:
        return np.zeros(0, dtype=np.int64)
    rv = reversal_indices(u, REVERSAL_TOL * span)
    k = min(STEP_SAMPLES, n - 1)
    fast = np.abs(u[k:] - u[:-k]) >= STEP_SHARE * span
    fast = np.concatenate([fast, np.zeros(k, dtype=bool)])
    first = np.flatnonzero(fast & ~np.concatenate([[False], fast[:-1]]))
    # the window that flags a step opens up to k samples before it: the step's event is the
    # sample after its first sample-to-sample change of at least half its largest one
    du = np.abs(np.diff(u))
    starts = np.array([s + 1 + int(np.argmax(du[s : s + k] >= 0.5 * du[s : s + k].max()))
                       for s in first], dtype=np.int64)
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
