"""The scoring of the final model: leave-one-recording-out scores (:func:`loro_scores`),
rule 8 (:func:`drop_recording_specific`), the uncertainties widened by the recordings'
disagreement and the base's misspecification, and the cross-fitted scores of strict
hold-out (:func:`crossval_scores`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..fitting.metrics import percent_of_range
from .acceptance import generalises
from .between import leave_one_recording_out
from .context import FitContext
from .crossfitting import (
    ambiguous_parameters,
    combine_uncertainty,
    compare_heldout,
    recording_spread,
)
from .misspecification import base_sensitivity, describe_alternative, recording_jackknife
from .registry import EFFECTS
from .results import EffectFinding, RecordingSpecific
from .state import Run
from .structure import Fit, Structure

__all__ = ["adds_levels", "crossval_scores", "drop_recording_specific", "loro_scores",
           "recording_specific", "shared_loro", "spread_over_recordings", "widen_for_base"]


def loro_scores(ctx: FitContext, base: Fit, cur: Fit, findings: list[EffectFinding]
                ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Leave-one-recording-out scores of the baseline and the final structure, and (into each
    finding's ``loro``) of the structure up to and including each accepted effect against
    the structure just before it (what that effect adds on unseen recordings)."""
    loro_b = leave_one_recording_out(ctx, base.structure)
    loro_f = loro_b if cur.structure == base.structure else leave_one_recording_out(
        ctx, cur.structure)
    loro_f = dict(loro_f, mse_reduction=1.0 - loro_f["rmse"] ** 2 / max(
        loro_b["rmse"] ** 2, 1e-300))
    prev = loro_b
    for fnd in findings:
        st = fnd.structure
        lo = loro_f if st == cur.structure else (
            leave_one_recording_out(ctx, st) if st is not None else None)
        if lo is None:
            continue
        fnd.loro = {"rmse_before": prev["rmse"], "rmse_after": lo["rmse"],
                    "mse_reduction": 1.0 - lo["rmse"] ** 2 / max(prev["rmse"] ** 2, 1e-300),
                    "per_recording": [
                        {"recording": a["recording"], "rmse_before": a["rmse"],
                         "rmse_after": b_["rmse"]}
                        for a, b_ in zip(prev["per_recording"], lo["per_recording"],
                                         strict=True)]}
        prev = lo
    return loro_b, loro_f


def spread_over_recordings(ctx: FitContext, base: Fit, cur: Fit,
                           findings: list[EffectFinding]) -> None:
    """Widen each finding's 1-sigmas by the recordings' disagreement about its parameters
    (:func:`~core.diagnosis.crossfitting.recording_spread`, each recording fitted alone, and
    :func:`~core.diagnosis.misspecification.recording_jackknife`, each left out in turn),
    where larger, and mark the parameters that stay ambiguous: a base misfit biases them
    differently per recording, which the noise-driven sigmas cannot show."""
    for f in findings:
        if EFFECTS[f.name].family != "dynamics":  # the ones with nonlinear parameters
            continue
        unc0 = f.uncertainty
        sp = recording_spread(ctx, f.name, cur, cur.structure.without(f.name, base.structure))
        if sp is not None and sp["sigma_between"]:
            f.recording_spread = sp
            f.uncertainty = combine_uncertainty(f.uncertainty, sp)
            f.uncertainty_method += (f"; widened by the disagreement of the "
                                     f"{len(sp['per_recording'])} recordings fitted alone "
                                     "(Birge ratio), where larger")
        jk = recording_jackknife(ctx, f.name, cur, f.parameters)
        if jk is not None:
            f.recording_jackknife = jk
            f.uncertainty = combine_uncertainty(f.uncertainty, {"sigma_between": jk["sigma"]})
            f.uncertainty_method += (f"; widened by the jackknife over the "
                                     f"{len(jk['recordings'])} recordings left out in turn, "
                                     "where larger")
        if f.uncertainty is not unc0:
            f.ambiguous_parameters = ambiguous_parameters(f.parameters, f.uncertainty)


