"""The acceptance of a round: the rules of :mod:`core.diagnosis.acceptance` applied to the
candidates of :mod:`core.diagnosis.search` (:func:`judge_round`), the look-ahead of rule 6
(:func:`lookahead`), and the choice among the passing effects (:func:`choose`).
"""

from __future__ import annotations

from dataclasses import replace
from fractions import Fraction

import numpy as np

from ..recordings import Recording
from ..validation import filled
from .acceptance import (
    RULE,
    Decision,
    beyond_loop_shape_ok,
    decide,
    earns_place,
    enough_events,
    generalises,
    harmless_elsewhere,
    split_supports_transport,
    trend_follows_steps,
)
from .acceptance import size_ok as effect_size_ok
from .candidates import build_candidate
from .context import FitContext
from .crossfitting import compare_heldout, crossfit_candidate, screen_gain
from .data import ANY_BLOCK_S, crossfit_folds
from .events import event_windows, excitation
from .history import history_refusal
from .lookalikes import beyond_loop_shape, lookalike_evidence, sign_locking
from .registry import EFFECTS
from .results import RoundRow, pooled_mse
from .scoring import adds_levels, recording_specific, shared_loro
from .screening import RANKING_SPAN
from .search import candidate_evidence, same_signature_rows, search_round
from .specs import FAMILY_PRIORITY
from .state import Candidate, Run, excess_of, round_row
from .stats import HeldOut, heldout_comparison
from .structure import Fit

__all__ = ["MIN_EVENT_ROWS", "choose", "event_gains", "fewer_parameters_on_same_rows",
           "judge_round", "lookahead", "needs_earning", "remaining"]


def judge_round(run: Run, cur: Fit, cands: dict[str, Candidate], rows: list[RoundRow],
                rnd: int, accepted: tuple[str, ...], n_tests: int | None = None
                ) -> tuple[dict[str, Candidate], list[RoundRow], list[str]]:
    """Apply the acceptance rules (:func:`~core.diagnosis.acceptance.decide`) to every
    candidate of the round on top of ``cur`` (which holds the ``accepted`` effects);
    ``n_tests``: the Bonferroni divisor (default: the number of candidates). Returns the
    candidates (with any cross-fitting and their decisions added), the round's rows and the
    names that pass."""
    ctx = run.ctx
    n_tests = len(cands) if n_tests is None else n_tests
    mse_cur = pooled_mse(ctx.test_res(cur))
    excess = {n: excess_of(c, mse_cur, run.noise, ctx.strict) for n, c in cands.items()}
    cands = {n: _sized(c, excess[n]) for n, c in cands.items()}
    size_ok = {n: c.size_ok for n, c in cands.items()}
    needs_cf = {n for n in cands if size_ok[n] and ctx.folds and not EFFECTS[n].before_wipeout
                and not ctx.strict}
    skip = _cannot_win({n: c.heldout for n, c in cands.items()}, size_ok, needs_cf, n_tests)
    rows = list(rows)
    passing: list[str] = []
    for name, c in list(cands.items()):
        if name in skip:
            rows.append(round_row(ctx, rnd, c, passes=False, decision="deferred",
                                  evidence="not needed: an effect of a higher-priority family "
                                  f"passed and explains at least {_share(1 / RULE.family_lead)} "
                                  "as much"))
            continue
        if name in needs_cf:
            run.step(rnd, 0.5, f"cross-fitting {name}")
            cf = crossfit_candidate(ctx, name, cur, c.fit)
            if cf is not None:
                c = cands[name] = replace(c, crossfit=cf)
        cv = (c.crossfit.parameter_cv if c.crossfit else
              c.between.parameter_cv if c.between else {})
        dec = decide(c.heldout, excess[name], n_tests, cv, significance=c.evidence_rows,
                     elsewhere=c.elsewhere)
        decision = None
        if dec.passes and not harmless_elsewhere(c.elsewhere):
            e = filled(c.elsewhere)
            dec = replace(dec, passes=False, reasons=(
                f"judged {c.where}, it makes the other test rows worse (MSE "
                f"{100 * e.gain:+.1f} %, z {e.z:.2f})",))
            decision = "contradicted"
        elif dec.passes and (why := _events_refusal(ctx, cur, c)) is not None:
            dec = replace(dec, passes=False, reasons=(why,))
        elif dec.passes and (why := _loop_shape_refusal(ctx, cur, c)) is not None:
            dec = replace(dec, passes=False, reasons=(why,))
        elif (dec.passes and not c.beyond_history
              and (why := history_refusal(ctx, cur, name, c.fit)) is not None):
            # rule 17 (history.py); judged between rows of the same input history, where a
            # misfit depending on the input's state and history alone cancels, the effect
            # has already met it
            dec = replace(dec, passes=False, reasons=(why,))
        elif (dec.passes and EFFECTS[name].transport and run.rate_testable
                and not _split_ok(run, cur)):
            dec = replace(dec, passes=False, reasons=(_SPLIT_REASON,))
            decision = "contradicted"
        elif dec.passes and EFFECTS[name].sign_locked and not _locking_ok(run, cur):
            dec = replace(dec, passes=False, reasons=(_LOCKING_REASON,))
            decision = "contradicted"
        elif dec.passes and (why := _recording_specific_refusal(run, cur, c)) is not None:
            dec = replace(dec, passes=False, reasons=(why,))  # rule 8, at the choice
        elif dec.passes and accepted and needs_earning(ctx, c):
            run.step(rnd, 0.6, f"cross-fitting {name} against the accepted effects")
            dec = _earns(run, cur, c, n_tests, accepted)
            decision = None if dec.passes else "not earned"
        cands[name] = replace(c, decision=dec, verdict=decision)
        rows.append(round_row(ctx, rnd, c, passes=dec.passes, reasons=dec.reasons,
                              decision=decision))
        if dec.passes:
            passing.append(name)
    return cands, rows, passing


