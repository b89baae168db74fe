"""The readable text report of a diagnosis."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .misspecification import describe_alternative, long_name

if TYPE_CHECKING:
    from .results import DiagnosisResult, EffectFinding

__all__ = ["ALL_ROWS_WORDS", "final_fit_words", "summary_text"]

#: What the report says beside an effect whose term was to be fitted on its changes from
#: cycle to cycle and was fitted on all the training rows
#: (:attr:`~core.diagnosis.results.EffectFinding.fitted_on_all_rows`).
ALL_ROWS_WORDS = ("fitted on all the training rows: fitted on its changes from cycle to "
                  "cycle it left the training rows worse than without it")


def final_fit_words(res: DiagnosisResult, e: EffectFinding) -> str | None:
    """What the report says when the final model fitted the term of the accepted effect
    ``e`` otherwise than the fit its parameters come from, else ``None``.

    The effect's line gives the parameters of the fit it was judged with, and beside them
    whether that fit fell back to all the training rows
    (:attr:`~core.diagnosis.results.EffectFinding.fitted_on_all_rows`). The final model,
    refitted with every effect named (:attr:`~core.diagnosis.results.DiagnosisResult.final`,
    :attr:`~core.diagnosis.structure.Fit.raw_fallback`), may have fitted the same term the
    other way; the model the user gets is that one, so the report says so.
    """
    if e.name not in res.final.structure.effects:
        return None
    fell_back = e.name in res.final.raw_fallback
    if fell_back == e.fitted_on_all_rows:
        return None
    if fell_back:
        return ("in the final model, refitted with every effect named, this term was "
                f"{ALL_ROWS_WORDS}; the values above are from the fit it was judged with, "
                "on its changes from cycle to cycle")
    return ("the final model, refitted with every effect named, did not need to fit this "
            "term on all the training rows; the values above are from the fit it was judged "
            "with, which did")


def summary_text(res: DiagnosisResult) -> str:  # noqa: C901 - one branch per report section
    """The readable multi-line report of a diagnosis (``hyst diagnose`` without ``--json``)."""
    yr = res.y_range
    b = res.heldout_rmse(res.baseline)
    f = res.heldout_rmse(res.final)
    lines = [
        f"Recordings: {', '.join(f'{r.name} ({r.n_samples} samples)' for r in res.records)}",
        f"Split: {res.split}",
        f"Baseline {res.baseline.structure.base_kind.upper()} "
        f"({len(res.baseline.structure.thresholds)} "
        f"{'elements' if res.baseline.structure.bouc_wen else 'operators'}"
        + (f" x {len(res.baseline.structure.levels) + 1} level segments"
           if res.baseline.structure.levels else "")
        + f"{', weights of free sign' if res.baseline.structure.free_weights else ''}"
        "): " + (f"held-out RMSE {b:.4g} ({100 * b / yr:.3f} % of output range)"
                 if np.isfinite(b) else "no test window")
        + f"; white-noise floor {res.noise_rms:.3g}",
    ]
    nq = len(res._req.structure.thresholds)
    bc = res.base_choice
    if bc is not None and (bc.kind != "pi" or bc.tried):
        # (after the baseline line: which base, and how the others predicted the recordings)
        lines.insert(3, f"Base: {bc.text_in(res.records[0].units)}")
    if (bc is None or bc.kind == "pi") and nq != len(res.baseline.structure.thresholds):
        q = res.heldout_rmse(res._req)
        lines.insert(2, f"PI with the requested {nq} operators: held-out RMSE {q:.4g} "
                     f"({100 * q / yr:.3f} %); under-resolved, the grid was refined")
    ad = res.adequacy
    if not res.effects and (ad is None or ad.adequate):
        lines.append("No missing physics detected: no effect improved the held-out fit "
                     "significantly, and the residual is at the noise floor.")
    elif not res.effects:
        lines.append("No effect of the list improved the held-out fit significantly"
                     + (" and generalised to unseen recordings." if res.recording_specific
                        else "."))
    for i, e in enumerate(res.effects, 1):
        lines += _effect_lines(res, i, e, yr)
    if np.isfinite(f):
        lines.append(f"Final: held-out RMSE {f:.4g} ({100 * f / yr:.3f} % of output range)")
    else:
        lines.append("Final: no test window (nothing held out to score)")
    if res.crossval is not None:
        cv = res.crossval
        lines.append(
            f"Cross-fitted training blocks ({cv['folds']}, the rows the selection used, so "
            f"optimistic for the final model): RMSE baseline {cv['baseline_rmse']:.4g} "
            f"({cv['baseline_rmse'] * cv['pct_of']:.3f} %) -> final {cv['final_rmse']:.4g} "
            f"({cv['final_rmse'] * cv['pct_of']:.3f} %)")
    if res.loro_baseline is not None and res.loro_final is not None:
        lb_, lf_ = res.loro_baseline, res.loro_final
        per = ", ".join(f"{a['recording']} {a['rmse']:.4g} -> {b_['rmse']:.4g}"
                        for a, b_ in zip(lb_["per_recording"], lf_["per_recording"],
                                         strict=True))
        lines.append(f"Leave-one-recording-out RMSE (each recording predicted by the model "
                     f"refitted on the others): baseline {lb_['rmse']:.4g} -> final "
                     f"{lf_['rmse']:.4g} (MSE {-100 * lf_['mse_reduction'] + 0.0:+.1f} %); "
                     f"{per}")
    lines += _not_claimed_lines(res)
    bp = res.between
    if bp is not None and len(res.records) >= 2:
        lines.append("Between recordings (each predicted from the others): rate-dependent "
                     + ("effects tested" if bp.rate else f"effects not tested ({bp.rate_reason})")
                     + "; amplitude-dependent " + ("effects tested" if bp.amplitude else
                                                    f"effects not tested ({bp.amplitude_reason})"))
    if ad is not None and (not ad.adequate or res.effects):
        lines.append(f"Base model: {ad.text}")
    for a in res.ambiguous:
        lines.append(f"Ambiguous: {' vs '.join(a['effects'])} ({a['reason']}); to decide: "
                     f"{a['experiment']}")
    groups: dict[tuple[str, str], list[str]] = {}
    for u in res.untestable:  # effects untestable for the same reason share one line
        groups.setdefault((u.reason, u.experiment), []).append(u.name)
    for (reason, experiment), names in groups.items():
        lines.append(f"Untestable: {', '.join(names)}: {reason}; would need {experiment}")
    return "\n".join(lines)


def _effect_lines(res: DiagnosisResult, i: int, e: EffectFinding, yr: float) -> list[str]:
    """The report's lines of the ``i``-th accepted effect ``e`` (parameters, evidence,
    cross-fitting, where, why, the equation, caveats and dependences)."""
    units = dict(getattr(res.records[0], "units", None) or {}) if res.records else {}
    ps = ", ".join(_param_text(e, k, v, units) for k, v in e.parameters.items())
    if e.evidence == "test rows":
        evidence = [
            f"   held-out RMSE {e.heldout_rmse_before:.4g} -> {e.heldout_rmse_after:.4g} "
            f"({100 * e.heldout_rmse_before / yr:.3f} % -> "
            f"{100 * e.heldout_rmse_after / yr:.3f} %), MSE -{100 * e.heldout.gain:.1f} "
            f"%, z = {e.heldout.z:.1f}, signed-rank p = {e.heldout.sign_p:.2g}"]
    else:
        evidence = [
            f"   accepted on {e.evidence}: MSE -{100 * e.heldout.gain:.1f} %, "
            f"z = {e.heldout.z:.1f}, signed-rank p = {e.heldout.sign_p:.2g}"]
        if np.isfinite(e.heldout_rmse_after):
            # (only an explicit test window is never used for selection: without one
            # the interleaved held-out blocks also chose the other candidates)
            evidence.append(
                ("   test window (scored only, never used for selection): RMSE "
                 if res.crossval is not None else
                 "   held-out blocks (they also served the selection of other effects): "
                 "RMSE ")
                +
                f"{e.heldout_rmse_before:.4g} -> {e.heldout_rmse_after:.4g} "
                f"({100 * e.heldout_rmse_before / yr:.3f} % -> "
                f"{100 * e.heldout_rmse_after / yr:.3f} %)")
    head = f"{i}. {e.name}: {ps}"
    if e.fitted_on_all_rows:
        head += f" ({ALL_ROWS_WORDS})"
    lines = [head, *evidence] + ([
        f"   cross-fitted training blocks: test rows + {e.crossfit['folds']} blocks give "
        f"z = {e.crossfit['dm_z_pooled']:.1f}, signed-rank p = "
        f"{e.crossfit['signed_rank_p_pooled']:.2g}; MSE reduction per block "
        + ", ".join(f"{100 * g:+.0f} %" for g in e.crossfit["fold_mse_reductions"])
    ] if e.crossfit and e.evidence == "test rows" else []) + [
        f"   where: {e.where.get('summary', '')}",
        f"   why: {e.explanation}",
        f"   added: {e.equation}",
    ]
    lines += [f"   caveat: {c}" for c in e.caveats]
    if (other := final_fit_words(res, e)) is not None:
        lines.append(f"   final model: {other}")
    lines += _base_dependence(e)
    lines += _recording_dependence(e)
    if e.loro is not None:
        lines.append(f"   leave-one-recording-out RMSE {e.loro['rmse_before']:.4g} -> "
                     f"{e.loro['rmse_after']:.4g} (MSE "
                     f"{-100 * e.loro['mse_reduction'] + 0.0:+.1f} %)")
    if e.ambiguous_with:
        lines.append(f"   ambiguous with: {', '.join(e.ambiguous_with)}")
    return lines


def _not_claimed_lines(res: DiagnosisResult) -> list[str]:
    """The report's lines of what was tested and not claimed: suggestive effects, the
    recording-specific ones and those judged between recordings only."""
    lines: list[str] = []
    suggestive = res.suggestive_rows
    for sg in suggestive:
        ex = dict(sg.extra)
        pooled = (f"; with the cross-fitted blocks z = {ex['dm_z_pooled']:.2f}, "
                  f"p = {ex['signed_rank_p_pooled']:.2g}, parameter CV across folds "
                  + ", ".join(f"{k} {100 * v:.0f} %" for k, v in ex["parameter_cv"].items())
                  if "dm_z_pooled" in ex else "")
        lines.append(f"Suggestive, not claimed: {sg.effect} (held-out MSE "
                     f"-{100 * sg.heldout_mse_reduction:.0f} %, z = {sg.dm_z:.2f}, "
                     f"signed-rank p = {sg.signed_rank_p:.2g}{pooled}: below the "
                     "acceptance rule)")
    if res.after_steps is not None:
        lines.append(f"Suggestive, not claimed: {res.after_steps.text}")
    for rs in res.recording_specific:
        per = ", ".join(f"{p['recording']} {p['rmse_before']:.4g} -> {p['rmse_after']:.4g}"
                        for p in rs.per_recording)
        lines.append(f"Recording-specific, not claimed: {rs.text}"
                     + (f"; left-out RMSE {per}" if per else ""))
    shown = ({sg.effect for sg in suggestive} | {e.name for e in res.effects}
             | {rs.name for rs in res.recording_specific})
    for row in res.rounds:  # judged between recordings and not claimed: say so
        ex = dict(row.extra)
        if row.round == 1 and "per_recording" in ex and row.effect not in shown:
            per = ", ".join(f"{p['recording']} {-100 * p['mse_reduction'] + 0.0:+.0f} %"
                            for p in ex["per_recording"])
            lines.append(f"Tested between recordings, not claimed: {row.effect} (each "
                         "recording predicted from the others with its parameters searched "
                         f"on them: MSE {-100 * row.heldout_mse_reduction + 0.0:+.1f} % "
                         f"pooled, z = {row.dm_z:.2f}; {per})")
    return lines


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v)


def _base_dependence(e: Any) -> list[str]:
    """For each ambiguous parameter whose sigma is mostly the base model's misspecification
    (:func:`~core.diagnosis.misspecification.base_sensitivity`): its estimates on the other
    bases, and what would fix it."""
    bs = getattr(e, "base_sensitivity", None)
    if not bs:
        return []
    out = []
    for k in e.ambiguous_parameters:
        sys_s, stat = bs["sigma"].get(k), bs["sigma_statistical"].get(k)
        if sys_s is None or (isinstance(stat, float) and stat >= sys_s):
            continue
        chosen = long_name(bs["base"])
        alts = ", ".join(f"{_fmt(p[k])} on {describe_alternative(b, bs['base'])}"
                         for b, p in bs["per_base"].items())
        out.append(f"   {k} depends on the base model: {_fmt(e.parameters[k])} on the "
                   f"chosen {chosen} base, {alts} (the ± includes it); a base model that "
                   f"fits the loop better, or an experiment that excites the {e.name} apart "
                   "from the loop, would fix it")
    return out


def _recording_dependence(e: Any) -> list[str]:
    """For each ambiguous parameter whose sigma is mostly the recordings' disagreement (the
    jackknife of :func:`~core.diagnosis.misspecification.recording_jackknife` at least as
    large as the base model's term): its estimates with each recording left out."""
    jk = getattr(e, "recording_jackknife", None)
    if not jk:
        return []
    bs = getattr(e, "base_sensitivity", None) or {}
    out = []
    for k in e.ambiguous_parameters:
        s_jk, s_base = jk["sigma"].get(k), (bs.get("sigma") or {}).get(k)
        if s_jk is None or (isinstance(s_base, float) and s_base > s_jk):
            continue
        est = ", ".join(f"{_fmt(p[k])} without '{n}'"
                        for n, p in zip(jk["recordings"], jk["per_recording"], strict=True))
        out.append(f"   {k} depends on which recordings are used: {_fmt(e.parameters[k])} "
                   f"from all, {est} (the ± includes it); more recordings that excite the "
                   f"{e.name} like these would fix it")
    return out


def _param_text(e: Any, k: str, v: Any, units: dict[str, str] | None = None) -> str:
    """``k = v ± sigma``, or ``k ambiguous (estimate v ± sigma)`` for a parameter the data do
    not fix to a number; a parameter whose name is a symbol of the code (asymmetry's ``a2``)
    is named by the words its effect declared
    (:func:`~core.diagnosis.registry.parameter_words`), with its unit (the recording's, else
    "output units" / "input units")."""
    from .registry import parameter_words

    s = e.uncertainty.get(k)
    declared = parameter_words(e.name, k)
    name, unit = k, ""
    if declared is not None:
        name, role = declared
        have = (units or {}).get(role.removeprefix("1/"), "")
        if role in ("", "s", "Hz"):
            unit = role
        else:
            unit = f"{'1/' if role.startswith('1/') else ''}{have}" if have else f"{role} units"
        unit = f" {unit}" if unit else ""
    if k in e.ambiguous_parameters:
        return f"{name} ambiguous (estimate {_fmt(v)} ± {_fmt(s)}{unit})"
    return f"{name} = {_fmt(v)}" + (f" ± {_fmt(s)}" if s is not None else "") + unit
