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

from ..fitting.cyclechange import CYCLE_TOL, START_TOL
from ..fitting.cycles import repeating_run
from ..fitting.thresholds import reversal_indices
from ..recordings import Recording
from .registry import SignatureRows

__all__ = ["CYCLE_TOL", "HISTORY_TOL", "MIN_CYCLES", "MIN_SAME_BRANCHES", "START_TOL",
           "cycle_to_cycle", "longest_repeating_run", "same_history", "repeated_cycles"]

#: Fewest identical input cycles that make a slow trend testable inside one recording.
MIN_CYCLES = 4
# CYCLE_TOL (fraction of the input range, RMS, within which one cycle repeats the next) and
# START_TOL (a cycle follows the one before it when it starts one period after it within
# this share of the period: no rest or missing cycle in between) are the fit's
# (core.fitting.cyclechange), so both commands find the same repeated cycles.


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
    return repeating_run(u, CYCLE_TOL, START_TOL)


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


#: Tolerance (fraction of the input range) within which two reversal values, and two input
#: values, count as the same in :func:`same_history`.
HISTORY_TOL = CYCLE_TOL
#: Fewest branches whose rows :func:`same_history` compares with an earlier branch of the
#: same history for a trend to be testable (two changes, as from cycle to cycle: the first
#: branches set the memory and are compared with nothing).
MIN_SAME_BRANCHES = 2


def _memory_keys(u: np.ndarray, rv: np.ndarray, tol: float) -> list[tuple[float, ...]]:
    """Per branch (the rows after reversal ``rv[k]`` up to the next), the input history a
    rate-independent model's output can depend on there: the alternating extrema the input
    has not wiped out yet (a new maximum reaching an earlier one within ``tol`` closes the
    loop it started, and that maximum and the minimum after it drop out; likewise for
    minima), ending with the branch's own start, and the reversal before it (what a model
    without the wiping-out property, a Menegotto-Pinto branch, reads as well). Branch 0
    (from the first sample: no reversal yet) has an empty key."""
    keys: list[tuple[float, ...]] = [()]
    stack: list[float] = []
    for k in range(1, rv.size):
        v = float(u[rv[k]])
        rising_to = v > float(u[rv[k - 1]])  # v is a maximum
        while len(stack) >= 2 and ((stack[-2] <= v + tol) if rising_to
                                    else (stack[-2] >= v - tol)):
            del stack[-2:]
        stack.append(v)
        keys.append((float(rising_to), float(u[rv[k - 1]]), *stack))
    return keys


def _same_key(a: tuple[float, ...], b: tuple[float, ...], tol: float) -> bool:
    """Whether two branches' memory keys (:func:`_memory_keys`) agree: the same direction
    and the same extrema within ``tol``."""
    return len(a) == len(b) and len(a) > 0 and a[0] == b[0] and float(np.max(
        np.abs(np.subtract(a[1:], b[1:])))) <= tol


def _samples_to_travel(branch: np.ndarray, travel: float) -> int:
    """Samples from a branch's reversal (``branch[0]``) until the input has moved ``travel``
    (input units) away from it; ``branch.size - 1`` if it never does."""
    moved = np.maximum.accumulate(np.abs(branch - branch[0]))
    return min(int(np.searchsorted(moved, travel)), branch.size - 1)