def _recording_specific_refusal(run: Run, cur: Fit, c: Candidate) -> str | None:
    """Acceptance rule 8 (:func:`~core.diagnosis.acceptance.generalises`) for a candidate
    that adds a level per recording (offset, drift), judged when it could be chosen: the
    shared part predicting each recording from the others, each with its own level
    (:func:`~core.diagnosis.scoring.shared_loro`), must not get worse. Applied only after
    the rounds, an effect that fails it was taken out of the final model after it had been
    chosen over a look-alike that passes every rule, and nothing was named. ``None`` when it
    holds or does not apply (one recording, explicit windows, no new level); a refusal is
    kept in :attr:`~core.diagnosis.state.Run.recording_specific` with its numbers."""
    st = c.fit.structure
    if not run.across_recordings or not adds_levels(cur.structure, st):
        return None
    lo = shared_loro(run.ctx, cur.structure, st)
    if generalises(lo["mse_reduction"]):
        run.recording_specific.pop(c.name, None)
        return None
    run.recording_specific[c.name] = recording_specific(c.name, c.parameters, lo, True)
    return (f"one level per recording: predicting each recording from the others, each "
            f"with its own level, is {1.0 - lo['mse_reduction']:.3g} times worse in MSE "
            f"with it (leave-one-recording-out {-100 * lo['mse_reduction']:+.0f} %): it does "
            "not generalise (acceptance rule 8)")


def _share(x: float) -> str:
    """``x`` in words as a small fraction (2/3), or as a number when it is none."""
    f = Fraction(x).limit_denominator(12)
    return f"{f.numerator}/{f.denominator}" if abs(float(f) - x) < 1e-9 else f"{x:.2g}"


#: Fewest test rows in an event window for its MSE reduction to count (acceptance rule 14).
MIN_EVENT_ROWS = 20


