"""A slow term fitted where it is judged: on the changes between training rows of the same
input history.

A drift, or the settling of creep under a repeated input, is judged on the held-out rows of
its signature as changes ``e[t] - e[previous[t]]`` between rows of the same input history
(:class:`~core.diagnosis.registry.SignatureRows` with ``previous``: one input cycle apart,
:func:`~core.diagnosis.periodic.cycle_to_cycle`, or an earlier branch of the same history,
:func:`~core.diagnosis.periodic.same_history`). There the base's misfit, which repeats with
the input's history, cancels. Fitted jointly with the base on the raw training rows, the
same slow columns (a polynomial in time, a bank of slow lags) are free to absorb that misfit
instead: on a base that misses the loop's shape the fitted drift follows the misfit (a
Menegotto-Pinto plant: 87 % worse on its own rows) and the held-out changes get worse, not
better.

So the term's weights are estimated from the same kind of evidence as it is judged on: the
least-squares fit of the changes of the residual left by the structure without the term,
``d_t = e0[t] - e0[previous[t]]``, on the changes of the term's columns,
``g[t] - g[previous[t]]``, over the pairs whose two rows are both training rows (the
within-history estimator: the same as fitting the term beside one free level per input
history, which takes every misfit that depends on the history alone). The base's columns
drop out of the changes (a rate-independent model gives both rows of a pair the same
output), so no base weight enters this solve. The rest of the structure is then solved on
the raw training rows with the term held at those weights
(:func:`~core.diagnosis.structure.fit_structure`, ``held``). A weight whose column does not
change over at least :data:`MIN_PAIRS_PER_WEIGHT` pairs (a drift of a recording that never
revisits its history) is left to the raw solve as before.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..fitting.gram import COND_LIMIT, r_factor, solve_constrained
from .registry import EFFECTS, SignatureRows, term_of
from .structure import Fit, HeldWeights, Structure, term_columns_at

if TYPE_CHECKING:
    from .context import FitContext

__all__ = ["MAX_CHANGE_PAIRS", "MIN_CHANGE_SHARE", "MIN_PAIRS_PER_WEIGHT", "REPEAT_FACTOR",
           "changed_terms",
           "training_pairs",
           "weights_on_changes"]

#: Fewest training pairs over which a weight's column changes for the weight to be fitted
#: on the changes (else it is solved with the rest on the raw rows).
MIN_PAIRS_PER_WEIGHT = 20
#: Smallest change of a column over the pairs (its RMS change as a share of its RMS swing
#: about its mean on their rows), relative to the most changing column of the same term,
#: for its weight to be fitted on the changes (a rank tolerance): a column that changes far
#: less from one visit of a history to the next repeats with the history and acts as part
#: of the loop (the fast end of a creep bank, a lag shorter than the input's period, whose
#: settling is over before the compared cycles); the changes do not determine its weight
#: (a 0.1 s lag under a 1 Hz cycle, changing 1e-5 times as much as the 10 s lag, got 8085
#: from them on the shipped piezo recording), the raw rows do.
MIN_CHANGE_SHARE = 0.01
#: A column's change share (above) must exceed this many times the hysteresis output's own
#: (the part of a column's change a pairing one or two samples off leaves although the
#: column repeats: a 10 ms lag under a 1 Hz cycle at 1 kHz, paired one sample off, changed
#: as much as the 10 s lag and got a weight of 0.82 from the base misfit's slope).
REPEAT_FACTOR = 2.0
#: Most pairs the changes are solved on (evenly thinned beyond: neighbouring samples are
#: nearly redundant, as in the structure fit's own rows).
MAX_CHANGE_PAIRS = 20_000


def changed_terms(ctx: FitContext, s: Structure) -> tuple[tuple[str, ...], SignatureRows | None]:
    """The static terms of ``s`` judged on changes from cycle to cycle of a repeated input
    (their effect's signature has ``previous``), and those rows; with several such terms,
    those whose rows are the first one's (a drift and a creep both from cycle to cycle).

    None with strict hold-out (explicit windows, and its cross-fitting folds): a candidate
    is then judged on cross-fitted raw training blocks, not on changes.

    Not the rows paired between branches of the same input history
    (:func:`~core.diagnosis.periodic.same_history`, ``SignatureRows.raw_fit``): their
    training pairs cover a short stretch of each recording (on the development
    Menegotto-Pinto plant with a concealed drift, 0.2 s of the 3 s sine, the held-out pairs
    all later), so a polynomial in time fitted on them is extrapolated to the rows it is
    judged on (-660 % there, against -150 % fitted on the raw rows); such a term is solved
    on the raw rows as before."""
    if ctx.strict or ctx.within_strict:
        # strict hold-out: every candidate is judged on cross-fitted raw training blocks,
        # so it is fitted on raw rows too
        return (), None
    names: list[str] = []
    first: SignatureRows | None = None
    for name, _ in s.terms:
        spec = EFFECTS[name]
        sig = spec.signature(ctx) if spec.signature is not None else None
        if sig is None or sig.previous is None or sig.raw_fit:
            # (rows paired by their history between branches, not whole cycles: see above)
            continue
        if first is None:
            first = sig
        elif not all(np.array_equal(a, b) for a, b in
                     zip(first.previous or [], sig.previous, strict=True)):
            continue
        names.append(name)
    return tuple(names), first


def training_pairs(sig: SignatureRows, train: list[np.ndarray]) -> list[tuple[np.ndarray,
                                                                              np.ndarray]]:
    """Per recording, the pairs ``(t, p)`` of training rows of the same history: every
    training row ``t`` of ``sig`` with the nearest earlier training row ``p`` reached through
    ``sig.previous`` (one cycle back, or two when the cycle before is held out, ...; never
    the first cycle, which sets the memory and has no ``previous`` itself), as two index
    arrays (at most :data:`MAX_CHANGE_PAIRS` over all the recordings, evenly thinned). The
    held-out blocks alternate with the training ones, so a row and the row one cycle
    before are seldom both training rows."""
    assert sig.previous is not None
    out = []
    for prev, tr in zip(sig.previous, train, strict=True):
        t = np.flatnonzero((prev >= 0) & tr)
        p = prev[t]
        for _ in range(prev.size):
            back = (p >= 0) & ~tr[np.maximum(p, 0)]
            if not back.any():
                break
            p[back] = prev[p[back]]
        keep = p >= 0
        out.append((t[keep], p[keep]))
    n = sum(a.size for a, _ in out)
    step = max(1, -(-n // MAX_CHANGE_PAIRS))
    return [(a[::step], b[::step]) for a, b in out]


def weights_on_changes(ctx: FitContext, s: Structure, names: tuple[str, ...],
                       sig: SignatureRows, f0: Fit) -> tuple[HeldWeights, ...]:
    """The weights of the terms ``names`` of ``s`` fitted on the changes between training
    rows of the same history (``sig``), from ``f0``: ``s`` fitted without those terms (its
    residual is what the changes are taken of; its PI-stage output is what a term acting
    before the output dynamics reads). Empty when no weight has
    :data:`MIN_PAIRS_PER_WEIGHT` changing pairs."""
    pairs = training_pairs(sig, ctx.train)
    if sum(a.size for a, _ in pairs) < MIN_PAIRS_PER_WEIGHT:
        return ()
    lo = min(float(r.y[m].min()) for r, m in zip(ctx.records, ctx.train, strict=True) if m.any())
    hi = max(float(r.y[m].max()) for r, m in zip(ctx.records, ctx.train, strict=True) if m.any())
    center, half = 0.5 * (lo + hi), max(0.5 * (hi - lo), 1e-12)
    D_parts, d_parts, G_parts, X_parts = [], [], [], []
    for k, (a, b) in enumerate(pairs):
        if not a.size:
            continue
        rows = np.unique(np.concatenate((a, b)))
        ia, ib = np.searchsorted(rows, a), np.searchsorted(rows, b)
        x = None if f0.x_pi is None else f0.x_pi[k]
        G = np.column_stack([term_columns_at(s, n, ctx.records, k, rows, x, center, half)
                             for n in names])
        e = ctx.records[k].y[rows] - np.asarray(f0.pred[k])[rows]
        D_parts.append(G[ia] - G[ib])
        G_parts.append(G)
        if x is not None:
            xr = np.asarray(x[: int(rows[-1]) + 1])[rows]
            X_parts.append((xr[ia] - xr[ib], xr))
        d_parts.append(e[ia] - e[ib])
    D, d, G_all = np.vstack(D_parts), np.concatenate(d_parts), np.vstack(G_parts)
    widths = [term_of(n).width(s.term(n), len(ctx.records)) for n in names]
    lower = np.concatenate([np.full(w, term_of(n).lower) for n, w in zip(names, widths,
                                                                       strict=True)])
    # a column that repeats itself from one visit of a history to the next (the fast end
    # of a creep bank: a lag shorter than the period) acts as part of the loop and is not
    # identified by the changes: left to the raw solve with the base
    share = np.sqrt(np.mean(D**2, axis=0)) / np.maximum(
        np.sqrt(np.mean((G_all - G_all.mean(axis=0)) ** 2, axis=0)), np.finfo(float).tiny)
    most = np.concatenate([np.full(w, share[o : o + w].max(initial=0.0)) for o, w in
                           zip(np.cumsum([0, *widths[:-1]]), widths, strict=True)])
    # the same share of the hysteresis output itself, which repeats with the history:
    # what a pairing one sample off (a measured drive's period is not a whole number of
    # samples) leaves of a repeating column; a column must change twice as much
    floor = 0.0
    if X_parts:
        dx = np.concatenate([a for a, _ in X_parts])
        xs = np.concatenate([b for _, b in X_parts])
        floor = float(np.sqrt(np.mean(dx**2)) / max(float(np.std(xs)), np.finfo(float).tiny))
    sup = ((np.count_nonzero(D, axis=0) >= MIN_PAIRS_PER_WEIGHT)
           & (share > REPEAT_FACTOR * floor) & (share >= MIN_CHANGE_SHARE * most))
    if not sup.any():
        return ()
    A = np.column_stack((D[:, sup], d))
    w = np.zeros(D.shape[1])
    sol = solve_constrained(lower[sup], gram=A.T @ A, cond_limit=COND_LIMIT)
    if sol.cond > COND_LIMIT:  # (nearly collinear slow lags: from the triangular factor)
        sol = solve_constrained(lower[sup], factor=r_factor(A))
    w[sup] = sol.theta
    out, o = [], 0
    for n, width in zip(names, widths, strict=True):
        out.append(HeldWeights(n, w[o : o + width], sup[o : o + width].copy()))
        o += width
    return tuple(out)
