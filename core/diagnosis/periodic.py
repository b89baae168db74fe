"""Periodic steady-state recordings: one input cycle repeated, the output already periodic,
or a single closed loop (one cycle whose input and output return to where they started, as
a measured B-H loop).

Such a recording did not start from the virgin memory state: its memory at the first sample
is the one its own cycle leaves. Starting the model virgin would leave an error before the
wipe-out time that an ``initial-memory`` finding would then "explain" (an artefact); instead
the baseline starts from the cycle's own extrema.
"""

from __future__ import annotations

import numpy as np

from ..fitting.cycles import input_cycles
from ..fitting.thresholds import reversal_indices, wipeout_index
from ..recordings import Recording
from .registry import SignatureRows

__all__ = ["CLOSED_TOL", "CYCLE_TOL", "MIN_CYCLES", "START_TOL", "STEADY_TOL",
           "closed_loop_history", "cycle_to_cycle", "longest_repeating_run",
           "repeated_cycles", "steady_state_history"]

#: Allowance (fraction of the output range) on top of 1.5x the period-to-period RMS
#: difference of the later periods, within which the first period counts as steady state.
STEADY_TOL = 0.002

#: A single cycle is a closed loop when its last sample is within this fraction of the input
#: range and of the output range of its first sample.
CLOSED_TOL = 0.02


def steady_state_history(rec: Recording) -> tuple[float, ...]:
    """Virtual input history that puts the memory in the recording's periodic steady state.

    Returns ``(first, second)``: the cycle's two extremes in the order the input last visits
    them before one period has elapsed; empty when the input is not one cycle repeated (at
    least three periods, ``u(t + T)`` within 2 % of the input range of ``u(t)`` over the
    whole record) or when the output of the first period differs from the second's by more
    than 1.5 times the second's difference from the third plus :data:`STEADY_TOL` of the
    output range, on the rows before the wipe-out time (a virgin start, or a transient).
    """
    u, y = rec.u, rec.y
    span = float(np.ptp(u))
    if span <= 0:
        return ()
    rv = reversal_indices(u, 0.1 * span)
    rv = rv[(rv > 0) & (rv < u.size - 1)]
    if rv.size < 4:
        return closed_loop_history(rec)
    period = int(rv[2] - rv[0])
    if period < 4 or 3 * period > u.size:
        return closed_loop_history(rec)
    ext = u[rv]
    if np.ptp(ext[::2]) > 0.02 * span or np.ptp(ext[1::2]) > 0.02 * span:
        return ()
    # the whole record is the one cycle repeated (not a sweep, not a decaying sine)
    if np.sqrt(np.mean((u[:-period] - u[period:]) ** 2)) > 0.02 * span:
        return ()
    # the first period's output repeats as well as the later periods repeat each other
    # (noise), plus STEADY_TOL of the output range
    yr = float(np.ptp(y)) or 1.0
    # (on the rows before the wipe-out time: the only rows an initial memory changes)
    w = max(min(wipeout_index(u), period), 2)
    d12 = float(np.sqrt(np.mean((y[:w] - y[period : period + w]) ** 2)))
    d23 = float(np.sqrt(np.mean((y[period : period + w] - y[2 * period : 2 * period + w]) ** 2)))
    if d12 > 1.5 * d23 + STEADY_TOL * yr:
        return ()
    seg = u[1 : period + 1]
    i_hi, i_lo = int(np.argmax(seg)), int(np.argmin(seg))
    hi, lo = float(seg[i_hi]), float(seg[i_lo])
    return (hi, lo) if i_hi < i_lo else (lo, hi)


def closed_loop_history(rec: Recording) -> tuple[float, ...]:
    """Virtual input history of a single closed loop (e.g. one measured B-H loop).

    The recording is one cycle: at most two large input reversals (> 10 % of the input
    range) inside it, and its last sample within :data:`CLOSED_TOL` of the input range and
    of the output range of its first sample. A closed loop is its own steady state: the
    memory at its first sample is the one the cycle leaves at its last. Returns the cycle's
    two extremes in the order the input visits them (empty when it is not a closed loop).
    """
    u, y = rec.u, rec.y
    span, yr = float(np.ptp(u)), float(np.ptp(y))
    if span <= 0 or u.size < 8:
        return ()
    rv = reversal_indices(u, 0.1 * span)
    rv = rv[(rv > 0) & (rv < u.size - 1)]
    if not 1 <= rv.size <= 2:
        return ()
    if abs(u[-1] - u[0]) > CLOSED_TOL * span or abs(y[-1] - y[0]) > CLOSED_TOL * yr:
        return ()
    seg = u[1:]
    i_hi, i_lo = int(np.argmax(seg)), int(np.argmin(seg))
    if float(seg[i_hi] - seg[i_lo]) < 0.9 * span:
        return ()
    hi, lo = float(seg[i_hi]), float(seg[i_lo])
    return (hi, lo) if i_hi < i_lo else (lo, hi)