def _same_rate(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """Whether two branches (each the input from its reversal to its end, shape (n_a,) and
    (n_b,)) move at one input rate over their common stretch: the samples each needs to
    travel the shorter one's input travel (less ``tol``, so that noise on the extremum
    does not decide it) agree within :data:`START_TOL` of the first branch's and two
    samples. A branch that goes on to a larger extremum than the other (a cycle growing at
    one rate) is compared up to the other's end only, as is the last one, cut by the
    record's end."""
    travel = min(float(np.max(np.abs(a - a[0]))), float(np.max(np.abs(b - b[0])))) - tol
    if travel <= 0:
        return True
    na, nb = _samples_to_travel(a, travel), _samples_to_travel(b, travel)
    return abs(nb - na) <= START_TOL * na + 2


def _history_pairs(keys: list[tuple[float, ...]], branches: list[np.ndarray], tol: float,
                   settled_only: bool = False) -> list[tuple[int, int]]:
    """The ``(earlier, later)`` pairs of branches compared by :func:`same_history`.

    The branches (from the second on: the first sets the memory) are grouped by input
    history and rate: each joins the first group whose first branch has its key and its
    rate, either as long in samples (within :data:`START_TOL` and two: one period of a
    sine or triangle at one frequency, whose amplitude may grow or taper at the next
    reversal) or moving alike over their common stretch (:func:`_same_rate`: the same
    number of samples from the reversal to the shorter branch's travel, within
    :data:`START_TOL` and two: one input rate, so that a branch going on to a larger
    extremum, as in a triangle growing at one rate, joins the branch of its history before
    it); the last branch, cut by the record's end, when it is at most as long or by the
    second. A branch with no such group starts its own, so the branches of one history at
    another rate are paired among themselves, never with a branch at the first one's rate
    (the per-row check of :func:`same_history`, the same time since the reversal, drops the
    rows of a group's pair where the two part, as after the mid-point of a sine whose
    amplitude grows at the next reversal). In each group of ``N``, in time order, the
    ``i``-th is paired with the ``(i + ceil(N / 2))``-th, each branch in one pair at most.
    ``settled_only``: each group's first branch (the history's first visit) is paired with
    nothing, as the first cycle in :func:`cycle_to_cycle`.

    Parameters
    ----------
    keys : list of tuple of float
        Per branch, its memory key (:func:`_memory_keys`; branch 0, before the first
        reversal, is never paired).
    branches : list of ndarray
        Per branch, the input from its reversal to its end (both samples included), shape
        (n_k + 1,) for a branch of ``n_k`` samples.
    tol : float
        Input tolerance (input units) of the keys and of the travel.
    settled_only : bool
        Leave each group's first branch unpaired.

    Returns
    -------
    list of (int, int)
        Branch indices ``(earlier, later)``, in the order of the later branch.
    """
    groups: list[list[int]] = []
    last = len(keys) - 1
    for k in range(1, len(keys)):
        for g in groups:
            n0, nk = branches[g[0]].size, branches[k].size
            as_long = (abs(nk - n0) <= START_TOL * n0 + 2 if k < last
                       else nk <= (1 + START_TOL) * n0 + 2)
            if (_same_key(keys[g[0]], keys[k], tol)
                    and (as_long or _same_rate(branches[g[0]], branches[k], tol))):
                g.append(k)
                break
        else:
            groups.append([k])
    pairs: list[tuple[int, int]] = []
    for g in groups:
        if settled_only:
            g = g[1:]
        h = (len(g) + 1) // 2
        pairs.extend((g[i], g[i + h]) for i in range(len(g) - h)
                     if _same_key(keys[g[i]], keys[g[i + h]], tol))
    return sorted(pairs, key=lambda jk: jk[1])


def same_history(records: list[Recording], settled_only: bool = False
                 ) -> SignatureRows | None:
    """Where a slow change with time shows apart from the model's bias in recordings whose
    input revisits its states without repeating a whole cycle (a tapered sine whose
    amplitude ramps up and down, a few cycles at constant amplitude between): rows are
    compared with rows of an earlier branch (the rows between two reversals) that had the
    same input history. A rate-independent model's output, and so its misfit, depends only
    on the input's value, its direction and the extrema it has not wiped out yet (and the
    reversal before the branch, for a model without wiping out): rows on which those agree
    within :data:`HISTORY_TOL` of the input range, reached at the same rate (the same time
    since the branch's reversal within :data:`START_TOL`: output dynamics then act alike),
    get the same output from it, so their residuals' difference is what changed with time
    (the noise twice), however large the misfit. Each row is compared with the paired
    branch's row nearest its input value (within :data:`HISTORY_TOL`).

    The pairs (:func:`_history_pairs`): the ``N`` branches of one history at one rate (as
    long in samples, or the same number of samples from the reversal over their common
    stretch, so that in a cycle growing at one input rate the branch going on to a larger
    extremum is paired with the one before it), in time order, the first half each with
    the one ``ceil(N / 2)`` places later, so that every branch is in one pair at most.
    The test on these rows (:func:`~core.diagnosis.stats.heldout_comparison`) takes its
    batch means as independent; they are, under the null, only if no branch's noise enters two
    differences. Against one shared reference (``e_k - e_1`` for every later ``k``) every
    two differences correlate by +1/2: the variance of their mean grows with the square of
    their number while the batch means estimate it as growing linearly, so the z of pure
    noise spreads 1.8 times too wide (a Menegotto-Pinto null reached z 1.92). Chained
    (``e_k - e_(k-1)``, neighbours correlate by -1/2) the z is conservative (its spread
    0.4) and a steady trend shows only over one branch's time. Disjoint pairs half a group
    apart are independent and span the longest times that keep them so.

    ``settled_only``: a history's first visit is compared with nothing (its rows neither
    tested nor a reference). Where the recordings break Masing's rule and the base cannot
    follow them (:attr:`~core.diagnosis.context.FitContext.unsettled_memory`), a branch's
    output is not yet fixed by its history on the first visit: a non-Masing element's state
    at a reversal still carries the excursions before it, so the first cycle at a new
    amplitude differs from the second, the same way a drift over one cycle's time would
    (a Menegotto-Pinto null under a growing sine, two cycles per amplitude: `drift` named,
    z 6.4).

    ``None`` when fewer than :data:`MIN_SAME_BRANCHES` branches over all the recordings are
    paired with an earlier one (the first excursions set the memory and are compared with
    nothing; a decaying or growing sine never revisits a state)."""
    masks, prevs, n_branches, spans = [], [], 0, []
    for r in records:
        u = np.asarray(r.u, dtype=np.float64)
        m = np.zeros(u.size, dtype=bool)
        prev = np.full(u.size, -1, dtype=np.int64)
        masks.append(m)
        prevs.append(prev)
        span = float(np.ptp(u)) if u.size else 0.0
        if span <= 0:
            continue
        tol = HISTORY_TOL * span
        rv = reversal_indices(u, 0.1 * span)
        bounds = [*rv.tolist(), u.size - 1]
        keys = _memory_keys(u, rv, tol)
        branches = [u[bounds[k]:bounds[k + 1] + 1] for k in range(len(keys))]
        for j, k in _history_pairs(keys, branches, tol, settled_only):
            a, b = bounds[k] + 1, bounds[k + 1] + 1
            ja, jb = bounds[j] + 1, bounds[j + 1] + 1
            if b - a < 2 or jb - ja < 2:
                continue
            order = np.argsort(u[ja:jb], kind="stable")
            us = u[ja:jb][order]
            i = np.clip(np.searchsorted(us, u[a:b]), 1, us.size - 1)
            near = np.where(np.abs(us[i - 1] - u[a:b]) <= np.abs(us[i] - u[a:b]), i - 1, i)
            # at the same rate too: the same time since the branch's reversal (within
            # START_TOL of it, and two samples), so that an output lag, delay or mode,
            # which a faster branch shows more, is not read as a change with time
            since_k = np.arange(a, b) - bounds[k]
            since_j = order[near] + ja - bounds[j]
            ok = ((np.abs(us[near] - u[a:b]) <= tol)
                  & (np.abs(since_k - since_j) <= START_TOL * since_k + 2))
            if ok.sum() < 2:
                continue
            m[a:b] = ok
            prev[a:b] = np.where(ok, ja + order[near], -1)
            n_branches += 1
            spans.append(f"{r.name}: t = {r.t[a]:.3g} s against t = {r.t[ja]:.3g} s")
    if n_branches < MIN_SAME_BRANCHES:
        return None
    return SignatureRows(masks, f"of the same input history ({n_branches} branches each "
                                f"against an earlier one with the same input value, "
                                f"direction and unwiped extrema, each branch compared "
                                f"once; "
                                f"{'; '.join(spans[:3])}{'; ...' if len(spans) > 3 else ''})",
                         previous=prevs, beyond_history=True, raw_fit=True)
