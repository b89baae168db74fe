"""Accepting the chosen effect of a round (:func:`accept_best`): the round's decisions,
the finding and its ambiguities, the resolution refined, and the output-dynamics look-alikes
compared again (:mod:`core.diagnosis.recheck`).
"""

from __future__ import annotations

from dataclasses import replace

from .acceptance import RULE
from .bases import BASE_KINDS
from .context import FitContext
from .crossfitting import compare_heldout
from .finding import lookalikes_of, make_finding
from .recheck import recheck_dynamics
from .registry import EFFECTS, rate_effect
from .results import RoundRow
from .shapes import shape_thresholds
from .specs import DECIDING_EXPERIMENT
from .state import Candidate, Run
from .structure import Fit, dynamics_stages

__all__ = ["accept_best"]


def accept_best(run: Run, cur: Fit, cands: dict[str, Candidate], passing: list[str],
                best: str, rows: list[RoundRow], rnd: int, n_max: int) -> Fit:
    """Accept ``best``: record the round's decisions, the finding (where, discriminators,
    uncertainty, caveats), the look-alikes it is ambiguous with; refine the resolution and,
    for dynamics, re-compare the look-alikes at it. Returns the new current fit."""
    ctx = run.ctx
    c, c_spec = cands[best], EFFECTS[best]
    amb, runner = lookalikes_of(ctx, c, cands, passing)
    run.rounds.extend(r if r.decision in _KEPT_DECISIONS else replace(r, decision=(
        "accepted" if r.effect == best else "ambiguous" if r.effect in amb else
        "passes" if r.passes else "rejected")) for r in rows)
    run.findings.append(make_finding(run, cur, c, amb, runner))
    for other in amb:
        run.ambiguous.append({
            "effects": [best, other],
            "chosen": best,
            "reason": f"{other} explains {100 * cands[other].heldout.gain:.0f} % of the "
            f"{'cross-fitted' if ctx.strict else 'held-out'} MSE against "
            f"{100 * c.heldout.gain:.0f} % for {best}; the recordings do not separate them",
            "experiment": DECIDING_EXPERIMENT.get(frozenset({best, other}),
                                                  "recordings that excite both "
                                                  "mechanisms differently"),
        })
    if c_spec.inseparable_from is not None:
        other, why, experiment = c_spec.inseparable_from
        run.ambiguous.append({"effects": [best, other], "chosen": best, "reason": why,
                              "experiment": experiment})
    new = c.fit
    if n_max:
        refine: list[RoundRow] = []
        new = _refine_resolution(ctx, c.fit, n_max, refine, rnd + 1)
        run.rounds.extend(refine)
    fnd = run.findings[-1]
    if c_spec.dynamics is not None and not ctx.strict:
        new = recheck_dynamics(run, new, fnd, rnd + 1)
    elif not ctx.strict:
        new = _recheck_earlier_dynamics(run, new, rnd)
    if fnd is run.findings[-1]:  # (a second stage named in series set both structures)
        fnd.structure = new.structure
    named = fnd.name  # the dynamics recheck may rename it
    for hidden, e in EFFECTS.items():
        if e.mimicked_by is None:
            continue
        names, why = e.mimicked_by
        if named not in names or any(set(a["effects"]) == {named, hidden}
                                     for a in run.ambiguous):
            continue
        partly = e.partly_tested(ctx) if e.partly_tested is not None else None
        if hidden in run.untestable_names or partly:
            run.ambiguous.append({"effects": [named, hidden], "chosen": named,
                                  "reason": (partly or why).format(best=named),
                                  "experiment": EFFECTS[hidden].experiment})
    if (EFFECTS[named].dynamics is not None and new.structure.bouc_wen
            and run.rate_testable):
        # rate-dependent plays are not modelled on a Bouc-Wen or Menegotto-Pinto base (on a
        # Preisach base they are: the rate candidate widens the levelled plays' thresholds):
        # say so rather than let the dynamics stand in for them unchallenged
        rate = rate_effect()
        base = BASE_KINDS[new.structure.base_kind].short
        run.findings[-1].ambiguous_with.append(rate)
        run.ambiguous.append({
            "effects": [named, rate], "chosen": named,
            "reason": f"on a {base} base rate-dependent hysteresis is not modelled, so "
            f"{named} was not compared with it",
            "experiment": DECIDING_EXPERIMENT.get(frozenset({named, rate}),
                                                  EFFECTS[rate].experiment)})
    return new


#: Decisions of the acceptance rules that :func:`accept_best` keeps as they are.
_KEPT_DECISIONS = ("deferred", "contradicted", "not earned")


def _recheck_earlier_dynamics(run: Run, new: Fit, rnd: int) -> Fit:
    """Look-alikes against the model that holds every accepted effect: once a slow or static
    effect joins, an earlier delay / lag / resonance finding is compared again with its
    look-alikes (on top of the new model), renamed if one now predicts the held-out rows
    better, and reported ambiguous with those it does not beat."""
    earlier = next((f for f in run.findings[:-1] if EFFECTS[f.name].dynamics is not None),
                   None)
    if earlier is None or len(dynamics_stages(new.structure.dynamics)) > 1:
        return new  # (two stages in series: each was judged against the other, rule 12)
    old, rmse_after = earlier.name, earlier.heldout_rmse_after
    new = recheck_dynamics(run, new, earlier, rnd + 1)
    earlier.heldout_rmse_after = rmse_after  # its own step's score stays
    if earlier.name != old and earlier.structure is not None:
        earlier.structure = earlier.structure.with_(dynamics=new.structure.dynamics)
    return new


def _refine_resolution(ctx: FitContext, fit: Fit, n_max: int, rounds: list[RoundRow], rnd: int
                       ) -> Fit:
    """Once an effect is in, the baseline may turn out under-resolved: double the play grid
    while the held-out fit improves (``resolution_gain`` and ``resolution_z`` of
    :class:`~core.diagnosis.acceptance.AcceptRule`) as long as the doubled bank's weights stay
    within ``n_max`` (:attr:`~core.diagnosis.structure.Structure.play_weights`: plays times
    level segments on a Preisach base, not the plays, since every later structure fit costs
    about the square of its columns). A Preisach base of 25 plays x 3 or 5 level segments
    (75 or 125 weights) is then not refined within the ceiling of 100. Counted in plays, the
    development Preisach plant with a 200 Hz mode (25 plays x 5 segments, 132 columns) was
    refined to 100 plays (507 columns, held-out MSE -3.2 % and -2.3 %) once its mode was
    fitted from a simplex spanning the grid cell, and its diagnosis took 8 times the CPU
    time (292 s against 37 s; three fifths of it in the recordings' spread, whose fits of
    one recording fell back to a QR factor of 0.7 s each)."""
    while not fit.structure.bouc_wen and 2 * fit.structure.play_weights <= n_max:
        n2 = 2 * len(fit.structure.thresholds)
        r = shape_thresholds(fit.structure.shape, ctx.records, ctx.train, n2)  # w units
        f2 = ctx.fit(fit.structure.with_(thresholds=tuple(float(x) for x in r)), fit)
        h = compare_heldout(ctx, fit, f2)
        ok = h.gain >= RULE.resolution_gain and (h.z >= RULE.resolution_z
                                                  or h.sign_p < RULE.sign_p)
        rounds.append(RoundRow(rnd, f"resolution:{n2}", float(h.gain), float(h.z),
                               float(h.sign_p), bool(ok), "accepted" if ok else "rejected"))
        if not ok:
            break
        fit = f2
    return fit

