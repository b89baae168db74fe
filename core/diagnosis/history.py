"""A misfit that depends on the input's state and history, against one that depends on time.

A rate-independent plant's output, and so its model's misfit, is a function of where the
input is and of what it did before (its direction, the reversals that set its memory), never
of the clock. When the base model cannot follow the plant's loops (a non-Masing steel whose
branch curvature depends on the previous excursion, a pinched loop), its misfit is large and
changes wherever the input's history changes: under a decaying sine or a protocol of growing
amplitude that is also from one moment to the next, and a slow polynomial in time (a drift),
an unknown state before the record (initial memory) or a rate term can take it up. A name
that says *time* (drift, creep, initial memory) or *rate* must therefore be earned by what a
history-dependent misfit cannot give: a change of the residual between moments at which the
input is at the same state with the same recent history (cycle to cycle of a repeated
input, along a hold, between first loadings from rest of several recordings), or the same
loop at different rates.

:func:`history_basis` spans such misfits: smooth functions of the input, its direction, its
last two reversals, and the first loading from rest apart, pooled over the recordings (the
same plant gives the same function in every recording). :func:`beyond_history` compares a
candidate with the current model once each residual's part in that span is removed
(acceptance rule 17, :func:`core.diagnosis.acceptance.beyond_history_ok`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..fitting.thresholds import reversal_indices
from .acceptance import beyond_history_ok
from .context import FitContext
from .events import REVERSAL_TOL
from .registry import EFFECTS
from .search import WHERE_MIN_ROWS
from .stats import HeldOut, heldout_comparison, with_where
from .structure import Fit

__all__ = ["HISTORY_KNOTS", "HISTORY_ROWS", "MIN_HISTORY_ROWS", "beyond_history",
           "history_basis", "history_refusal", "says_time"]

#: Knots of the hat basis in the input of :func:`history_basis` (over the pooled range).
HISTORY_KNOTS = 12
#: Largest number of training rows (evenly thinned) on which the history part is fitted.
HISTORY_ROWS = 40000

#: Weights of the hats after the first reversal, per direction: 1, the last reversal value
#: r, r^2, the one before it p, p^2 and r p (all scaled to [-1, 1]).
_WEIGHTS = 6


def history_basis(u: np.ndarray, lo: float, span: float,
                  rows: np.ndarray | None = None) -> np.ndarray:
    """History columns of one recording's input: functions of the input's value, of its
    direction of motion and of its last two reversal values, with the first loading from
    rest (the rows before the first reversal) in columns of its own; never of time or rate.

    Piecewise-linear hats on the input (:data:`HISTORY_KNOTS` knots over ``[lo, lo +
    span]``, the range of every recording of a diagnosis, so that one input value means
    one column in each) times 1, ``r``, ``r**2``, ``p``, ``p**2`` and ``r p`` (``r``: the last
    reversal value, ``p``: the one before, both scaled to [-1, 1]) separately while the
    input rises and falls (a hold keeps the direction of the motion before it); on the rows
    before the first reversal the hats alone, per direction.

    Parameters
    ----------
    u : ndarray, shape (n,)
        Input samples.
    lo, span : float
        Lowest input value and input range over all the recordings (input units).
    rows : ndarray of int, shape (m,), optional
        The rows wanted (default: all ``n``); the reversals are found on the whole input.

    Returns
    -------
    ndarray, shape (m, (2 * _WEIGHTS + 2) * HISTORY_KNOTS)
        Zero when ``span`` is not positive or the input does not move.
    """
    u = np.asarray(u, dtype=np.float64)
    n, k = u.size, HISTORY_KNOTS
    idx = np.arange(n) if rows is None else np.asarray(rows, dtype=np.int64)
    out = np.zeros((idx.size, (2 * _WEIGHTS + 2) * k))
    own = float(np.ptp(u)) if n else 0.0
    if span <= 0 or own <= 0 or idx.size == 0:
        return out
    rv = reversal_indices(u, REVERSAL_TOL * own)  # rv[0] == 0: the first sample
    at = np.searchsorted(rv, idx, side="right") - 1  # the last reversal at or before
    last = rv[at]
    prev = rv[np.maximum(at - 1, 0)]
    ui = u[idx]
    virgin = at == 0
    x = np.clip((ui - lo) / span, 0.0, 1.0) * (k - 1)
    hats = np.clip(1.0 - np.abs(x[:, None] - np.arange(k)[None, :]), 0.0, None)
    r = 2.0 * (u[last] - lo) / span - 1.0
    p = 2.0 * (u[prev] - lo) / span - 1.0
    rising = ui >= u[last]
    for j, w in enumerate((np.ones(idx.size), r, r * r, p, p * p, r * p)):
        cols = hats * (w * ~virgin)[:, None]
        out[:, 2 * j * k : (2 * j + 1) * k] = cols * rising[:, None]
        out[:, (2 * j + 1) * k : (2 * j + 2) * k] = cols * ~rising[:, None]
    c0 = 2 * _WEIGHTS * k
    out[:, c0 : c0 + k] = hats * (virgin & rising)[:, None]
    out[:, c0 + k : c0 + 2 * k] = hats * (virgin & ~rising)[:, None]
    return out


#: Share of the compared rows, those where the effect changes the prediction most, on which
#: its significance is also tested (as the engine does for output dynamics).
WHERE_SHARE = 0.2

#: Rows per block when the fitted history part is evaluated (bounds the basis' memory).
_BLOCK = 25000


def beyond_history(ctx: FitContext, cur: Fit, new: Fit,
                   rows: Sequence[np.ndarray] | None = None) -> HeldOut:
    """The current model against ``new`` (one effect more), each with its residual's
    history-dependent part (:func:`history_basis`, one least-squares fit over the training
    rows of every recording, thinned to :data:`HISTORY_ROWS`) removed, compared on ``rows``
    (one mask per recording; default the test rows): what the effect explains that a misfit
    depending on the input's state and history alone cannot. The MSE reduction is that of
    all those rows; the significance the better of all of them and of the
    :data:`WHERE_SHARE` where the effect changes the prediction most (signed-rank p doubled:
    Bonferroni over the two)."""
    lo = min(float(r.u.min()) for r in ctx.records)
    span = max(float(r.u.max()) for r in ctx.records) - lo
    n_train = sum(int(m.sum()) for m in ctx.train)
    step = max(1, n_train // HISTORY_ROWS)
    fit_idx = [np.flatnonzero(m)[::step] for m in ctx.train]
    F = np.concatenate([history_basis(r.u, lo, span, i)
                        for r, i in zip(ctx.records, fit_idx, strict=True)])
    where = [np.flatnonzero(m) for m in (ctx.test if rows is None else rows)]
    res = []
    for f in (cur, new):
        es = [rec.y - p for rec, p in zip(ctx.records, f.pred, strict=True)]
        e = np.concatenate([x[i] for x, i in zip(es, fit_idx, strict=True)])
        c = np.linalg.lstsq(F, e, rcond=None)[0]
        out = []
        for rec, x, w in zip(ctx.records, es, where, strict=True):
            parts = [x[w[a : a + _BLOCK]] - history_basis(rec.u, lo, span, w[a : a + _BLOCK]) @ c
                     for a in range(0, w.size, _BLOCK)]
            out.append(np.concatenate(parts) if parts else np.zeros(0))
        res.append(out)
    h = heldout_comparison(res[0], res[1])
    # its significance also where the effect changes the prediction most (the share
    # WHERE_SHARE of the rows, chosen from the two models' predictions alone): a time
    # effect concentrated in some recordings or segments (creep's fast lags at the fast
    # sines, its tail in the holds) is diluted in a batch-means test over every row
    d = [np.abs(a - b)[w] for a, b, w in zip(new.pred, cur.pred, where, strict=True)]
    pooled = np.concatenate(d) if d else np.zeros(0)
    if pooled.size < WHERE_MIN_ROWS or not np.any(pooled > 0):
        return h
    cut = float(np.quantile(pooled, 1.0 - WHERE_SHARE))
    top = [dd >= cut for dd in d]
    hw = heldout_comparison([r[m] for r, m in zip(res[0], top, strict=True)],
                            [r[m] for r, m in zip(res[1], top, strict=True)])
    return with_where(h, hw)


def says_time(name: str) -> bool:
    """Whether effect ``name`` claims a change with time or rate that a rate-independent
    plant cannot make (acceptance rule 17): a time-dependent effect that is not an output
    dynamics stage (drift, creep, rate; delay, lag and modes answer to rules 14-16), or one
    judged before the wipe-out time (initial memory)."""
    spec = EFFECTS[name]
    return bool((spec.time_dependent and spec.dynamics is None) or spec.before_wipeout)


#: Fewest rows on which :func:`history_refusal` judges an effect.
MIN_HISTORY_ROWS = 200


def _rows_of(ctx: FitContext, name: str) -> list[np.ndarray] | None:
    """The rows on which rule 17 compares ``name`` (``None``: the test rows): an initial
    memory on the rows before the wipe-out time (the only rows it changes; the training
    ones too, as it is judged there)."""
    if EFFECTS[name].before_wipeout:
        return ([a & b for a, b in zip(ctx.memory_masks, ctx.train, strict=True)]
                if ctx.strict else list(ctx.memory_masks))
    return None


def history_refusal(ctx: FitContext, cur: Fit, name: str, new: Fit) -> str | None:
    """Why acceptance rule 17 refuses candidate ``name`` (fit ``new`` on top of ``cur``), or
    ``None`` when it holds or does not apply (:func:`says_time`), when the rows it is
    judged on (:func:`_rows_of`) are fewer than :data:`MIN_HISTORY_ROWS`, or, for an
    initial memory, when only one recording has rows before its wipe-out time (its first
    loading is then compared with nothing: left to the effect's own rules, as before)."""
    if not says_time(name):
        return None
    rows = _rows_of(ctx, name)
    if rows is not None and sum(int(m.sum()) for m in rows) < MIN_HISTORY_ROWS:
        return None  # the effect's own rules decide where it has too few rows to judge
    if EFFECTS[name].before_wipeout and sum(1 for m in rows or () if m.any()) < 2:
        # one first loading: the history columns of the rows before the first reversal
        # would take up any initial state, so there is nothing to compare it with
        return None
    h = beyond_history(ctx, cur, new, rows)
    if beyond_history_ok(h):
        return None
    spec = EFFECTS[name]
    what = spec.history_experiment or "an input that revisits its states at other times"
    change = "rate" if spec.rate_dependent_hysteresis else "time"
    return (f"once the residual's part that depends on the input's state and history alone "
            f"(its value, direction and last two reversals; the first loading from rest "
            f"apart) is removed, it lowers the held-out MSE by {100 * h.gain:.1f} % (DM z "
            f"{h.z:.2f}, signed-rank p {h.sign_p:.2g}): a base that misses the plant's loops "
            f"(their shape changing with amplitude or with the previous excursion) explains "
            f"as much as a change with {change}, so the two are "
            f"ambiguous here ({what} would decide)")
