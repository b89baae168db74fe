"""The recheck of accepted output dynamics (delay / lag / resonance): the look-alikes
compared again at the refined resolution and on the model holding every accepted effect
(rules 9-11, :func:`recheck_dynamics`), a pair of stages in series named (rule 12), and the
final polish of the stage's parameters (:func:`polish_dynamics`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .acceptance import (
    RULE,
    clearly_better,
    pair_beats_single,
    second_stage_named,
    signatures_separable,
    yields_to_lookalike,
)
from .candidates import (
    PAIR_MAXFEV,
    PAIR_STEP,
    build_candidate,
    nelder_mead,
    sigma_from_curvature,
)
from .candidates import stage_pair as build_pair
from .context import FitContext
from .crossfitting import ambiguous_parameters
from .data import ANY_BLOCK_S, crossfit_folds
from .eventresponse import MAX_STEP_DT_S, EventResponse, StepSuggestion, event_response
from .events import Excitation, excitation, step_starts
from .finding import make_finding
from .registry import EFFECTS, dynamics_of, output_dynamics, stage_pairs
from .results import EffectFinding, RoundRow, pooled_mse
from .search import WHERE_MIN_ROWS, WHERE_MIN_Z, WHERE_SHARE, where_it_lives
from .specs import DECIDING_EXPERIMENT
from .state import Candidate, Run
from .stats import HeldOut, heldout_comparison, with_where
from .structure import Fit, dynamics_stages, pack_dynamics

__all__ = ["POLISH_XATOL", "STAGE_BLOCKS_PER_RECORDING", "polish_dynamics", "recheck_dynamics"]


#: How the caveat saying what the rows after the input events show begins (rule 18).
AFTER_EVENTS = "output dynamics after the input events: "
#: A stage's fits in :func:`recheck_dynamics`, by name: (fit, parameters, 1-sigmas, the
#: comparison with the structure without output dynamics on the held-out rows).
_Fitted = dict[str, tuple[Fit, dict[str, Any], dict[str, Any], HeldOut]]


def recheck_dynamics(run: Run, cur: Fit, finding: EffectFinding, rnd: int) -> Fit:
    """Re-compare delay / lag / resonance at the refined resolution and keep the best; a
    pair of stages in series that beats it (rule 11) is named when each of its stages earns
    its place over the other alone (rule 12, :func:`_name_pair`; only for the stage just
    accepted: ``finding`` is the last finding)."""
    ctx, ambiguous, rounds = run.ctx, run.ambiguous, run.rounds
    base = ctx.fit(cur.structure.with_(dynamics=()), cur)
    te0 = ctx.test_res(base)
    results: _Fitted = {finding.name: (cur, finding.parameters, finding.uncertainty,
                                       heldout_comparison(te0, ctx.test_res(cur)))}
    for alt in output_dynamics():
        if alt in results:
            continue
        got = build_candidate(ctx, alt, base)
        if got is not None:
            results[alt] = (got[0], got[1], got[2], heldout_comparison(te0, ctx.test_res(got[0])))
    best, unnamed, lacks, vs = _named_stage(ctx, results)
    exc = excitation(ctx.records)
    # rule 15: without steps or several rates the look-alikes' signatures cannot show
    unseparated = not signatures_separable(exc.steps, exc.rate_ratio)
    after = _after_events(run, base)
    if unseparated and after is not None:
        # rule 18: the look-alikes stay open; the one named first is the one the step shows
        shown = after.step_kind
        if (shown in results and shown not in (best, unnamed)
                and not _lacks_signature(shown, results[shown][1])):
            best, vs = shown, _against(ctx, results, shown)
    fit, params, unc, h = results[best]
    amb = []
    for other, hh in vs.items():
        oh = results[other][3]
        # rule 10: a look-alike not clearly beaten on the same structure stays open
        open_ = not clearly_better(hh) or other == unnamed or unseparated
        rounds.append(RoundRow(rnd, f"recheck:{other}", oh.gain, hh.z, hh.sign_p, False,
                               "ambiguous" if open_ else "rejected", results[other][1]))
        if open_:
            amb.append(other)
    in_pair, beating = _pairs_in_series(ctx, rounds, base, fit, results, best, te0, rnd)
    amb += [n for n in in_pair if n not in amb]
    if best != finding.name:
        # pairs among delay / lag / resonance are recomputed below; others (rate, creep) follow
        # the new name
        old = finding.name
        ambiguous[:] = [dict(a, effects=[best if e == old else e for e in a["effects"]],
                             chosen=best, reason=a["reason"].replace(old, best))
                        if a["chosen"] == old else a for a in ambiguous]
        finding.name = best
        finding.parameters = params
        finding.uncertainty = unc
        finding.ambiguous_parameters = ambiguous_parameters(params, unc)
        finding.explanation = EFFECTS[best].explanation
        finding.equation = EFFECTS[best].equation
    finding.ambiguous_with = amb
    if after is not None:
        words = AFTER_EVENTS + after.where(float(ctx.records[0].t[1] - ctx.records[0].t[0]))
        finding.caveats = [c for c in finding.caveats if not c.startswith(AFTER_EVENTS)] + [words]
    finding.heldout_rmse_after = float(np.sqrt(pooled_mse(ctx.test_res(fit))))
    ambiguous[:] = [a for a in ambiguous if not set(a["effects"]) <= set(output_dynamics())]
    for other in amb:
        why = _why_open(other, best, unnamed, results, h, vs.get(other), in_pair, exc)
        ambiguous.append({
            "effects": [best, other],
            "chosen": best,
            "reason": why + (
                f"; {other} is not named: {lacks}" if lacks and other == unnamed else ""),
            "experiment": DECIDING_EXPERIMENT.get(frozenset({best, other}),
                                                  "recordings at more frequencies"),
        })
    for a, b, got, hp in beating if finding is run.findings[-1] else ():
        named = _name_pair(run, base, finding, {n: results[n] for n in (a, b)}, got, hp, rnd)
        if named is not None:
            return named
    return fit


def suggest_after_steps(run: Run, cur: Fit) -> StepSuggestion | None:
    """The output dynamics kind the input steps of the one recording show on top of the
    final fit ``cur`` when it has no output dynamics (rule 18: with fewer than
    ``min_events`` steps, suggestive; :meth:`EventResponse.step_suggestion`), ``None``
    otherwise or where :func:`_after_events` judges nothing."""
    if cur.structure.dynamics or len(run.ctx.records) != 1:
        return None
    # no step, or enough steps for the held-out rules: nothing to suggest (not judged)
    if not 0 < step_starts(run.ctx.records[0].u).size < RULE.min_events:
        return None
    after = _after_events(run, cur)
    if after is None:
        return None
    return after.step_suggestion(float(run.ctx.records[0].t[1] - run.ctx.records[0].t[0]))


def _after_events(run: Run, base: Fit) -> EventResponse | None:
    """What the rows after the input events of the one recording show on top of ``base``
    (the structure without output dynamics; :mod:`core.diagnosis.eventresponse`), ``None``
    with several recordings, without a uniform time axis or sampled more slowly than
    :data:`~core.diagnosis.eventresponse.MAX_STEP_DT_S`."""
    ctx = run.ctx
    if len(ctx.records) != 1:
        return None
    t = np.asarray(ctx.records[0].t, dtype=np.float64)
    dt = np.diff(t)
    if dt.size < 2 or not np.allclose(dt, dt[0], rtol=1e-6, atol=0.0):
        return None
    if dt[0] > MAX_STEP_DT_S:  # too slow a sampling for a step's milliseconds
        return None
    return event_response(ctx.records[0], base.pred[0], noise=run.noise)


def _undecided(hh: HeldOut) -> bool:
    """Neither test of the significance rule separates two stages (DM z below ``min_z`` and
    signed-rank p at least ``sign_p``, without Bonferroni)."""
    return hh.z < RULE.min_z and hh.sign_p >= RULE.sign_p


def _against(ctx: FitContext, results: _Fitted, b: str) -> dict[str, HeldOut]:
    """Comparison of every other stage with ``b`` on the held-out rows."""
    return {o: heldout_comparison(ctx.test_res(results[o][0]), ctx.test_res(results[b][0]))
            for o in results if o != b}


def _named_stage(ctx: FitContext, results: _Fitted
                 ) -> tuple[str, str | None, str | None, dict[str, HeldOut]]:
    """The stage named among ``results``: the one with the least held-out MSE, unless its
    fitted values lack its own signature (a mode too damped to ring) and a look-alike that
    shows its own is not significantly worse or leaves at most a small margin more held-out
    MSE (rule 9). Returns the name, the stage passed over by rule 9 (or ``None``), why it
    lacks its signature (or ``None``) and every other stage against the named one."""
    best = min(results, key=lambda n: results[n][3].mse_after)
    unnamed = None
    vs = _against(ctx, results, best)
    lacks = _lacks_signature(best, results[best][1])
    if lacks:
        alts = [o for o, hh in vs.items()
                if (_undecided(hh) or yields_to_lookalike(results[best][3].mse_after,
                                                          results[o][3].mse_after))
                and not _lacks_signature(o, results[o][1])]
        if alts:
            unnamed = best
            best = min(alts, key=lambda n: results[n][3].mse_after)
            vs = _against(ctx, results, best)
    return best, unnamed, lacks, vs


def _pairs_in_series(ctx: FitContext, rounds: list[RoundRow], base: Fit, fit: Fit,
                     results: _Fitted, best: str, te0: list[np.ndarray], rnd: int
                     ) -> tuple[dict[str, str], list[tuple[str, str, tuple, HeldOut]]]:
    """Rule 11: each pair of stages the registry lets act in series, fitted jointly on
    ``base`` and compared with the named stage ``best`` (``fit``) where the pair changes the
    prediction most, one round row each. Returns why each member of a pair that beats it
    (other than ``best``) stays open, and those pairs (names, fit, comparison)."""
    in_pair: dict[str, str] = {}
    beating: list[tuple[str, str, tuple, HeldOut]] = []
    for a, b in stage_pairs():
        if a not in results or b not in results:
            continue
        got = build_pair(ctx, base, (a, results[a][1]), (b, results[b][1]))
        if got is None:
            continue
        # tested also where the pair changes the prediction most, as a single stage is
        hp = where_it_lives(ctx, fit, got[0], heldout_comparison(ctx.test_res(fit),
                                                                 ctx.test_res(got[0])))
        rings = not any(_lacks_signature(n, {k.split(".", 1)[1]: v for k, v in got[1].items()
                                             if k.startswith(n + ".")}) for n in (a, b))
        ok = rings and pair_beats_single(hp)
        if ok:
            beating.append((a, b, got, hp))
        rounds.append(RoundRow(rnd, f"recheck:{a}+{b}", heldout_comparison(te0, ctx.test_res(
            got[0])).gain, hp.z, hp.sign_p, False, "ambiguous" if ok else "rejected", got[1]))
        for n in (a, b) if ok else ():
            if n != best:
                in_pair[n] = (f"{a} followed by {b}, fitted together, leaves "
                              f"{100 * hp.gain:.0f} % less held-out MSE than {best} alone "
                              f"(DM z {hp.z:.1f}): the output may pass through both")
    return in_pair, beating


def _why_open(other: str, best: str, unnamed: str | None, results: _Fitted, h: HeldOut,
              ho: HeldOut | None, in_pair: dict[str, str], exc: Excitation) -> str:
    """Why look-alike stage ``other`` stays ambiguous with the named ``best`` (``h``: its
    comparison with the structure without output dynamics; ``ho``: ``other`` against it)."""
    at = " at the final resolution"
    if other == unnamed and results[other][3].mse_after < h.mse_after:
        why = (f"{other} leaves {100 * (1 - results[other][3].mse_after / h.mse_after):.1f}"
               f" % less held-out MSE than {best}")
    elif other == unnamed or ho is None or _undecided(ho):
        why = (f"{best} and {other} predict the held-out rows equally well (DM z < "
               f"{RULE.min_z:g}, signed-rank p >= {RULE.sign_p:g})")
    elif not clearly_better(ho):
        why = (f"{best} predicts the held-out rows better than {other}, but {other} "
               f"leaves only {100 * (ho.mse_before / ho.mse_after - 1):.1f} % more "
               "held-out MSE")
    elif other in in_pair:
        why = in_pair[other]
    else:
        at = ""
        why = (f"the recordings hold {exc.steps} input step(s) and one excitation rate "
               f"(slowest / fastest {exc.rate_ratio:.2g}): a {best} and a {other} cannot "
               "show their own signatures there (no response for a dead time, an "
               "immediate smooth one for a lag, a ringing for a mode), so the "
               f"{100 * (ho.mse_before / ho.mse_after - 1):.0f} % more held-out MSE of "
               f"{other} is how it absorbs the base's misfit, not its mechanism")
    return why + at


#: Contiguous training blocks per recording held out in turn when a second output stage is
#: judged on training rows (acceptance rule 12): the blocks of rule 4 are placed by duration
#: and miss a short recording (the fast sines) where output dynamics live.
STAGE_BLOCKS_PER_RECORDING = 2


def _stage_folds(run: Run) -> list[tuple[list[np.ndarray], list[np.ndarray]]]:
    """Folds holding out each of :data:`STAGE_BLOCKS_PER_RECORDING` contiguous training
    blocks of every recording in turn (the other rows stay in training; memoised)."""
    if run.stage_folds is None:
        ctx = run.ctx
        none = [np.zeros_like(m) for m in ctx.train]
        run.stage_folds = []
        for j in range(len(ctx.train)):
            only = [m if k == j else none[k] for k, m in enumerate(ctx.train)]
            for _, blk in crossfit_folds(ctx.records, only, min_block_s=ANY_BLOCK_S,
                                         max_blocks=STAGE_BLOCKS_PER_RECORDING):
                run.stage_folds.append(([t & ~b for t, b in zip(ctx.train, blk, strict=True)],
                                        blk))
    return run.stage_folds


def _blocks_where_it_lives(ctx: FitContext, folds: list, cur: Fit, new: Fit) -> HeldOut:
    """``cur`` against ``new`` on cross-fitted training blocks (linear weights refitted
    without each block, nonlinear parameters kept, as
    :func:`~core.diagnosis.crossfitting.compare_heldout`), the significance also tested
    where the two predictions differ most, as on the test rows
    (:func:`~core.diagnosis.search.where_it_lives`)."""
    eb: list[np.ndarray] = []
    ea: list[np.ndarray] = []
    diff: list[np.ndarray] = []
    for tr_f, blk in folds:
        fc = FitContext(ctx.records, tr_f, blk, parent=ctx)
        fa, fb = fc.fit(cur.structure, cur), fc.fit(new.structure, new)
        eb += fc.test_res(fa)
        ea += fc.test_res(fb)
        diff += [np.abs(a - b)[m] for a, b, m in zip(fb.pred, fa.pred, blk, strict=True)]
    h = heldout_comparison(eb, ea)
    pooled = np.concatenate(diff) if diff else np.zeros(0)
    if not (np.isfinite(h.z) and h.z >= WHERE_MIN_Z) or pooled.size < WHERE_MIN_ROWS or (
            not np.any(pooled > 0)):
        return h
    cut = float(np.quantile(pooled, 1.0 - WHERE_SHARE))
    keep = [d >= cut for d in diff]
    hw = heldout_comparison([e[k] for e, k in zip(eb, keep, strict=True)],
                            [e[k] for e, k in zip(ea, keep, strict=True)])
    return with_where(h, hw)


def _polish_alone(ctx: FitContext, base: Fit, name: str, starts: list[dict[str, Any]]) -> Fit:
    """Output stage ``name`` alone on ``base`` (no dynamics), re-optimised from the best of
    its ``starts`` (parameter dicts) with the Nelder-Mead budget of a pair
    (:data:`~core.diagnosis.candidates.PAIR_MAXFEV`, log space): the baseline against which
    a second stage in series is judged (rule 12) gets the optimiser effort the pair got."""
    spec = EFFECTS[name].dynamics
    assert spec is not None
    dt = min(r.dt for r in ctx.records)

    def obj(lx: np.ndarray) -> float:
        v = tuple(float(a) for a in np.exp(lx))
        return (ctx.rss(base.structure.with_(dynamics=(name, *v)), base) if spec.valid(v, dt)
                else np.inf)

    xs = [np.log(np.asarray([float(p[k]) for k in spec.params])) for p in starts]
    fs = [obj(x) for x in xs]
    x0 = xs[int(np.argmin(fs))]
    x, fx = nelder_mead(obj, x0, PAIR_STEP, PAIR_MAXFEV)
    if not fx <= min(fs):
        x = x0
    return ctx.fit(base.structure.with_(dynamics=(name, *(float(a) for a in np.exp(x)))), base)


def _pair_sigmas(ctx: FitContext, fit: Fit, h: float = 0.05) -> dict[str, dict[str, Any]]:
    """1-sigmas of each stage's parameters in the pair ``fit`` (per stage name): the 1-D
    profile curvature of the training RSS in log space (step ``h``; the other parameters
    held), as for a single stage
    (:func:`~core.diagnosis.candidates.sigma_from_curvature`)."""
    stages = dynamics_stages(fit.structure.dynamics)
    x0 = np.log(np.asarray([v for _, vals in stages for v in vals], dtype=float))

    def rss(lx: np.ndarray) -> float:
        dyn = pack_dynamics([n for n, _ in stages], np.exp(lx))
        return ctx.rss(fit.structure.with_(dynamics=dyn), fit)

    f0 = rss(x0)
    sig: dict[str, dict[str, Any]] = {}
    j = 0
    for n, vals in stages:
        keys = dynamics_of(n).params
        sig[n] = {}
        for k, v in zip(keys, vals, strict=True):
            e = np.eye(x0.size)[j] * h
            c = (rss(x0 + e) - 2 * f0 + rss(x0 - e)) / h**2
            sig[n][k] = sigma_from_curvature(ctx, fit, c, float(v))
            j += 1
    return sig


def _name_pair(run: Run, base: Fit, finding: EffectFinding, alone: dict[str, tuple],
               got: tuple, hp: HeldOut, rnd: int) -> Fit | None:
    """Acceptance rule 12: name both stages of a pair in series that beat the single stage
    ``finding`` names (rule 11, ``hp``: that stage against the pair ``got``, fitted on
    ``base``), when each stage shows its own signature in the pair and the pair beats the
    other stage alone (re-optimised alone, :func:`_polish_alone`, from its single fit
    ``alone[name]`` and from its values in the pair) on the held-out rows where they differ
    and on cross-fitted training blocks. ``finding`` becomes the stage that predicts better
    alone, on the structure with that stage alone; the other stage is a new finding after
    it, on the structure with the pair. Returns the pair's fit, or ``None`` (nothing
    changed but the round rows)."""
    ctx = run.ctx
    pair_fit = got[0]
    stages = dynamics_stages(pair_fit.structure.dynamics)
    params = {n: dict(zip(dynamics_of(n).params, v, strict=True))
              for n, v in stages}
    why: dict[str, str] = {}
    for n, v in stages:
        other = next(o for o, _ in stages if o != n)
        lacks = dynamics_of(n).lacks_signature_in_series
        reason = lacks(v, dict(stages)[other], min(r.dt for r in ctx.records)) if lacks else None
        if reason:
            why[n] = reason
    folds = _stage_folds(run)
    fits: dict[str, Fit] = {}
    tests: dict[str, tuple[HeldOut, HeldOut | None]] = {}
    for n, _ in stages if not why and folds else ():
        if why:  # (the other stage did not earn its place: nothing is named)
            break
        other = next(o for o, _ in stages if o != n)
        fits[other] = _polish_alone(ctx, base, other, [alone[other][1], params[other]])
        h = heldout_comparison(ctx.test_res(fits[other]), ctx.test_res(pair_fit))
        h = where_it_lives(ctx, fits[other], pair_fit, h)
        hb = (_blocks_where_it_lives(ctx, folds, fits[other], pair_fit)
              if pair_beats_single(h) else None)
        tests[n] = (h, hb)
        if hb is None or not second_stage_named(h, hb):
            why[n] = (f"it does not predict better than {other} alone, re-optimised alone "
                      f"(held-out {100 * h.gain:.0f} %, DM z {h.z:.1f}" + (
                          f"; training blocks {100 * hb.gain:.0f} %, DM z {hb.z:.1f}"
                          if hb is not None else "") + ")")
    if not folds:
        why = {n: "too few training rows to cross-fit it" for n, _ in stages}
    for n, _ in stages if why else ():
        why.setdefault(n, "not named alone: the other stage of the pair did not earn its place")
    for n, _ in stages:
        h, hb = tests.get(n, (hp, None))
        run.rounds.append(RoundRow(rnd, f"second stage:{n}", h.gain, h.z, h.sign_p,
                                   n not in why, "rejected" if n in why else "accepted",
                                   params[n], reasons=(why[n],) if n in why else None))
    if why:
        return None
    # the stage that predicts better alone is the finding's; the other joins after it
    first = min(fits, key=lambda n: pooled_mse(ctx.test_res(fits[n])))
    second = next(n for n, _ in stages if n != first)
    old = finding.name
    if old != first:
        run.ambiguous[:] = [dict(a, effects=[first if e == old else e for e in a["effects"]],
                                 chosen=first, reason=a["reason"].replace(old, first))
                            if a["chosen"] == old else a for a in run.ambiguous]
        finding.name = first
        finding.explanation = EFFECTS[first].explanation
        finding.equation = EFFECTS[first].equation
    sig = _pair_sigmas(ctx, pair_fit)
    finding.parameters = params[first]
    finding.uncertainty = sig[first]
    finding.uncertainty_method = ("profile curvature in the pair of stages (inflated for "
                                  "residual autocorrelation)")
    finding.ambiguous_parameters = ambiguous_parameters(finding.parameters, finding.uncertainty)
    # the pair's stages are no longer look-alikes of each other; the single stage the pair
    # replaced stays open unless the pair is clearly better (rule 10)
    members = {first, second}
    run.ambiguous[:] = [a for a in run.ambiguous
                        if not set(a["effects"]) <= set(output_dynamics())]
    finding.ambiguous_with = []
    if old not in members and not clearly_better(hp):
        finding.ambiguous_with.append(old)
        run.ambiguous.append({
            "effects": [first, old], "chosen": first,
            "reason": f"{first} followed by {second} leaves only "
            f"{100 * (hp.mse_before / hp.mse_after - 1):.1f} % less held-out MSE than {old}",
            "experiment": DECIDING_EXPERIMENT.get(frozenset({first, old}),
                                                  "recordings at more frequencies")})
    alone_fit = fits[first]
    finding.heldout_rmse_after = float(np.sqrt(pooled_mse(ctx.test_res(alone_fit))))
    finding.structure = alone_fit.structure
    h2 = tests[second][0]
    c2 = Candidate(second, pair_fit, params[second], sig[second], heldout=h2)
    f2 = make_finding(run, alone_fit, c2, [], {})
    f2.uncertainty_method = finding.uncertainty_method
    f2.evidence = f"{f2.evidence}, in series with {first} re-optimised alone (rule 12)"
    f2.structure = pair_fit.structure
    run.findings.append(f2)
    return pair_fit


def _lacks_signature(name: str, params: dict[str, Any]) -> str | None:
    """Why the fitted ``params`` of output dynamics stage ``name`` do not show its own
    signature (:attr:`~core.diagnosis.registry.OutputDynamics.lacks_signature`), or None."""
    dyn = EFFECTS[name].dynamics
    if dyn is None or dyn.lacks_signature is None:
        return None
    return dyn.lacks_signature(tuple(float(params[k]) for k in dyn.params))


#: Relative resolution (log units) of the final polish of a dynamics stage's parameters.
POLISH_XATOL = 0.002


def polish_dynamics(ctx: FitContext, cur: Fit, findings: list[EffectFinding]) -> Fit:
    """Settle the accepted dynamics stage's parameters to :data:`POLISH_XATOL` on the final
    structure (with every effect found after it). The searches that rank the candidates
    stop at about 3 % in log units, coarser than the parameters' uncertainty: a 200 Hz mode
    was reported as 206.6 Hz with a 0.3 Hz sigma on three different base families."""
    import scipy.optimize as so

    dyn = cur.structure.dynamics
    stages = dynamics_stages(dyn)
    if not stages or any(not any(f.name == n for f in findings) for n, _ in stages):
        return cur
    dt = min(r.dt for r in ctx.records)
    x0 = np.log(np.asarray([v for _, vals in stages for v in vals], dtype=float))

    def stage(lx: np.ndarray) -> tuple | None:
        return pack_dynamics([n for n, _ in stages], np.exp(lx), dt)

    def obj(lx: np.ndarray) -> float:
        d = stage(lx)
        return np.inf if d is None else ctx.rss(cur.structure.with_(dynamics=d), cur)

    f0 = obj(x0)
    if x0.size == 1:
        r = so.minimize_scalar(lambda v: obj(np.array([v])), method="bounded",
                               bounds=(x0[0] - 0.05, x0[0] + 0.05),
                               options={"xatol": POLISH_XATOL, "maxiter": 20})
        x, fx = np.array([r.x]), float(r.fun)
    else:
        # steps of 0.03 in the log of the first value of each stage, 0.1 in the others
        steps = [0.03 if k == 0 else 0.1 for _, vals in stages for k in range(len(vals))]
        simplex = np.vstack([x0] + [x0 + st * np.eye(x0.size)[k] for k, st in enumerate(steps)])
        r = so.minimize(obj, x0, method="Nelder-Mead",
                        options={"xatol": POLISH_XATOL, "fatol": 0.0, "maxfev": 40 * x0.size,
                                 "initial_simplex": simplex})
        x, fx = r.x, float(r.fun)
    new = stage(x)
    if not fx < f0 or new is None:
        return cur
    old = dyn
    for g in findings:
        if g.structure is not None and g.structure.dynamics == old:
            g.structure = g.structure.with_(dynamics=new)
    for (n, _), (_, vals) in zip(stages, dynamics_stages(new), strict=True):
        f = next(f for f in findings if f.name == n)
        spec = EFFECTS[n].dynamics
        assert spec is not None
        f.parameters = dict(f.parameters, **dict(zip(spec.params, vals, strict=True)))
    return ctx.fit(cur.structure.with_(dynamics=new), cur)
