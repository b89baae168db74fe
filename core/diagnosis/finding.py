"""The finding of an accepted candidate (SAY / MODEL / SHOW: where it improves, its
uncertainty, caveats, discriminators) and the look-alikes the recordings do not separate from
it (:func:`make_finding`, :func:`lookalikes_of`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .acceptance import RULE, harm_bound
from .context import FitContext
from .crossfitting import ambiguous_parameters, crossfit_summary, effect_uncertainty
from .locate import where_improved
from .lookalikes import lookalike_evidence, score_statistic, sign_locking
from .registry import EFFECTS
from .results import EffectFinding, pooled_mse
from .search import same_signature_rows
from .state import Candidate, Run, evidence_label
from .stats import heldout_comparison
from .structure import Fit

__all__ = ["MIN_OUTSIDE_ROWS", "lookalikes_of", "make_finding"]


def lookalikes_of(ctx: FitContext, c: Candidate, cands: dict[str, Candidate],
                  passing: list[str]) -> tuple[list[str], dict[str, Any]]:
    """Same-family candidates the recordings do not separate from the chosen ``c``, and the
    runner-up.

    A runner-up is compared with the winner directly on held-out rows (strict hold-out: on
    the cross-fitted blocks; between recordings: on the left-out recordings; both judged
    where their signature lives, on the same rows: there). It is
    ambiguous when it passed too (or, between recordings or as a declared look-alike of
    another family (:attr:`Effect.lookalikes`), met the effect-size rules: a look-alike that
    failed only significance or fold agreement cannot be ruled out) and explains nearly as
    much or is not significantly worse.
    """
    amb: list[str] = []
    runner: dict[str, Any] = {}
    for other, o in cands.items():
        cross = other in EFFECTS[c.name].lookalikes  # declared look-alike of another family
        if other == c.name or (o.family != c.family and not cross):
            continue
        if ctx.strict:
            if o.crossfit is None or c.crossfit is None:
                continue
            hh = heldout_comparison(o.crossfit.after, c.crossfit.after)
        elif o.between is not None and c.between is not None:
            hh = heldout_comparison(o.between.after, c.between.after)
        elif (rows := same_signature_rows(ctx, c, o)) is not None:
            # both judged on the same rows of their signature (a drift and a creep from
            # cycle to cycle): compared with each other there too
            hh = heldout_comparison(ctx.signature_res(o.fit, rows), ctx.signature_res(c.fit, rows))
        else:
            hh = heldout_comparison(ctx.test_res(o.fit), ctx.test_res(c.fit))
        oh = o.heldout
        if not runner or oh.gain > runner.get("heldout_mse_reduction", -np.inf):
            runner = {"effect": other, "heldout_mse_reduction": oh.gain,
                      "z_best_vs_this": hh.z, "parameters": o.parameters}
        if (other in passing or ((o.between is not None or cross) and o.size_ok)) and (
                oh.gain >= (1 - RULE.family_margin) * c.heldout.gain or hh.z < RULE.min_z):
            amb.append(other)
    return amb, runner


def make_finding(run: Run, cur: Fit, c: Candidate, amb: list[str], runner: dict[str, Any]
                 ) -> EffectFinding:
    """The finding of accepted candidate ``c`` (SAY / MODEL / SHOW)."""
    ctx, records = run.ctx, run.ctx.records
    disc = (lookalike_evidence(ctx, cur).to_dict() if c.family == "dynamics" else
            sign_locking(ctx, cur).to_dict() if c.family == "slow" else {})
    used = [tr | te for tr, te in zip(ctx.train, ctx.test, strict=True)]
    where = where_improved(records, [e * u for e, u in zip(ctx.all_res(cur), used, strict=True)],
                           [e * u for e, u in zip(ctx.all_res(c.fit), used, strict=True)],
                           ctx.coords)
    where["outside_train_test"] = _outside(records, ctx.all_res(cur), ctx.all_res(c.fit), used)
    caveats = [
        f"outside the train/test rows ({o['recording']}, {o['samples']} samples) the RMS "
        f"residual grows from {o['rms_before']:.4g} to {o['rms_after']:.4g}: the effect as "
        "fitted does not hold for what those rows contain (a step, a hold, another "
        "amplitude); trust it for inputs like the training ones"
        for o in where["outside_train_test"]
        if o["rms_after"] > RULE.outside_worse * o["rms_before"]
    ]
    unc, unc_how = effect_uncertainty(ctx, c.name, cur, c.uncertainty, c.crossfit, ctx.train)
    systematic = EFFECTS[c.name].systematic
    if systematic is not None:
        sys_sigma, sys_how = systematic(ctx, cur, c.fit)
        unc = dict(unc)
        for k, v in sys_sigma.items():
            s0 = unc.get(k)
            s0 = float(s0) if isinstance(s0, (int, float)) and np.isfinite(s0) else 0.0
            unc[k] = float(np.hypot(s0, v))
        unc_how += f"; {sys_how}"
    return EffectFinding(
        name=c.name,
        parameters=c.parameters,
        uncertainty=unc,
        uncertainty_method=unc_how,
        where=where,
        explanation=EFFECTS[c.name].explanation,
        equation=EFFECTS[c.name].equation,
        heldout=c.heldout,
        heldout_rmse_before=float(np.sqrt(pooled_mse(ctx.test_res(cur)))),
        heldout_rmse_after=float(np.sqrt(pooled_mse(ctx.test_res(c.fit)))),
        score_lm=score_statistic(ctx, cur, c.fit),
        discriminators=disc,
        ambiguous_with=amb,
        runner_up=runner,
        crossfit=crossfit_summary(c.crossfit),
        caveats=caveats,
        evidence=_evidence(run, c) + (f", judged on top of {c.given}" if c.given else ""),
        ambiguous_parameters=ambiguous_parameters(c.parameters, unc),
        fitted_on_all_rows=c.name in c.fit.raw_fallback,
    )


def _evidence(run: Run, c: Candidate) -> str:
    """Where the evidence of accepted candidate ``c`` came from, in words: the rows its
    signature lives in when it was judged there (with what it did to the other test rows,
    and, when acceptance rule 19 waived the excess share, that it was waived), else the
    evidence rows of :func:`~core.diagnosis.state.evidence_label`."""
    label = evidence_label(run.ctx, c.name, c.crossfit, c.between)
    if c.where is None:
        return label
    words = c.where
    e = c.elsewhere
    if e is not None and np.isfinite(e.gain):
        words += (f"; on the other test rows its held-out MSE reduction is "
                  f"{100 * e.gain:+.1f} % (z {e.z:.2f})")
    if c.share_waived and e is not None:
        words += ("; it removes less than "
                  f"{100 * RULE.min_excess_share:.0f} % of those rows' excess over the noise "
                  "floor (what the model leaves there that does not repeat from one branch "
                  "to the next), and is accepted because the other test rows show it "
                  "harmless: the upper "
                  f"{100 * (1 - RULE.equivalence_p):.0f} % confidence bound of their MSE "
                  f"change is {100 * harm_bound(e):+.1f} % "
                  f"({e.n_independent:.0f} independent batches), within the "
                  f"{100 * RULE.max_harm_elsewhere:.0f} % margin")
    return words


#: Fewest rows outside the train and test rows of a recording for their RMS before/after
#: to be reported (and a caveat printed when it grows by ``outside_worse`` of
#: :class:`~core.diagnosis.acceptance.AcceptRule`).
MIN_OUTSIDE_ROWS = 10


def _outside(records, e0, e1, used) -> list[dict[str, Any]]:
    """RMS before/after on the rows outside train and test (an independent check)."""
    out = []
    for r, a, b, m in zip(records, e0, e1, used, strict=True):
        o = ~m
        if o.sum() >= MIN_OUTSIDE_ROWS:
            out.append({"recording": r.name, "samples": int(o.sum()),
                        "rms_before": float(np.sqrt(np.mean(a[o] ** 2))),
                        "rms_after": float(np.sqrt(np.mean(b[o] ** 2)))})
    return out
