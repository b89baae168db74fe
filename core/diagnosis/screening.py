"""The part of a long recording that the searches over nonlinear parameters read.

A ranking solve (:meth:`~core.diagnosis.context.FitContext.rss`: the searches over a
delay, a time constant, a mode, a loop shape or an initial memory state) already solves on
a fixed number of training rows (:data:`~core.diagnosis.bankcache.RANKING_ROWS`), but it
forms the play bank and the output dynamics along the recording up to its last training
row, so each of its hundreds of solves costs time in proportion to the record. On a long
record whose input has repeated its events many times, a prefix holding enough of them
ranks the parameters as the whole record does: the search reads only that prefix, and the
parameters it finds are then fitted and scored on every training and test row. The report
says so (:func:`screening_note`).

Where the statistics do not allow it (a record with few events, or one whose input
reaches its full range only late), the search reads the whole record.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..recordings import Recording
from .events import event_starts

__all__ = ["RANKING_EVENTS", "RANKING_RANGE_SHARE", "RANKING_SPAN", "RANKING_TRAIN_ROWS",
           "ranking_span", "screening_note"]

#: Samples of a recording up to which the searches read all of it (issue 31's time target
#: counts from 100,000 samples; every shipped recording is shorter).
RANKING_SPAN = 100_000
#: Training rows the prefix holds at least (half of :data:`RANKING_SPAN`: an interleaved
#: split trains on half the rows).
RANKING_TRAIN_ROWS = RANKING_SPAN // 2
#: Input events (large reversals and steps, :func:`~core.diagnosis.events.event_starts`) in
#: training rows that the prefix holds at least, each with its response after it: eight
#: periods of a periodic input, as many as the training blocks of a 10 s recording of the
#: shipped piezo's 1 Hz cycle hold (a choice of cost against precision: a search's cost
#: grows with the prefix; the test plant's delay is recovered within 25 % from it).
RANKING_EVENTS = 16
#: Share of the input's range on all the training rows that the prefix's training rows
#: span, so a loop shape or a saturation is searched over the whole range of the input.
RANKING_RANGE_SHARE = 0.98


def ranking_span(rec: Recording, train: np.ndarray, events: np.ndarray | None = None) -> int:
    """Samples of ``rec``, from its first, whose training rows the searches over nonlinear
    parameters read.

    The shortest prefix, of more than :data:`RANKING_SPAN` samples only, whose training rows
    number :data:`RANKING_TRAIN_ROWS`, hold :data:`RANKING_EVENTS` input events followed by
    the start of the next one, and span :data:`RANKING_RANGE_SHARE` of the input range on all
    the training rows; the whole record (``rec.n_samples``) where no shorter prefix does.

    Parameters
    ----------
    rec : Recording
    train : ndarray of bool, shape (n_samples,)
        The training rows.
    events : ndarray of int, optional
        :func:`~core.diagnosis.events.event_starts` of ``rec.u`` (computed when not given).

    Returns
    -------
    int
        A sample count in ``[1, rec.n_samples]``.
    """
    n = rec.n_samples
    if n <= RANKING_SPAN or int(train.sum()) <= RANKING_TRAIN_ROWS:
        return n
    ev = event_starts(rec.u) if events is None else events
    ev = ev[train[ev]]
    if ev.size <= RANKING_EVENTS:
        return n
    idx = np.flatnonzero(train)
    u = np.asarray(rec.u, dtype=np.float64)[idx]
    reach = np.maximum.accumulate(u) - np.minimum.accumulate(u)
    full = int(np.searchsorted(reach, RANKING_RANGE_SHARE * float(reach[-1])))
    end = max(RANKING_SPAN, int(idx[RANKING_TRAIN_ROWS - 1]) + 1, int(ev[RANKING_EVENTS]),
              int(idx[min(full, idx.size - 1)]) + 1)
    return min(n, end)


def screening_note(records: Sequence[Recording], train: Sequence[np.ndarray]) -> str:
    """The report's words for the prefixes the searches read on the training rows
    ``train``; ``""`` when they read every recording whole."""
    parts = []
    for rec, m in zip(records, train, strict=True):
        k = ranking_span(rec, m)
        if k < rec.n_samples:
            parts.append(f"the first {k * rec.dt:.4g} s of {rec.name} ({k:,} of "
                         f"{rec.n_samples:,} samples)")
    if not parts:
        return ""
    return ("the searches over delays, time constants, modes, loop shapes and initial "
            f"memory read only {', '.join(parts)}, where the input's events repeat at least "
            f"{RANKING_EVENTS} times; every candidate is then fitted and scored on all rows")
