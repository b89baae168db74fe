"""The search of a round: every candidate effect fitted on top of the current model, with
the held-out evidence it is judged on (:func:`search_round`, :func:`candidate_evidence`).

The evidence rows are the test rows, the cross-fitted training blocks (strict hold-out), the
rows before the wipe-out time (``initial-memory``), the other recordings (rate- and
amplitude-dependent effects), or the rows the effect's signature lives in
(:func:`where_it_lives` for output dynamics).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .acceptance import RULE, decide
from .between import between_recordings
from .candidates import build_candidate
from .context import FitContext
from .crossfitting import compare_heldout, crossfit_candidate, screen_gain
from .registry import EFFECTS, SignatureRows
from .results import RoundRow, pooled_mse
from .specs import FAMILY_PRIORITY
from .state import Candidate, Run, deferred_row, excess_of
from .stats import HeldOut, heldout_comparison, with_where
from .structure import Fit

__all__ = ["MEMORY_MAX_HARM", "MIN_SIGNATURE_ROWS", "WHERE_MIN_ROWS", "WHERE_MIN_Z",
           "WHERE_SHARE", "candidate_evidence", "same_signature_rows", "search_round",
           "where_it_lives"]


def _lead_bound(lead: tuple[str, float] | None, name: str) -> float:
    """Smallest gain with which ``name`` could still be chosen over the leading passing
    family (:func:`~core.diagnosis.judge.choose`: a later family needs ``family_lead`` times
    its gain); 0 when unbounded."""
    if lead is None:
        return 0.0
    fam = EFFECTS[name].family
    if fam == lead[0] or FAMILY_PRIORITY[fam] <= FAMILY_PRIORITY[lead[0]]:
        return 0.0
    return RULE.family_lead * lead[1]


def _new_lead(lead: tuple[str, float] | None, name: str, gain: float) -> tuple[str, float]:
    """The leading passing family after ``name`` passed with ``gain``."""
    fam = EFFECTS[name].family
    if lead is None or FAMILY_PRIORITY[fam] < FAMILY_PRIORITY[lead[0]] or (
            fam == lead[0] and gain > lead[1]):
        return fam, gain
    return lead


def search_round(run: Run, cur: Fit, todo: list[str], rnd: int
                 ) -> tuple[dict[str, Candidate], list[RoundRow]]:
    """Fit every effect of ``todo`` on top of ``cur`` and collect its evidence.

    With strict hold-out the highest-priority families go first; once one passes, a later
    family can only be chosen with ``family_lead`` (1.5) times its gain
    (:func:`~core.diagnosis.judge.choose`), so hopeless candidates are deferred to the next
    round without their (costly) cross-fitting.
    Returns the candidates and the rows of the deferred ones.
    """
    ctx = run.ctx
    order = sorted(todo, key=lambda n: FAMILY_PRIORITY[EFFECTS[n].family]) if (
        ctx.strict) else todo
    lead: tuple[str, float] | None = None
    # the current model's test-row MSE, which the excess is counted in where the evidence
    # rows are the test rows (state.excess_of, as the judge counts it)
    mse_cur = pooled_mse(ctx.test_res(cur))
    cands: dict[str, Candidate] = {}
    deferred: list[RoundRow] = []
    for i, name in enumerate(order):
        bound = _lead_bound(lead, name)
        if bound > 1.0:
            deferred.append(deferred_row(rnd, name))
            continue
        frac = 0.5 * i / max(len(todo), 1)
        run.step(rnd, frac, f"fitting {name}")
        got = build_candidate(ctx, name, cur)
        if got is None:
            continue
        c = Candidate(name, *got, heldout=screen_gain(got[0], cur))
        if ctx.strict and not EFFECTS[name].before_wipeout and c.heldout.gain < bound:
            deferred.append(deferred_row(rnd, name, c.parameters,
                                         None if bound > 0 else c.heldout.gain))
            continue
        judged = candidate_evidence(run, cur, c, rnd, frac + 0.25 / max(len(todo), 1))
        if judged is None:
            continue
        c = judged
        cands[name] = c
        cv = c.crossfit.parameter_cv if c.crossfit is not None else None
        if ctx.strict and decide(c.heldout, excess_of(c, mse_cur, run.noise, ctx.strict),
                                 len(todo), cv).passes:
            lead = _new_lead(lead, name, c.heldout.gain)
    return cands, deferred


#: Largest relative increase of the held-out MSE (all test rows, or the cross-fitted blocks
#: with strict hold-out) that an ``initial-memory`` candidate, judged on the rows before the
#: wipe-out time, may cause elsewhere (:func:`candidate_evidence`).
MEMORY_MAX_HARM = 0.01


def candidate_evidence(run: Run, cur: Fit, c: Candidate, rnd: int, frac: float) -> Candidate | None:
    """The held-out evidence of candidate ``c`` (``None``: not applicable on some subset).

    * strict hold-out: the training-RSS screen, then cross-fitting when it can pass;
    * ``initial-memory``: the rows before the wipe-out time (the only rows an initial state
      changes; with strict hold-out the training ones, in-sample, 1-2 parameters), and it
      must not make the held-out (cross-fitted) rows worse by more than
      :data:`MEMORY_MAX_HARM` (otherwise it cannot pass: it is made not significant and,
      without strict hold-out, its gain is that worsening);
    * rate-dependent effects between recordings at different rates: each recording
      predicted from the others;
    * otherwise the test rows.
    """
    ctx, name = run.ctx, c.name
    if ctx.strict and not EFFECTS[name].before_wipeout:
        if c.heldout.gain >= RULE.min_gain:
            run.step(rnd, frac, f"cross-fitting {name}")
            cf = crossfit_candidate(ctx, name, cur, c.fit)
            if cf is not None:
                return replace(c, heldout=cf.pooled, crossfit=cf)
        return c
    if EFFECTS[name].before_wipeout:
        mm = ([a & b for a, b in zip(ctx.memory_masks, ctx.train, strict=True)] if ctx.strict
              else ctx.memory_masks)
        h = heldout_comparison(ctx.test_res(cur, mm), ctx.test_res(c.fit, mm))
        worse = (compare_heldout(ctx, cur, c.fit).gain if ctx.strict
                 else heldout_comparison(ctx.test_res(cur), ctx.test_res(c.fit)).gain)
        if worse < -MEMORY_MAX_HARM:
            h = HeldOut(h.mse_before, h.mse_after, h.gain if ctx.strict else min(h.gain, worse),
                        min(h.z, 0.0), 1.0, h.n_batches)
        return replace(c, heldout=h)
    spec = EFFECTS[name]
    if (run.between.rate and spec.between_recordings) or (
            run.between.amplitude and spec.amplitude_dependent):
        run.step(rnd, frac, f"predicting each recording from the others ({name})")
        bt = between_recordings(ctx, name, cur)
        return None if bt is None else replace(c, heldout=bt.pooled, between=bt)
    local = _on_its_signature(ctx, cur, c)
    if local is not None:
        return local
    h = heldout_comparison(ctx.test_res(cur), ctx.test_res(c.fit))
    if spec.dynamics is not None:
        h = where_it_lives(ctx, cur, c.fit, h)
    return replace(c, heldout=h)


#: Fewest test rows among the rows an effect's signature lives in for judging it there.
MIN_SIGNATURE_ROWS = 200


def _on_its_signature(ctx: FitContext, cur: Fit, c: Candidate) -> Candidate | None:
    """Candidate ``c`` judged on the test rows its signature lives in (the effect's
    :attr:`~core.diagnosis.registry.DiagnosableEffect.signature`), with the comparison on
    the other test rows kept for acceptance rule 13; ``None`` when the effect declares no
    such rows or too few of them are test rows (:data:`MIN_SIGNATURE_ROWS`)."""
    spec = EFFECTS[c.name]
    sig = spec.signature(ctx) if spec.signature is not None else None
    if sig is None:
        return None
    where = [m & t for m, t in zip(sig.masks, ctx.test, strict=True)]
    if sum(int(w.sum()) for w in where) < MIN_SIGNATURE_ROWS:
        return None
    rest = [~m & t for m, t in zip(sig.masks, ctx.test, strict=True)]
    h = heldout_comparison(ctx.signature_res(cur, sig), ctx.signature_res(c.fit, sig))
    other = (heldout_comparison(ctx.test_res(cur, rest), ctx.test_res(c.fit, rest))
             if sum(int(r.sum()) for r in rest) >= MIN_SIGNATURE_ROWS else None)
    overall = heldout_comparison(ctx.test_res(cur), ctx.test_res(c.fit))
    return replace(c, heldout=h, where=f"test rows {sig.words}", elsewhere=other,
                   overall=overall, beyond_history=sig.beyond_history,
                   noise_factor=sig.noise_factor)


def same_signature_rows(ctx: FitContext, c: Candidate, o: Candidate) -> SignatureRows | None:
    """The rows of their signature that candidates ``c`` and ``o`` were both judged on
    (:func:`_on_its_signature`: a drift and a creep from cycle to cycle of one repeated
    input), or ``None`` when they were not judged on the same rows."""
    sig = EFFECTS[c.name].signature
    if c.where is None or o.where != c.where or sig is None:
        return None
    return sig(ctx)


#: Share of the test rows, those where a delay / lag / resonance changes the prediction most,
#: on which its significance is also tested (:func:`where_it_lives`).
WHERE_SHARE = 0.2
#: ... only when the Diebold-Mariano z on all the test rows is at least this ...
WHERE_MIN_Z = 2.0
#: ... and the rows it is chosen from number at least this.
WHERE_MIN_ROWS = 50


def where_it_lives(ctx: FitContext, cur: Fit, new: Fit, h: HeldOut) -> HeldOut:
    """The held-out comparison ``h`` (all test rows) of a linear-dynamics candidate, with
    its significance also tested where it lives: the :data:`WHERE_SHARE` of the test rows
    where it changes the prediction most (the fast segments, the milliseconds after
    reversals and steps), where the Diebold-Mariano test on all rows is conservative. The
    rows are chosen from the two models' predictions alone (not from the measured output),
    so the test stays valid; the better of the two counts, the signed-rank p doubled
    (Bonferroni over the two row sets), and only when the z on all rows is at least
    :data:`WHERE_MIN_Z`. The effect size (MSE reduction) stays that of all the test rows."""
    if not (np.isfinite(h.z) and h.z >= WHERE_MIN_Z):
        return h
    d = [np.abs(a - b)[m] for a, b, m in zip(new.pred, cur.pred, ctx.test, strict=True)]
    pooled = np.concatenate(d) if d else np.zeros(0)
    if pooled.size < WHERE_MIN_ROWS or not np.any(pooled > 0):
        return h
    cut = float(np.quantile(pooled, 1.0 - WHERE_SHARE))
    where = [m & (np.abs(a - b) >= cut) for a, b, m in zip(new.pred, cur.pred, ctx.test,
                                                           strict=True)]
    hw = heldout_comparison(ctx.test_res(cur, where), ctx.test_res(new, where))
    return with_where(h, hw)