#: Event windows rule 14 scores at most on a recording longer than
#: :data:`~core.diagnosis.screening.RANKING_SPAN` samples (evenly spread over them).
MAX_HELD_OUT_EVENTS = 24


def held_out_windows(rec: Recording, test: np.ndarray | None = None
                     ) -> tuple[list[tuple[int, int]], bool]:
    """The event windows of ``rec`` that rule 14 scores, and whether they are scored on
    their test rows with the fits on the training rows (``True``) rather than each held
    out in turn and both structures refitted without it (``False``).

    Every window of at least :data:`MIN_EVENT_ROWS` rows is held out in turn on a recording
    of up to :data:`~core.diagnosis.screening.RANKING_SPAN` samples. On a longer one, each
    refit would cost two fits on every sample (thousands of events: the square of the
    length): the windows with at least :data:`MIN_EVENT_ROWS` ``test`` rows, which the fits
    never saw, are scored there instead, at most :data:`MAX_HELD_OUT_EVENTS` of them evenly
    spread; without :data:`~core.diagnosis.acceptance.AcceptRule.min_events` such windows
    (no test rows: an explicit training window alone), at most that many windows are held
    out and refitted.
    """
    wins = [(a, b) for a, b in event_windows(rec) if b - a >= MIN_EVENT_ROWS]
    if rec.n_samples <= RANKING_SPAN:
        return wins, False
    tw = ([] if test is None else
          [(a, b) for a, b in wins if int(test[a:b].sum()) >= MIN_EVENT_ROWS])
    scored = len(tw) >= RULE.min_events
    if scored:
        wins = tw
    if len(wins) > MAX_HELD_OUT_EVENTS:
        pick = np.unique(np.round(np.linspace(0, len(wins) - 1, MAX_HELD_OUT_EVENTS)))
        wins = [wins[int(i)] for i in pick]
    return wins, scored


def event_gains(ctx: FitContext, cur: Fit, new: Fit) -> list[float]:
    """Relative MSE reduction of ``new`` over ``cur`` in each event window (from one input
    step or reversal to the next) of the one recording (:func:`held_out_windows`): each
    window held out in turn, both structures refitted on the training rows outside it
    (their nonlinear parameters kept) and scored on all its rows; on a long recording, the
    windows' test rows scored with the fits on the training rows. ``cur``'s refits are kept
    on ``ctx`` for the next candidate judged on it (:attr:`FitContext.event_residuals`)."""
    rec = ctx.records[0]
    wins, scored = held_out_windows(rec, ctx.test[0])
    memo = ctx.event_residuals
    of = memo.get("cur")
    now = (ctx.iterations, ctx.strict, ctx.within_strict)
    if of is None or of[0] is not cur or of[1] != now:
        memo.clear()
        memo["cur"] = (cur, now)
    out = []
    for a, b in wins:
        if scored:
            te = ctx.test[0][a:b]
            e0 = (rec.y[a:b] - cur.pred[0][a:b])[te]
            e1 = (rec.y[a:b] - new.pred[0][a:b])[te]
        else:
            ev = np.zeros(rec.n_samples, dtype=bool)
            ev[a:b] = True
            sub = FitContext(ctx.records, [ctx.train[0] & ~ev], [ev], parent=ctx)
            e0 = memo.get((a, b))
            if e0 is None:
                e0 = memo[(a, b)] = (rec.y - sub.fit(cur.structure, cur).pred[0])[ev]
            e1 = (rec.y - sub.fit(new.structure, new).pred[0])[ev]
        before = float(np.mean(e0**2))
        out.append(1.0 - float(np.mean(e1**2)) / before if before > 0 else 0.0)
    return out