def widen_for_base(ctx: FitContext, cur: Fit, findings: list[EffectFinding]) -> None:
    """Add to each finding's 1-sigmas, in quadrature, the systematic term of the base model's
    misspecification (:func:`~core.diagnosis.misspecification.base_sensitivity`: the shifts
    of its parameters with the base replaced by the other base families, on the training
    rows of the final structure), and mark the parameters that become ambiguous."""
    for f in findings:
        sens = base_sensitivity(ctx, f.name, cur, f.parameters)
        if sens is None or not sens["per_base"]:
            continue
        f.base_sensitivity = {"base": cur.structure.base_kind, **sens,
                              "sigma_statistical": {k: f.uncertainty.get(k)
                                                    for k in sens["sigma"]}}
        unc = dict(f.uncertainty)
        for k, v in sens["sigma"].items():
            s0 = unc.get(k)
            s0 = float(s0) if isinstance(s0, (int, float)) and np.isfinite(s0) else 0.0
            unc[k] = float(np.hypot(s0, v))
        f.uncertainty = unc
        alts = " and by ".join(describe_alternative(k, cur.structure.base_kind)
                               for k in sens["per_base"])
        f.uncertainty_method += ("; widened by the largest shift of the estimate with the base "
                                 f"model replaced by {alts}")
        f.ambiguous_parameters = ambiguous_parameters(f.parameters, f.uncertainty)


def drop_recording_specific(run: Run, base: Fit, cur: Fit, loro_b: dict[str, Any],
                            loro_f: dict[str, Any]
                            ) -> tuple[Fit, dict[str, Any], list[RecordingSpecific]]:
    """Acceptance rule 8 (:func:`~core.diagnosis.acceptance.generalises`): an accepted effect
    whose leave-one-recording-out MSE gets worse explains the recordings it was fitted on but
    not unseen ones. It is taken out of the findings and the final model (refitted without
    it) and reported as recording-specific with the numbers; look-alike notes that chose it
    go with it. Returns the final fit, its leave-one-recording-out score and the list."""
    ctx = run.ctx
    drop: list[tuple[EffectFinding, dict[str, Any], bool]] = []
    prev = base.structure
    for f in run.findings:
        lo, st = f.loro, f.structure
        per_rec = st is not None and adds_levels(prev, st)
        if lo is not None and st is not None and per_rec:
            lo = shared_loro(ctx, prev, st)
            f.loro = dict(f.loro or {}, shared=lo)
        if lo is not None and not per_rec:
            lo = _scored_where_testable(ctx, f.name, lo)
            f.loro = lo
        if lo is not None and not generalises(lo["mse_reduction"]):
            drop.append((f, lo, per_rec))
        prev = st if st is not None else prev
    if not drop:
        return cur, loro_f, []
    s = cur.structure
    out = []
    for f, lo, per_rec in drop:
        s = s.without(f.name, base.structure)
        out.append(recording_specific(f.name, f.parameters, lo, per_rec))
    names = {f.name for f, _, _ in drop}
    run.findings[:] = [f for f in run.findings if f.name not in names]
    run.ambiguous[:] = [a for a in run.ambiguous if a.get("chosen") not in names]
    cur = ctx.fit(s, cur)
    lo = loro_b if s == base.structure else leave_one_recording_out(ctx, s)
    loro_f = dict(lo, mse_reduction=1.0 - lo["rmse"] ** 2 / max(loro_b["rmse"] ** 2, 1e-300))
    return cur, loro_f, out


def adds_levels(prev: Structure, st: Structure) -> bool:
    """Whether structure ``st`` holds per-recording levels (offsets, drifts) that ``prev``
    does not: levels an unseen recording cannot know, judged by :func:`shared_loro`."""
    return st.recording_levels() != prev.recording_levels()


def shared_loro(ctx: FitContext, prev: Structure, st: Structure) -> dict[str, Any]:
    """Acceptance rule 8 for a per-recording level (offset, drift) that ``st`` adds to
    ``prev``: such a level cannot be known for an unseen recording, so what it does to the
    shared part is judged, each left-out recording given its own level of the same degree
    in time (:data:`~core.diagnosis.between.SHARED_RULE`) with and without it.

    Returns
    -------
    dict
        ``{"rule", "rmse_before", "rmse_after", "mse_reduction", "per_recording":
        [{"recording", "rmse_before", "rmse_after"}]}``; RMSE in output units.
    """
    a = leave_one_recording_out(ctx, prev, st.own_level)
    b = leave_one_recording_out(ctx, st, st.own_level)
    return {"rule": a["rule"], "rmse_before": a["rmse"], "rmse_after": b["rmse"],
            "mse_reduction": 1.0 - b["rmse"] ** 2 / max(a["rmse"] ** 2, 1e-300),
            "per_recording": [{"recording": x["recording"], "rmse_before": x["rmse"],
                               "rmse_after": y["rmse"]}
                              for x, y in zip(a["per_recording"], b["per_recording"],
                                              strict=True)]}


