"""Held-out evidence inside the training rows: the screen on the test rows, fold refits,
blocked cross-fitting of a candidate and block-jackknife uncertainties (notes §5).

The engine (:mod:`core.diagnosis.engine`) calls these for every candidate; the acceptance rules
that read their results are in :mod:`core.diagnosis.acceptance`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .between import (
    NONLINEAR_PARAMS,
)
from .candidates import build_candidate
from .context import FitContext
from .data import crossfit_folds
from .stats import HeldOut, heldout_comparison
from .structure import Fit


def screen_gain(fit: Fit, cur: Fit) -> HeldOut:
    """In-sample training-RSS reduction of ``fit`` over ``cur`` (a screen, no significance):
    an effect that cannot reduce the training error by ``min_gain`` cannot pass held out."""
    b = cur.train_rss / max(cur.n_train, 1)
    a = fit.train_rss / max(fit.n_train, 1)
    return HeldOut(b, a, 1.0 - a / b if b > 0 else 0.0, 0.0, 1.0, 0)


def compare_heldout(ctx: FitContext, a: Fit, b: Fit) -> HeldOut:
    """Held-out comparison of two fitted structures (linear weights refitted per fold):
    on the test rows, or with strict hold-out on the cross-fitted training blocks."""
    if not ctx.strict:
        return heldout_comparison(ctx.test_res(a), ctx.test_res(b))
    eb, ea = [], []
    for tr_f, blk in ctx.folds:
        fc = FitContext(ctx.records, tr_f, blk, parent=ctx)
        eb += fc.test_res(fc.fit(a.structure, a))
        ea += fc.test_res(fc.fit(b.structure, b))
    return heldout_comparison(eb, ea)


def fold_fits(ctx: FitContext, folds: list, name: str, cur: Fit, iterations: int | None = None):
    """Per fold: (fold context, current structure refitted without the block, effect ``name``
    fitted on top of it or ``None``)."""
    for tr_f, blk in folds:
        fc = FitContext(ctx.records, tr_f, blk, parent=ctx)
        fc.iterations = iterations
        fc.uncertainty = False  # only the folds' parameters are used
        cur_f = fc.fit(cur.structure, cur)
        yield fc, cur_f, build_candidate(fc, name, cur_f)


#: Nonlinear parameters whose spread across cross-fitting folds is checked (notes §5, rule 4).
SCALAR_PARAMS = NONLINEAR_PARAMS


def crossfit_candidate(ctx: FitContext, name: str, cur: Fit, fit: Fit) -> dict[str, Any] | None:
    """Held-out evidence from the training window itself, by blocked cross-fitting.

    For each fold of ``ctx.folds`` the current structure's linear weights are re-solved
    without the block and effect ``name`` is fitted anew on top (its nonlinear parameters
    searched again), then both predict the block. The block residuals of all folds are
    pooled with the test rows into one Diebold–Mariano / signed-rank comparison.

    Returns
    -------
    dict or None
        ``pooled`` (HeldOut over test rows + blocks), ``folds``, ``fold_gains``,
        ``fold_parameters`` and ``parameter_cv`` (coefficient of variation across folds of
        each scalar nonlinear parameter); ``None`` without folds.
    """
    if not ctx.folds:
        return None
    eb, ea = ([], []) if ctx.strict else (list(ctx.test_res(cur)), list(ctx.test_res(fit)))
    n_test = sum(e.size for e in eb)
    gains, params = [], []
    for fc, cur_f, got in fold_fits(ctx, ctx.folds, name, cur):
        if got is None:
            return None
        b0, b1 = fc.test_res(cur_f), fc.test_res(got[0])
        eb += b0
        ea += b1
        m0 = float(np.mean(np.concatenate(b0) ** 2))
        m1 = float(np.mean(np.concatenate(b1) ** 2))
        gains.append(1.0 - m1 / m0 if m0 > 0 else 0.0)
        params.append(got[1])
    n_all = sum(e.size for e in eb)
    pooled = heldout_comparison(eb, ea, n_batches=40 if ctx.strict else int(
        round(40 * n_all / max(n_test, 1))))
    cv: dict[str, float] = {}
    for key in SCALAR_PARAMS:
        vals = np.array([p[key] for p in params if isinstance(p.get(key), float)])
        if vals.size == len(params) and vals.size >= 2 and np.mean(vals) != 0:
            cv[key] = float(np.std(vals, ddof=1) / abs(np.mean(vals)))
    return {"pooled": pooled, "folds": len(ctx.folds), "fold_gains": gains,
            "fold_parameters": params, "parameter_cv": cv, "before": eb, "after": ea}


#: Effects whose parameters are linear weights (one least-squares solve, cheap to refit).
LINEAR_EFFECTS = ("creep", "drift", "asymmetry", "offset")


def block_jackknife(param_sets: list[dict[str, Any]]) -> dict[str, Any]:
    """Block-jackknife 1-sigma of every numeric parameter from delete-one-block fits.

    ``sd = sqrt((K - 1) / K * sum_k (theta_k - mean)^2)`` elementwise; parameters fixed by
    design (identical in every fold, e.g. creep time constants) are left out.
    """
    out: dict[str, Any] = {}
    k = len(param_sets)
    if k < 2:
        return out
    for key in param_sets[0]:
        try:
            a = np.asarray([p[key] for p in param_sets], dtype=np.float64)
        except (TypeError, ValueError, KeyError):
            continue
        if a.shape[0] != k or not np.all(np.isfinite(a)) or np.all(a == a[0]):
            continue
        sd = np.sqrt((k - 1) / k * np.sum((a - a.mean(axis=0)) ** 2, axis=0))
        out[key] = sd.tolist() if sd.ndim else float(sd)
    return out


def effect_uncertainty(ctx: FitContext, name: str, cur: Fit, unc: dict[str, Any],
                        cf: dict[str, Any] | None, train: list[np.ndarray]
                        ) -> tuple[dict[str, Any], str]:
    """1-sigma uncertainties of an accepted effect's parameters, and how they were obtained.

    Block jackknife over training blocks (:func:`core.diagnosis.data.crossfit_folds`): free
    when the effect was cross-fitted for its significance test, otherwise refitted for the
    linear effects (one solve per fold). Dynamics found without cross-fitting keep their
    profile-curvature sigmas (inflated for autocorrelation); the initial memory has none.
    """
    params = cf["fold_parameters"] if cf is not None else None
    if params is None and name in LINEAR_EFFECTS:
        # four blocks bound the cost (the jackknife needs few; a diagnosis stays <= 30 s)
        folds = ctx.folds or crossfit_folds(ctx.records, train, max_blocks=4)
        params = []
        # bilinear regressors frozen at the full fit (linearised jackknife)
        for _, _, got in fold_fits(ctx, folds, name, cur, iterations=1):
            if got is None:
                params = None
                break
            params.append(got[1])
    jk = block_jackknife(params) if params else {}
    if jk:
        return {**unc, **jk}, f"block jackknife over {len(params)} training blocks"
    if any(v is not None for v in unc.values()):
        return unc, "profile curvature (inflated for residual autocorrelation)"
    return unc, "none"


def crossfit_summary(cf: dict[str, Any] | None) -> dict[str, Any] | None:
    """JSON-ready summary of :func:`crossfit_candidate` (``None`` when it was not used)."""
    if cf is None:
        return None
    p: HeldOut = cf["pooled"]
    return {"folds": cf["folds"], "dm_z_pooled": p.z, "signed_rank_p_pooled": p.sign_p,
            "mse_reduction_pooled": p.gain, "batches": p.n_batches,
            "fold_mse_reductions": cf["fold_gains"], "fold_parameters": cf["fold_parameters"],
            "parameter_cv": cf["parameter_cv"]}
