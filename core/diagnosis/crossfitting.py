"""Held-out evidence inside the training rows: the screen on the test rows, fold refits,
blocked cross-fitting of a candidate and block-jackknife uncertainties (notes §5).

The engine (:mod:`core.diagnosis.engine`) calls these for every candidate; the acceptance rules
that read their results are in :mod:`core.diagnosis.acceptance`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._typing import Float1D
from .between import (
    NONLINEAR_PARAMS,
)
from .candidates import build_candidate
from .context import FitContext
from .data import crossfit_folds
from .registry import EFFECTS
from .stats import HELDOUT_BATCHES, HeldOut, heldout_comparison
from .structure import Fit, Structure


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


def fold_fits(ctx: FitContext, folds: list, name: str, cur: Fit, iterations: int | None = None,
              full: Fit | None = None):
    """Per fold: (fold context, current structure refitted without the block, effect ``name``
    fitted on top of it or ``None``). ``full``: the effect fitted on all the training rows,
    from whose parameters a one-parameter search walks its grid
    (:func:`core.diagnosis.candidates.scalar_search`)."""
    for tr_f, blk in folds:
        fc = FitContext(ctx.records, tr_f, blk, parent=ctx)
        fc.iterations = iterations
        fc.uncertainty = False  # only the folds' parameters are used
        fc.start = None if full is None else full.structure
        cur_f = fc.fit(cur.structure, cur)
        yield fc, cur_f, build_candidate(fc, name, cur_f)


#: Nonlinear parameters whose spread across cross-fitting folds is checked (notes §5, rule 4).
SCALAR_PARAMS = NONLINEAR_PARAMS


@dataclass(frozen=True, eq=False)
class CrossFit:
    """The blocked cross-fitting of one candidate (:func:`crossfit_candidate`).

    Attributes
    ----------
    pooled : HeldOut
        The comparison over the test rows and every block.
    folds : int
        Number of blocks.
    fold_gains : list of float
        MSE reduction on each block.
    fold_parameters : list of dict
        The effect's parameters fitted without each block.
    parameter_cv : dict of str to float
        Coefficient of variation across folds of each scalar nonlinear parameter.
    before, after : list of ndarray
        The pooled residuals (test rows, then the blocks) without / with the effect.
    """

    pooled: HeldOut
    folds: int
    fold_gains: list[float]
    fold_parameters: list[dict[str, Any]]
    parameter_cv: dict[str, float]
    before: list[Float1D]
    after: list[Float1D]


def crossfit_candidate(ctx: FitContext, name: str, cur: Fit, fit: Fit) -> CrossFit | None:
    """Held-out evidence from the training window itself, by blocked cross-fitting.

    For each fold of ``ctx.folds`` the current structure's linear weights are re-solved
    without the block and effect ``name`` is fitted anew on top (its nonlinear parameters
    searched again; a one-parameter grid walked from ``fit``'s value), then both predict
    the block. The block residuals of all folds are
    pooled with the test rows into one Diebold–Mariano / signed-rank comparison.

    Returns
    -------
    CrossFit or None
        ``None`` without folds.
    """
    if not ctx.folds:
        return None
    eb, ea = ([], []) if ctx.strict else (list(ctx.test_res(cur)), list(ctx.test_res(fit)))
    n_test = sum(e.size for e in eb)
    gains, params = [], []
    for fc, cur_f, got in fold_fits(ctx, ctx.folds, name, cur, full=fit):
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
    # the test rows keep their batches' length: the blocks add batches in proportion
    pooled = heldout_comparison(eb, ea, n_batches=HELDOUT_BATCHES if ctx.strict else int(
        round(HELDOUT_BATCHES * n_all / max(n_test, 1))))
    cv: dict[str, float] = {}
    for key in SCALAR_PARAMS:
        vals = np.array([p[key] for p in params if isinstance(p.get(key), float)])
        if vals.size == len(params) and vals.size >= 2 and np.mean(vals) != 0:
            cv[key] = float(np.std(vals, ddof=1) / abs(np.mean(vals)))
    return CrossFit(pooled=pooled, folds=len(ctx.folds), fold_gains=gains,
                    fold_parameters=params, parameter_cv=cv, before=eb, after=ea)



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


#: Training blocks of the block jackknife of a linear effect not cross-fitted for its
#: significance test: four bound the cost (the jackknife needs few; a diagnosis stays
#: <= 30 s).
JACKKNIFE_BLOCKS = 4


def effect_uncertainty(ctx: FitContext, name: str, cur: Fit, unc: dict[str, Any],
                        cf: CrossFit | None, train: list[np.ndarray]
                        ) -> tuple[dict[str, Any], str]:
    """1-sigma uncertainties of an accepted effect's parameters, and how they were obtained.

    Block jackknife over training blocks (:func:`core.diagnosis.data.crossfit_folds`): free
    when the effect was cross-fitted for its significance test, otherwise refitted for the
    linear effects (one solve per fold). Dynamics found without cross-fitting keep their
    profile-curvature sigmas (inflated for autocorrelation); the initial memory has none.
    """
    params = cf.fold_parameters if cf is not None else None
    if params is None and EFFECTS[name].linear:
        folds = ctx.folds or crossfit_folds(ctx.records, train, max_blocks=JACKKNIFE_BLOCKS)
        params = []
        # bilinear regressors frozen at the full fit (linearised jackknife)
        for _, _, got in fold_fits(ctx, folds, name, cur, iterations=1):
            if got is None:
                params = None
                break
            params.append(got[1])
    jk = block_jackknife(params) if params else {}
    if jk and params is not None:
        return {**unc, **jk}, f"block jackknife over {len(params)} training blocks"
    if any(v is not None for v in unc.values()):
        return unc, "profile curvature (inflated for residual autocorrelation)"
    return unc, "none"


#: Largest relative 1-sigma (sigma / |value|) of a parameter reported as a number; beyond it
#: the parameter is "ambiguous". The resonance frequency is held to 10 %, the rest to 25 %.
AMBIGUOUS_REL_SIGMA: dict[str, float] = {"freq_hz": 0.10}
AMBIGUOUS_REL_SIGMA_DEFAULT = 0.25


#: Training-MSE reduction an effect must bring in one recording alone for that recording's
#: estimate to count in :func:`recording_spread`.
SPREAD_MIN_GAIN = 0.2
#: Training rows per weight (play or level segment, creep lag, bias and
#: map terms) a recording needs to be fitted alone.
SPREAD_ROWS_PER_WEIGHT = 10


def recording_spread(ctx: FitContext, name: str, cur: Fit, without: Structure
                     ) -> dict[str, Any] | None:
    """Do the recordings agree on effect ``name``'s nonlinear parameters?

    The effect is fitted on each recording's training rows alone (the structure ``without``
    it refitted there, the effect searched anew on top), each estimate with its own
    noise-driven 1-sigma. When the base hysteresis is not what the model fits, its misfit
    pulls the parameters differently in each recording, by more than those sigmas: the
    Birge ratio ``R = sqrt(chi2 / (n - 1))`` of the estimates about their weighted mean
    (weights ``1 / sigma_j**2``) measures it; the weighted mean's standard error widened by
    ``max(1, R)`` is the sigma the recordings allow (:func:`combine_uncertainty`).

    Returns
    -------
    dict or None
        ``per_recording`` (per recording with training rows: its estimates, or ``None``
        where the effect does not show there: training-MSE reduction below
        :data:`SPREAD_MIN_GAIN`), ``sigma_per_recording``, ``training_mse_reduction``, and
        per parameter (from the recordings whose sigma is known) ``birge_ratio`` and
        ``sigma_between``; ``None`` with fewer than two recordings that have
        :data:`SPREAD_ROWS_PER_WEIGHT` training rows per weight.
    """
    recs, tr = ctx.records, ctx.train
    none = [np.zeros(r.n_samples, dtype=bool) for r in recs]
    # a recording fitted alone needs rows for every weight (short periodic records do not)
    need = SPREAD_ROWS_PER_WEIGHT * (without.play_weights + without.bank_width + 4)
    only = [[m if k == j else none[k] for k, m in enumerate(tr)]
            for j in range(len(recs)) if tr[j].sum() >= need]
    if len(only) < 2:
        return None
    est: list[dict[str, Any] | None] = []
    sig: list[dict[str, Any]] = []
    gains: list[float] = []
    for masks in only:
        fc = FitContext(recs, masks, none, parent=ctx)
        fc.uncertainty = True
        cur_j = fc.fit(without, cur)
        got = build_candidate(fc, name, cur_j)
        gain = 0.0 if got is None else screen_gain(got[0], cur_j).gain
        gains.append(gain)
        # where the effect does not show, its parameters are noise with a meaningless sigma
        if got is None or gain < SPREAD_MIN_GAIN:
            est.append(None)
            sig.append({})
            continue
        est.append({k: v for k, v in got[1].items() if k in NONLINEAR_PARAMS})
        sig.append({k: v for k, v in got[2].items() if k in NONLINEAR_PARAMS})
    birge: dict[str, float] = {}
    between: dict[str, float] = {}
    for key in NONLINEAR_PARAMS:
        pairs = [(e[key], s[key]) for e, s in zip(est, sig, strict=True)
                 if e is not None and isinstance(e.get(key), float)
                 and isinstance(s.get(key), float) and s[key] > 0]
        if len(pairs) < 2:
            continue
        v, sd = (np.array(x) for x in zip(*pairs, strict=True))
        w = 1.0 / sd**2
        mu = float(np.sum(w * v) / np.sum(w))
        birge[key] = float(np.sqrt(np.sum(w * (v - mu) ** 2) / (len(v) - 1)))
        between[key] = max(birge[key], 1.0) / float(np.sqrt(np.sum(w)))
    return {"per_recording": est, "sigma_per_recording": sig, "training_mse_reduction": gains,
            "birge_ratio": birge, "sigma_between": between}


def combine_uncertainty(unc: dict[str, Any], spread: dict[str, Any] | None
                        ) -> dict[str, Any]:
    """The full fit's 1-sigmas, or the recordings' where larger: the standard error of their
    weighted mean widened by the Birge ratio, ``max(1, R) / sqrt(sum_j 1 / sigma_j**2)``
    (:func:`recording_spread`)."""
    if not spread:
        return unc
    out = dict(unc)
    for k, s in spread["sigma_between"].items():
        u = out.get(k)
        out[k] = max(u, s) if isinstance(u, float) else s
    return out


def ambiguous_parameters(params: dict[str, Any], unc: dict[str, Any]) -> list[str]:
    """Nonlinear parameters whose 1-sigma exceeds :data:`AMBIGUOUS_REL_SIGMA` of their value:
    the data do not fix them to a number."""
    out = []
    for k, v in params.items():
        s = unc.get(k)
        if k not in NONLINEAR_PARAMS or not isinstance(s, float) or not isinstance(v, float):
            continue
        if np.isfinite(s) and s > AMBIGUOUS_REL_SIGMA.get(k, AMBIGUOUS_REL_SIGMA_DEFAULT) * abs(v):
            out.append(k)
    return out


def crossfit_summary(cf: CrossFit | None) -> dict[str, Any] | None:
    """JSON-ready summary of :func:`crossfit_candidate` (``None`` when it was not used)."""
    if cf is None:
        return None
    p = cf.pooled
    return {"folds": cf.folds, "dm_z_pooled": p.z, "signed_rank_p_pooled": p.sign_p,
            "mse_reduction_pooled": p.gain, "batches": p.n_batches,
            "fold_mse_reductions": cf.fold_gains, "fold_parameters": cf.fold_parameters,
            "parameter_cv": cf.parameter_cv}