#: Fewest identical input cycles that make a slow trend testable inside one recording.
MIN_CYCLES = 4
#: Tolerance (fraction of the input range, RMS) within which one cycle repeats the next.
CYCLE_TOL = 0.02
#: A cycle follows the one before it when it starts one period after it within this share
#: of the period (no rest or missing cycle in between).
START_TOL = 0.05


def repeated_cycles(u: np.ndarray) -> tuple[tuple[int, int], ...]:
    """The longest run of whole input cycles that repeat one another, as sample ranges.

    Under a periodic input a rate-independent model repeats its output from one cycle to the
    next once the first cycle has set its memory, so a trend from cycle to cycle (a drift,
    the slow tail of creep) is testable inside one recording. The cycles are those of
    :func:`core.fitting.cycles.input_cycles` (each starts where the input rises through its
    median; the period is the median spacing of those starts, so a measured drive whose
    period is not a whole number of samples is followed cycle by cycle); a cycle belongs to
    the run when it starts one period (within :data:`START_TOL`) after the cycle before it
    and its input is within :data:`CYCLE_TOL` of the input range (RMS) of that cycle's.

    Parameters
    ----------
    u : ndarray, shape (n,)
        Input samples.

    Returns
    -------
    tuple of (int, int)
        ``(start, stop)`` sample ranges of consecutive cycles (each one period long), at
        least :data:`MIN_CYCLES` of them, or empty when the input does not repeat.
    """
    run = longest_repeating_run(u)
    return run if len(run) >= MIN_CYCLES else ()


def longest_repeating_run(u: np.ndarray) -> tuple[tuple[int, int], ...]:
    """The longest run of consecutive repeating cycles (:func:`repeated_cycles` without its
    :data:`MIN_CYCLES` floor; empty when the input has no whole cycle)."""
    u = np.asarray(u, dtype=np.float64)
    cyc = input_cycles(u)
    if cyc is None:
        return ()
    span = float(np.ptp(u))
    T = cyc.period
    best: list[tuple[int, int]] = []
    run: list[tuple[int, int]] = []
    for a, b in cyc.spans():
        if run:
            p = run[-1][0]
            if abs(a - p - T) > START_TOL * T or np.sqrt(
                    np.mean((u[a:b] - u[p : p + T]) ** 2)) > CYCLE_TOL * span:
                run = []
        run.append((a, b))
        if len(run) > len(best):
            best = list(run)
    return tuple(best)


def cycle_to_cycle(records: list[Recording]) -> SignatureRows | None:
    """Where a slow change with time (a drift, the settling of creep) shows apart from the
    model's bias: in a single recording whose input repeats one cycle
    (:func:`repeated_cycles`), the change from one cycle to the next. A rate-independent
    model repeats its output once the first cycle has set its memory, so each row of the
    third cycle on is compared as its residual's change from the same row one cycle before
    (the base's misfit, which repeats, cancels; a change with time does not). ``None`` with
    several recordings (whose differences already test a change with time) or when the one
    recording does not repeat its input."""
    if len(records) != 1:
        return None
    r = records[0]
    cyc = repeated_cycles(r.u)
    if not cyc:
        return None
    m = np.zeros(r.n_samples, dtype=bool)
    prev = np.full(r.n_samples, -1, dtype=np.int64)
    # the first cycle sets the memory: cycles from the third on, each against the one before
    for (a, b), (p, _) in zip(cyc[2:], cyc[1:-1], strict=True):
        m[a:b] = True
        prev[a:b] = np.arange(p, p + (b - a))
    return SignatureRows([m], f"cycle to cycle after the first ({r.name}: each of "
                              f"{len(cyc) - 2} repeated input cycles from t = "
                              f"{r.t[cyc[2][0]]:.4g} s against the one before)",
                         previous=[prev])