def recording_specific(name: str, parameters: dict[str, Any], lo: dict[str, Any],
                       per_rec: bool) -> RecordingSpecific:
    """The report of effect ``name`` failing acceptance rule 8 with leave-one-recording-out
    score ``lo`` (:func:`shared_loro` when ``per_rec``: one level per recording)."""
    worse = 1.0 - lo["mse_reduction"]
    per = " (one per recording: it differs between the recordings)" if per_rec else ""
    unscored = [r["recording"] for r in lo.get("per_recording", ()) if r.get("scored") is False]
    if unscored:
        per += (f" (scored without {', '.join(unscored)}: without it the others cannot "
                f"test {name})")
    return RecordingSpecific(
        name, dict(parameters), float(lo["mse_reduction"]), float(lo["rmse_before"]),
        float(lo["rmse_after"]), tuple(lo.get("per_recording", ())),
        f"{name}{per} improved the recordings it was fitted on, but predicting each "
        f"recording from the others with it is {worse:.3g} times worse in MSE "
        f"(leave-one-recording-out {-100 * lo['mse_reduction']:+.0f} %): it does not "
        "generalise, so it is specific to these recordings (or stands in for a misfit "
        "of the base model), not claimed as physics and not in the final model")


def _untestable_without(ctx: FitContext, name: str) -> dict[int, str]:
    """Recordings ``j`` whose removal leaves effect ``name`` untestable on the others (its
    own rule, :attr:`~core.diagnosis.registry.DiagnosableEffect.untestable`, applied to the
    other recordings' rows), with the reason: creep fitted on recordings without a hold."""
    rule = EFFECTS[name].untestable
    out: dict[int, str] = {}
    if rule is None or len(ctx.records) < 2:
        return out
    for j in range(len(ctx.records)):
        keep = [k for k in range(len(ctx.records)) if k != j]
        sub = FitContext([ctx.records[k] for k in keep], [ctx.train[k] for k in keep],
                         [ctx.test[k] for k in keep], parent=ctx)
        sub.coords = [ctx.coords[k] for k in keep]
        why = rule(sub)
        if why:
            out[j] = why[0] if isinstance(why, tuple) else why
    return out


def _scored_where_testable(ctx: FitContext, name: str, lo: dict[str, Any]) -> dict[str, Any]:
    """Acceptance rule 8 scores a left-out recording only when the others can test the effect
    (:func:`_untestable_without`): creep fitted on recordings without a hold is fitted where
    it is untestable, so its prediction of the recording that holds every hold says nothing
    about whether creep generalises. Those recordings keep their numbers, marked
    ``"scored": False`` with the reason; ``mse_reduction`` pools the scored ones (the
    unchanged ``lo`` when every recording is scored, ``None`` when none is)."""
    skip = _untestable_without(ctx, name)
    per = lo.get("per_recording") or []
    if not skip or len(per) != len(ctx.records):
        return lo
    sse_b = sse_a = 0.0
    rows = []
    for j, (row, rec) in enumerate(zip(per, ctx.records, strict=True)):
        if j in skip:
            rows.append(dict(row, scored=False,
                             why=f"without it the others cannot test {name}: {skip[j]}"))
            continue
        rows.append(dict(row, scored=True))
        sse_b += row["rmse_before"] ** 2 * rec.n_samples
        sse_a += row["rmse_after"] ** 2 * rec.n_samples
    red = None if sse_b <= 0 else 1.0 - sse_a / sse_b
    return dict(lo, per_recording=rows, mse_reduction=red, mse_reduction_all=lo["mse_reduction"])


def crossval_scores(ctx: FitContext, base: Fit, cur: Fit) -> dict[str, Any] | None:
    """Strict hold-out: baseline and final RMSE on the cross-fitted training blocks."""
    if not ctx.strict:
        return None
    cv = compare_heldout(ctx, base, cur)
    return {"folds": len(ctx.folds), "baseline_rmse": float(np.sqrt(cv.mse_before)),
            "final_rmse": float(np.sqrt(cv.mse_after)),
            # % of the output range of the block rows (per unit RMSE)
            "pct_of": percent_of_range(1.0, [
                r.y[np.any([blk[k] for _, blk in ctx.folds], axis=0)]
                for k, r in enumerate(ctx.records)])}
