"""What the recordings can test, and the evidence that separates look-alike effects.

``untestable`` lists the effects the recordings cannot excite (with the reason and the
experiment that would decide); ``discriminators`` (reversible/hysteretic split of the
residual rate, g2/g1²), ``sign_locking`` (creep vs drift after holds) and ``score``
(an LM score statistic of a candidate against the current model) feed the look-alike
rules of the engine.
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..fitting.gram import r_factor
from ..fitting.thresholds import reversal_indices
from .context import FitContext
from .events import REVERSAL_TOL
from .specs import Untestable, spec_untestable, time_effects
from .stats import HeldOut, heldout_comparison, score_test
from .structure import Fit


def untestable_effects(ctx: FitContext) -> list[Untestable]:
    """Effects the recordings of ``ctx`` cannot excite, each an :class:`Untestable` (with
    the recording that would make it testable): every time-dependent effect
    on recordings without a time axis, then each effect's own rule
    (:attr:`~core.diagnosis.registry.DiagnosableEffect.untestable`)."""
    untimed = [r.name for r in ctx.records if not r.has_time]
    out: list[Untestable] = []
    if untimed:
        why = (f"{', '.join(untimed)} {'has' if len(untimed) == 1 else 'have'} no time axis "
               "(sample index only, e.g. a quasi-static loop), so effects that depend on time, "
               "rate or frequency cannot be told apart from the loop itself")
        out = [Untestable(n, why, "the same recording with its time stamps (a time "
                          "column, or the sampling rate)") for n in time_effects()]
    return out + spec_untestable(ctx, {u.name for u in out})


@dataclass(frozen=True)
class LookalikeEvidence:
    """What tells the output-dynamics look-alikes apart in a residual
    (:func:`lookalike_evidence`): its regression on the reversible and the hysteretic
    parts of the PI output's rate (``a_rev_s``, ``a_hys_s`` in s, their ratio) and on the
    output's first and second derivatives (``g1_s`` in s, ``g2_s2`` in s², ``g2 / g1²``);
    a ratio is ``None`` where its denominator is 0."""

    a_rev_s: float
    a_hys_s: float
    rev_hys_ratio: float | None
    g1_s: float
    g2_s2: float
    g2_over_g1sq: float | None

    def to_dict(self) -> dict[str, float | None]:
        """The finding's ``discriminators`` (JSON)."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class SignLocking:
    """Whether the residual's trend after each held step follows that step's sign
    (:func:`sign_locking`): the number of steps with a hold and, with at least two, the
    share whose trend has the step's sign (``None`` below two)."""

    steps_with_hold: int
    trend_follows_step_sign: float | None = None

    def to_dict(self) -> dict[str, float]:
        """The finding's ``discriminators`` (JSON; the share only where there is one)."""
        d: dict[str, float] = {"steps_with_hold": self.steps_with_hold}
        if self.trend_follows_step_sign is not None:
            d["trend_follows_step_sign"] = self.trend_follows_step_sign
        return d