def _events_refusal(ctx: FitContext, cur: Fit, c: Candidate) -> str | None:
    """Why acceptance rule 14 refuses candidate ``c`` (only output dynamics with one
    recording), or ``None`` when it holds."""
    if EFFECTS[c.name].dynamics is None or len(ctx.records) != 1:
        return None
    g = event_gains(ctx, cur, c.fit)
    if enough_events(g):
        return None
    seen = sum(1 for x in g if x >= RULE.min_gain)
    total = sum(1 for a, b in event_windows(ctx.records[0]) if b - a >= MIN_EVENT_ROWS)
    held = "" if total == len(g) else f" scored (evenly spread over its {total})"
    return (f"seen after only {seen} of {len(g)} input events (steps, reversals){held} of the "
            f"one recording: a dynamic stage is named when at least {RULE.min_events} "
            "independent events show it (more steps or cycles would decide)")


def _loop_shape_refusal(ctx: FitContext, cur: Fit, c: Candidate) -> str | None:
    """Why acceptance rule 16 refuses candidate ``c`` (only output dynamics with one
    recording at one excitation rate), or ``None`` when it holds."""
    if EFFECTS[c.name].dynamics is None or len(ctx.records) != 1:
        return None
    if excitation(ctx.records).rate_ratio >= RULE.min_rate_ratio:
        return None
    h = beyond_loop_shape(ctx, cur, c.fit)
    if beyond_loop_shape_ok(h):
        return None
    return (f"one recording at one excitation rate: with the residual's rate-independent "
            f"loop-shape part (a function of the input, its direction and the last reversal) "
            f"removed, it lowers the held-out MSE by {100 * h.gain:.1f} % (DM z {h.z:.2f}, "
            f"signed-rank p {h.sign_p:.2g}), so a misfit of the loop's shape explains as much "
            "(recordings at several rates, or input steps with holds, would decide)")


_SPLIT_REASON = ("the residual does not lag on the reversible (r = 0) slope as a delay or lag "
                 "would: the reversible/hysteretic split points to rate-dependent hysteresis")


def _split_ok(run: Run, cur: Fit) -> bool:
    """Acceptance rule 5 on the current model's residual (memoised per current fit)."""
    if run.split_for is not cur:
        d = lookalike_evidence(run.ctx, cur)
        run.split_for, run.split = cur, split_supports_transport(d.a_rev_s, d.a_hys_s)
    return run.split


_LOCKING_REASON = ("the residual trend after the holds does not follow the sign of the step "
                   "before them as creep would (a drift continues across steps)")


def _locking_ok(run: Run, cur: Fit) -> bool:
    """Acceptance rule 7 on the current model's residual."""
    d = sign_locking(run.ctx, cur)
    return trend_follows_steps(d.trend_follows_step_sign, d.steps_with_hold)


def needs_earning(ctx: FitContext, c: Candidate) -> bool:
    """Acceptance rule 4 applies: a further effect judged on the test rows (not already on
    cross-fitted blocks alone, between recordings, or on the pre-wipe-out rows)."""
    return not ctx.strict and c.between is None and not EFFECTS[c.name].before_wipeout


def _earns(run: Run, cur: Fit, c: Candidate, n_tests: int, accepted: tuple[str, ...]
           ) -> Decision:
    """Acceptance rule 4: ``c`` against the model holding the ``accepted`` effects on
    training blocks alone (:func:`~core.diagnosis.acceptance.earns_place`): both refitted
    (linear weights) without each block, the candidate's nonlinear parameters kept at their
    fitted values (an effect excited in one segment only, as a resonance by the fast sines,
    cannot be re-identified without it)."""
    sub = _blocks_context(run)
    if sub is None:
        return Decision(False, True, False, True, (f"as a further effect on top of "
                        f"{', '.join(accepted)} it cannot be cross-fitted (too few training "
                        "blocks)",))
    return earns_place(compare_heldout(sub, cur, c.fit), n_tests, None, accepted)


#: Training blocks of acceptance rule 4 (a further effect cross-fitted against the accepted
#: ones) without the diagnosis's own folds; :data:`EARN_SHORT_BLOCKS` of any length where
#: the recordings are too short for blocks of the usual length.
EARN_BLOCKS = 5
EARN_SHORT_BLOCKS = 4


def _blocks_context(run: Run) -> FitContext | None:
    """The cross-fitted training blocks of acceptance rule 4 (strict hold-out: the test
    rows chose the effects before a further one), or ``None`` with too few blocks."""
    ctx = run.ctx
    if run.earn_folds is None:
        run.earn_folds = (ctx.folds or crossfit_folds(ctx.records, ctx.train,
                                                      max_blocks=EARN_BLOCKS)
                          # a recording too short for 0.5 s blocks: shorter ones
                          or crossfit_folds(ctx.records, ctx.train, min_block_s=ANY_BLOCK_S,
                                            max_blocks=EARN_SHORT_BLOCKS))
    if not run.earn_folds:
        return None
    sub = FitContext(ctx.records, ctx.train, ctx.test, folds=run.earn_folds, parent=ctx)
    sub.strict = True
    return sub


def lookahead(run: Run, cur: Fit, cands: dict[str, Candidate], rows: list[RoundRow],
              todo: list[str], rnd: int
              ) -> tuple[dict[str, Candidate], list[RoundRow], list[str]]:
    """Acceptance rule 6: two effects that hide each other.

    When nothing passes on top of ``cur``, the candidate ``t`` with the largest held-out
    gain that failed the significance rule alone (effect size and fold agreement met) is
    put in tentatively and the others are judged on top of it (every rule, rule 4 included).
    If one of them, ``p``, passes there, ``t`` is judged again on top of ``p`` (fitted on
    ``cur``) as a first effect would be, with the round's Bonferroni divisor. ``t`` is
    accepted when it passes there: each of the two earns its place against the model
    holding the other (``p`` is then judged in the next round as usual). Not used with
    strict hold-out. Returns ``(cands, rows, passing)``, with ``passing = []`` otherwise.
    """
    ctx = run.ctx
    none: tuple[dict[str, Candidate], list[RoundRow], list[str]] = (cands, rows, [])
    held = [c for c in cands.values() if c.decision is not None and c.verdict is None
            and c.decision.size_ok and c.decision.stable and not c.decision.significant
            and not EFFECTS[c.name].before_wipeout]
    if ctx.strict or not held:
        return none
    t = max(held, key=lambda c: c.heldout.gain)
    run.step(rnd, 0.8, f"the others on top of {t.name}")
    sub, sub_rows = search_round(run, t.fit, remaining(todo, t.name), rnd)
    ok = judge_round(run, t.fit, sub, sub_rows, rnd, (t.name,))[2] if sub else []
    p = choose(ok, {n: sub[n].choice_gain for n in ok}) if ok else None
    if p is None or p not in cands:
        return none
    base_p = cands[p].fit
    got = build_candidate(ctx, t.name, base_p)
    tt = None if got is None else candidate_evidence(
        run, base_p, Candidate(t.name, *got, heldout=screen_gain(got[0], base_p)), rnd, 0.9)
    if tt is None:
        return none
    # judged as a first effect would be (test rows, the round's Bonferroni divisor), on top of p
    tj, t_rows, t_ok = judge_round(run, base_p, {t.name: tt}, [], rnd, (), n_tests=len(cands))
    if not t_ok:
        return none
    c = t.judged_as(tj[t.name], given=p)
    row = replace(t_rows[0], evidence=f"{t_rows[0].evidence}, judged on top of {p} (the two "
                  f"hide each other; {p} passes on top of {t.name})")
    return {**cands, t.name: c}, [r for r in rows if r.effect != t.name] + [row], [t.name]


def _sized(c: Candidate, excess: float) -> Candidate:
    """``c`` with the effect-size rules applied (``excess``: units²) and whether it meets
    them only by acceptance rule 19's waiver of the excess share."""
    ok = effect_size_ok(c.heldout, excess, elsewhere=c.elsewhere)
    return replace(c, size_ok=ok, share_waived=ok and not effect_size_ok(c.heldout, excess))