def lookalike_evidence(ctx: FitContext, cur: Fit) -> LookalikeEvidence:
    """rev/hys split and g2/g1² of the current residual (train rows, base partialled out)."""
    rows = []
    for k, (rec, p, x, m) in enumerate(zip(ctx.records, cur.pred, cur.x_pi, ctx.train,
                                           strict=True)):
        dx = np.gradient(x, rec.dt)
        ddx = np.gradient(dx, rec.dt)
        du = np.gradient(rec.u, rec.dt)
        vrev = cur.p0 * du
        vhys = dx - vrev
        step = max(1, int(m.sum() // 20000))
        idx = np.flatnonzero(m)[::step]
        # (only the sampled rows of the bank: a long record's whole bank is (N, n + 1))
        B = ctx.cache.bank_rows(k, rec, np.asarray(cur.structure.thresholds),
                                cur.structure.history[k], cur.structure.beta_s,
                                cur.structure.shape, idx, bouc_wen=cur.structure.bouc_wen)
        rows.append(np.column_stack((B, np.ones(idx.size), vrev[idx], vhys[idx], dx[idx],
                                     ddx[idx], (rec.y - p)[idx])))
    X = np.concatenate(rows)
    nb = X.shape[1] - 5
    # the base columns partialled out of the others and the residual: the trailing block T
    # of the triangular factor of [base, v_rev, v_hys, dx, ddx, e] is the factor of those
    # five partialled columns (Q T with orthonormal Q), so the regressions below run on T
    T = r_factor(X)[nb:, nb:]
    c = np.linalg.lstsq(T[:, 0:2], T[:, 4], rcond=None)[0]
    g = np.linalg.lstsq(T[:, 2:4], T[:, 4], rcond=None)[0]
    return LookalikeEvidence(
        a_rev_s=float(c[0]), a_hys_s=float(c[1]),
        rev_hys_ratio=float(c[0] / c[1]) if c[1] != 0 else None,
        g1_s=float(g[0]), g2_s2=float(g[1]),
        g2_over_g1sq=float(g[1] / g[0] ** 2) if g[0] != 0 else None)


def score_statistic(ctx: FitContext, cur: Fit, new: Fit) -> float:
    """LM statistic of the fitted effect direction (train rows, base partialled, HAC)."""
    es, J, P = [], [], []
    for k, (rec, p0, p1, m) in enumerate(zip(ctx.records, cur.pred, new.pred, ctx.train,
                                               strict=True)):
        step = max(1, int(m.sum() // 8000))
        idx = np.flatnonzero(m)[::step]
        B = ctx.cache.bank_rows(k, rec, np.asarray(cur.structure.thresholds),
                                cur.structure.history[k], cur.structure.beta_s,
                                cur.structure.shape, idx, bouc_wen=cur.structure.bouc_wen)
        es.append((rec.y - p0)[idx])
        J.append(np.column_stack((B, np.ones(idx.size))))
        P.append((p1 - p0)[idx])
    stat, _ = score_test(np.concatenate(es), np.concatenate(J), np.concatenate(P), lags=20)
    return stat


def sign_locking(ctx: FitContext, cur: Fit) -> SignLocking:
    """Does the residual trend after each step follow the sign of that step (creep) or not?"""
    signs, trends = [], []
    for rec, p, c in zip(ctx.records, cur.pred, ctx.coords, strict=True):
        e = rec.y - p
        for st, n_hold, sign in c.holds:
            seg = e[st : st + n_hold]
            lt = np.log(np.arange(1, n_hold + 1) * rec.dt)
            signs.append(sign)
            trends.append(float(np.polyfit(lt, seg, 1)[0]))
    if len(signs) < 2:
        return SignLocking(len(signs))
    s = np.asarray(signs)
    tr = np.asarray(trends)
    return SignLocking(len(signs), float(np.mean(np.sign(tr) == s)))


#: Knots of the hat basis in the input of :func:`loop_shape_basis` (per direction of motion).
LOOP_SHAPE_KNOTS = 12


#: Rows per block in which :func:`beyond_loop_shape` forms the loop-shape columns of a long
#: recording (6 x :data:`LOOP_SHAPE_KNOTS` columns: 29 MB a block, where the whole basis of a
#: 10-million-sample recording would take 5.8 GB).
LOOP_SHAPE_BLOCK = 50_000


class _LoopState(NamedTuple):
    """What the loop-shape columns of every sample are formed from: the input's knot
    coordinates ``x``, the last reversal value scaled to [-1, 1] ``xr`` and the direction of
    motion ``rising``, each shape (n,); ``None`` for an input that never moves."""

    x: np.ndarray
    xr: np.ndarray
    rising: np.ndarray


def _loop_state(u: np.ndarray) -> _LoopState | None:
    n, k = u.size, LOOP_SHAPE_KNOTS
    lo, span = (float(u.min()), float(np.ptp(u))) if n else (0.0, 0.0)
    if span <= 0:
        return None
    rv = reversal_indices(u, REVERSAL_TOL * span)
    last = np.zeros(n, dtype=np.int64)
    last[rv] = rv
    last = np.maximum.accumulate(last)  # index of the last reversal at or before each sample
    return _LoopState((u - lo) / span * (k - 1), 2.0 * (u[last] - lo) / span - 1.0,
                      u >= u[last])


def _loop_columns(st: _LoopState | None, a: int, b: int) -> np.ndarray:
    """The loop-shape columns of samples ``a`` to ``b`` (exclusive), shape (b - a, 6 k)."""
    k = LOOP_SHAPE_KNOTS
    out = np.zeros((b - a, 6 * k))
    if st is None:
        return out
    hats = np.clip(1.0 - np.abs(st.x[a:b, None] - np.arange(k)[None, :]), 0.0, None)
    xr, rising = st.xr[a:b], st.rising[a:b, None]
    for j, w in enumerate((np.ones(b - a), xr, xr**2)):
        cols = hats * w[:, None]
        out[:, 2 * j * k : (2 * j + 1) * k] = cols * rising
        out[:, (2 * j + 1) * k : (2 * j + 2) * k] = cols * ~rising
    return out


def loop_shape_basis(u: np.ndarray) -> np.ndarray:
    """Rate-independent loop-shape columns of one recording's input: smooth functions of the
    input, of the direction of motion and of the last reversal value (the state a
    rate-independent hysteresis misfit depends on), never of time or rate.

    Piecewise-linear hats on the input (:data:`LOOP_SHAPE_KNOTS` knots over its range) times
    1, the last reversal value and its square (both scaled to [-1, 1]), separately while the
    input rises and falls (a hold keeps the direction of the motion before it).

    Parameters
    ----------
    u : ndarray, shape (n,)
        Input samples.

    Returns
    -------
    ndarray, shape (n, 6 * LOOP_SHAPE_KNOTS)
        Zero columns where the input never moves.
    """
    u = np.asarray(u, dtype=np.float64)
    return _loop_columns(_loop_state(u), 0, u.size)


def _without_loop_shape(u: np.ndarray, e: np.ndarray, train: np.ndarray,
                        test: np.ndarray) -> np.ndarray:
    """The residual ``e`` on the ``test`` rows less its loop-shape part (least squares on the
    ``train`` rows). A recording longer than :data:`LOOP_SHAPE_BLOCK` is solved block by
    block: the triangular factor of the training rows' columns is updated with each block
    (the same minimum-norm solution as one solve on all of them, to round-off), so no more
    than a block of the columns is ever formed."""
    u = np.asarray(u, dtype=np.float64)
    st, n = _loop_state(u), u.size
    if n <= LOOP_SHAPE_BLOCK:
        F = _loop_columns(st, 0, n)
        c = np.linalg.lstsq(F[train], e[train], rcond=None)[0]
        return (e - F @ c)[test]
    m = 6 * LOOP_SHAPE_KNOTS
    # the triangular factor of [columns | residual] on the training rows: its last column
    # holds Q' e, so its first m columns and that column are the whole least-squares problem
    R = np.zeros((0, m + 1))
    edges = [*range(0, n, LOOP_SHAPE_BLOCK), n]
    for a, b in itertools.pairwise(edges):
        t = train[a:b]
        R = r_factor(np.vstack([R, np.column_stack((_loop_columns(st, a, b)[t], e[a:b][t]))]))
    # (with the cut-off of the one solve on all the training rows)
    rcond = np.finfo(np.float64).eps * max(int(train.sum()), m)
    c = np.linalg.lstsq(R[:, :m], R[:, m], rcond=rcond)[0]
    return np.concatenate([(e[a:b] - _loop_columns(st, a, b) @ c)[test[a:b]]
                           for a, b in itertools.pairwise(edges)])


def beyond_loop_shape(ctx: FitContext, cur: Fit, new: Fit) -> HeldOut:
    """Held-out comparison of the current model against ``new`` (one output dynamics stage
    more), each with its residual's rate-independent loop-shape part
    (:func:`loop_shape_basis`, least squares on the training rows) added: what the stage
    explains that a rate-independent loop-shape misfit of the base cannot."""
    res = [[_without_loop_shape(rec.u, rec.y - p, tr, te)
            for rec, p, tr, te in zip(ctx.records, f.pred, ctx.train, ctx.test, strict=True)]
           for f in (cur, new)]
    return heldout_comparison(res[0], res[1])