def fewer_parameters_on_same_rows(ctx: FitContext, cands: dict[str, Candidate],
                                  passing: list[str], best: str) -> str:
    """Between ``best`` and the passing effects of its family judged on the same rows of
    their signature (a drift and a creep from cycle to cycle of one repeated input), the one
    with the fewest free parameters, unless ``best`` predicts those rows significantly
    better (Diebold-Mariano z >= ``min_z``). From cycle to cycle a creep differs from a drift
    only by the decay of its change: where the rows do not show that decay, the steady trend
    is named and the creep reported ambiguous with it
    (:func:`~core.diagnosis.finding.lookalikes_of`)."""

    def width(n: str) -> int:
        t = EFFECTS[n].term
        assert t is not None
        return int(t.width(cands[n].fit.structure.term(n), len(ctx.records)))

    c = cands[best]
    if EFFECTS[best].term is None:
        return best
    pick = best
    for n in passing:
        o = cands[n]
        if n == best or o.family != c.family or EFFECTS[n].term is None:
            continue
        rows = same_signature_rows(ctx, c, o)
        if rows is None or width(n) >= width(pick):
            continue
        hh = heldout_comparison(ctx.signature_res(o.fit, rows), ctx.signature_res(c.fit, rows))
        if not (np.isfinite(hh.z) and hh.z >= RULE.min_z):
            pick = n
    return pick


def choose(passing: list[str], gains: dict[str, float]) -> str:
    """Highest-priority family with a passing effect (best gain inside the family), unless a
    later family explains at least ``family_lead`` (1.5) times as much held-out MSE."""
    by_fam: dict[str, str] = {}
    for n in passing:
        f = EFFECTS[n].family
        if f not in by_fam or gains[n] > gains[by_fam[f]]:
            by_fam[f] = n
    order = sorted(by_fam, key=lambda f: FAMILY_PRIORITY[f])
    pick = by_fam[order[0]]
    for f in order[1:]:
        if gains[by_fam[f]] >= RULE.family_lead * gains[pick]:
            pick = by_fam[f]
    return pick


def _cannot_win(held: dict[str, HeldOut], size_ok: dict[str, bool], needs_cf: set[str],
                n_tests: int) -> set[str]:
    """Candidates whose cross-fitting can be skipped: :func:`choose` could not pick them.

    When an effect that needs no cross-fitting already passes in the highest-priority family
    that has passing effects, a later family can only be picked with at least
    ``family_lead`` (1.5) times that family's best gain (:func:`choose`); families below
    that bound are left undecided ("deferred") in this round and are tested again in the
    next one.
    """
    sure = [n for n in held if size_ok[n] and n not in needs_cf and (
        held[n].z >= RULE.min_z
        or held[n].sign_p < RULE.sign_p / n_tests)]
    if not sure or not needs_cf:
        return set()
    top = min(FAMILY_PRIORITY[EFFECTS[n].family] for n in sure)
    if any(FAMILY_PRIORITY[EFFECTS[n].family] <= top for n in needs_cf):
        return set()
    fam_top = {EFFECTS[n].family for n in sure if FAMILY_PRIORITY[EFFECTS[n].family] == top}
    bound = RULE.family_lead * max(held[n].gain for n in sure if EFFECTS[n].family in fam_top)
    best_of_family: dict[str, float] = {}
    for n in needs_cf:
        f = EFFECTS[n].family
        best_of_family[f] = max(best_of_family.get(f, -np.inf), held[n].gain)
    return {n for n in needs_cf if best_of_family[EFFECTS[n].family] < bound}


def remaining(todo: list[str], best: str) -> list[str]:
    """Effects still to test after ``best`` joined the model (one dynamics effect besides
    ``rate``: the structure holds one linear block after the hysteresis)."""
    fam = EFFECTS[best].family
    return [e for e in todo if e != best and not (
        EFFECTS[e].dynamics is not None and fam == "dynamics")]
