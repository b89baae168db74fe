"""The detection → attribution → validation engine (missing-physics notes §5).

1. Baseline: PI (+ bias) at saturating threshold resolution, NNLS on the training rows.
2. Residual battery and conditional-mean maps (LOCATE).
3. Every testable effect is fitted in full on the training rows (separable least squares:
   a search over its few nonlinear parameters with the linear weights re-solved inside) and
   compared with the current model on the held-out rows.
4. Acceptance (all must hold): held-out MSE reduction ≥ 5 % and ≥ 20 % of the current excess
   over the white-noise floor; batch-means Diebold–Mariano z ≥ 3 (robust to coloured
   residuals) or, when the effect lives in a few segments (where DM is conservative), a
   Wilcoxon signed-rank test of the batch means with p < 0.01 / K (Bonferroni over the K
   effects tested in the round).
   With explicit train/test windows the significance test also uses the training window:
   blocked cross-fitting (each training block after the wipe-out time predicted by the
   current model and by the candidate, both refitted without that block, the candidate's
   nonlinear parameters searched anew) adds those blocks to the held-out rows, and the
   nonlinear parameters must agree across folds (coefficient of variation < 30 %). The
   effect-size rules and all reported held-out RMSE stay on the test rows.
   An initial memory state can only change the rows before the wipe-out time, so
   ``initial-memory`` (1-2 virtual extrema picked from a grid on the training rows) is judged
   on those rows and must not worsen the held-out rows.
   A further effect (once effects are accepted) must pass again on cross-fitted training
   blocks alone against the model holding the accepted ones (acceptance rule 4), and a delay
   or lag is not named when the reversible/hysteretic split of the residual points to
   rate-dependent hysteresis (rule 5), creep only when the trend after the holds follows the
   step sign (rule 7); when nothing passes, two effects that hide each other are each judged
   on top of the other (rule 6; :mod:`core.diagnosis.acceptance`).
5. Inside a family of look-alike effects (delay / lag / resonance / rate; creep / drift) the
   winner is named only when it clearly beats the runner-up on held-out data; otherwise the
   finding is reported as *ambiguous*, with the experiment that would decide. An earlier
   delay / lag / resonance finding is compared with its look-alikes again once a later
   effect joins the model.
6. The accepted effect joins the model and the search repeats until nothing passes.

The loop itself is :func:`diagnose`: read → baseline and base family
(:mod:`~core.diagnosis.basechoice`) → rounds of :func:`~core.diagnosis.search.search_round`
(fit every candidate, collect its evidence), :func:`~core.diagnosis.judge.judge_round`
(acceptance rules, typed rows) and :func:`~core.diagnosis.accept.accept_best` (finding,
look-alikes, refinement, the dynamics recheck of :mod:`~core.diagnosis.recheck`) → final
scoring (:mod:`~core.diagnosis.scoring`) → adequacy → result. What a run carries between
these steps is :class:`~core.diagnosis.state.Run`.

Effects that the recordings cannot excite are reported as *untestable* with the recording
that would make them testable.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..csvio import ColumnSpec
from ..exceptions import ParameterError
from ..fitting.masing import masing
from ..validation import filled
from .accept import accept_best
from .adequacy import assess
from .basechoice import RATE_ON_STOP, choose_base_family, fit_baseline
from .between import between_plan
from .context import FitContext
from .creepsettling import untested_entry as creep_untested
from .data import as_records, crossfit_folds, split_masks
from .judge import choose, fewer_parameters_on_same_rows, judge_round, lookahead, remaining
from .locate import residual_maps
from .lookalikes import untestable_effects
from .recheck import polish_dynamics, suggest_after_steps
from .registry import EFFECTS, rate_effect
from .residualpeak import residual_peak
from .residualpeak import untestable_entry as unexcited_mode_entry
from .results import (
    ACCEPT_RULE,
    BaseChoice,
    DiagnosisResult,
    EffectFinding,
    RecordingSpecific,
    suggested_names,
)
from .scoring import (
    crossval_scores,
    drop_recording_specific,
    loro_scores,
    spread_over_recordings,
    widen_for_base,
)
from .screening import screening_note
from .search import search_round
from .specs import Untestable
from .state import Progress, Run
from .stats import noise_floor
from .structure import Fit

__all__ = ["ACCEPT_RULE", "DiagnosisResult", "EffectFinding", "diagnose"]

#: The output mode's effect name (a mode the input does not excite is said untestable).
_RESONANCE = "resonance"


def diagnose(
    recordings: Any,
    model: str = "pi",
    train: tuple[float, float] | None = None,
    test: tuple[float, float] | None = None,
    *,
    n_operators: int = 25,
    effects: Sequence[str] | None = None,
    max_effects: int = 5,
    auto_resolution: bool = True,
    base: str = "auto",
    crossfit: bool | None = None,
    time: ColumnSpec = None,
    input: ColumnSpec = None,  # noqa: A002 - mirrors csvio's role name
    output: ColumnSpec = None,
    run: ColumnSpec = None,
    resample: bool | float = False,
    progress: Callable[[float, str], None] | None = None,
) -> DiagnosisResult:
    """Locate, name, model and validate the physics a PI model leaves out.

    Parameters
    ----------
    recordings : Recording, (t, u, y) tuple, CSV path, object with t/u/y, or a list of those
        Measured recordings (t in seconds, or the sample index for quasi-static loops
        without a time axis). CSV files are read by :func:`core.csvio.read_csv`, like
        ``hyst fit``; a run/loop column gives several recordings.
    model : {"pi"}
        Base model class.
    train, test : (float, float), optional
        Time ranges (seconds) of the training and held-out rows, applied to every recording.
        By default each recording is cut into interleaved train/test blocks.
    n_operators : int
        Play operators of the baseline (uniform thresholds).
    base : {"auto", "pi"}
        ``"auto"``: a Preisach base (level-dependent memory) replaces the PI when it predicts
        each recording (or half of one) from the rest clearly better
        (:func:`~core.diagnosis.basechoice.choose_base`); ``"pi"``: always the PI.
    auto_resolution : bool
        Also try 2x and 4x as many operators and keep them while the held-out fit improves:
        the baseline's grid while its held-out MSE falls by ``resolution_gain`` (2 %) alone
        (:func:`~core.diagnosis.basechoice.fit_baseline`), once an effect is in also with a
        z of ``resolution_z`` (2) or a signed-rank p below ``sign_p``
        (:class:`~core.diagnosis.acceptance.AcceptRule`): an under-resolved baseline must
        not be mistaken for missing physics.
    effects : sequence of str, optional
        Effects to test (default: all of :data:`core.diagnosis.registry.EFFECTS`).
    max_effects : int
        Stop after this many accepted effects.
    crossfit : bool, optional
        Add blocked cross-fitting evidence from the training window to the significance test
        (:func:`core.diagnosis.data.crossfit_folds`): a candidate that passes the effect-size
        rules on the test rows is refitted with each training block held out in turn, and the
        Diebold–Mariano / signed-rank tests run on the test rows and those blocks together;
        its nonlinear parameters must also agree across folds (coefficient of variation
        below 30 %). Default: on with explicit ``train``/``test`` windows (one contiguous
        test window holds few independent batches), off for the interleaved split (its test
        blocks already span every recording). The effect-size rules and every reported
        held-out RMSE use the test rows only. A further effect (after the first) is always
        cross-fitted against the model holding the accepted ones
        (:func:`~core.diagnosis.acceptance.earns_place`).
    time, input, output, run : int, str, False or None
        Columns of CSV files (name or 0-based index; see :func:`core.csvio.read_csv`).
    resample : bool or float
        ``True``: interpolate uneven recordings (gaps too) onto a uniform grid; a float:
        resample to that spacing (s). Without it small time-stamp jitter is resampled with a
        note and a gap is an error naming where it is (:func:`core.diagnosis.as_records`).
    progress : callable ``(fraction, message)``, optional
        Called as the diagnosis advances, ``fraction`` in [0, 1].

    Returns
    -------
    DiagnosisResult
        ``.to_dict()`` is the JSON document; ``.model`` the final extended model.

    Raises
    ------
    ParameterError
        For an unknown model or effect, or unusable recordings/splits.
    """
    t_start = _time.perf_counter()
    todo = _effects_to_test(model, effects)
    say = Progress(progress)
    records = as_records(recordings, time=time, input=input, output=output, run=run,
                         resample=resample)
    say(0.0, f"read {len(records)} recording(s), {sum(r.n_samples for r in records)} samples; "
        "fitting the baseline")
    windows = train is not None or test is not None
    ctx, split = _context(records, train, test, crossfit)
    base_fit, requested, base_choice = _baseline(ctx, base, n_operators, auto_resolution)
    say(0.1, f"baseline: {len(base_fit.structure.thresholds)} operators")
    run_, todo = _start_run(ctx, base_fit, todo, max_effects, windows, say)
    tested = list(todo)
    cur, todo = _rounds(run_, base_fit, todo, max_effects,
                        4 * n_operators if auto_resolution else 0)
    cur = polish_dynamics(ctx, cur, run_.findings)
    polished, named = cur.pred, list(run_.findings)  # the mode's peak is read here
    say(0.9, "scoring the final model" + (f" ({', '.join(f.name for f in run_.findings)})"
                                          if run_.findings else ""))
    cur, loro = _across_recordings(run_, base_fit, cur, windows)
    widen_for_base(ctx, cur, run_.findings)
    say(0.92, "judging the base model against the noise floor")
    tried = [r.effect for r in run_.rounds if r.round == 1 and ":" not in r.effect]
    adequacy = assess(records, ctx.train, ctx.test, cur.pred, run_.noise, tried or list(todo),
                      base_fit.structure.free_weights, found=cur.structure.effects)
    crossval = crossval_scores(ctx, base_fit, cur)
    refit = None if windows else _refit_everywhere(ctx, cur)
    after_steps = suggest_after_steps(run_, cur)
    suggested = suggested_names(run_.rounds, after_steps)
    run_.untestable.extend(_unexcited_mode(records, polished, named, tested, suggested))
    creep = creep_untested(ctx, cur, run_.rounds, _speaking_of(run_, suggested))
    if creep is not None:
        run_.untestable.append(creep)
    say(1.0, "done")
    everywhere = [np.ones(r.n_samples, bool) for r in records]
    return DiagnosisResult(
        records=records, train=ctx.train, test=ctx.test, baseline=base_fit, final=cur,
        requested=requested, effects=run_.findings, untestable=run_.untestable,
        ambiguous=run_.ambiguous, rounds=run_.rounds,
        maps_before=residual_maps(records, ctx.all_res(base_fit), ctx.coords, everywhere),
        maps_after=residual_maps(records, ctx.all_res(cur), ctx.coords, everywhere),
        split=split, noise_rms=run_.noise, elapsed_s=_time.perf_counter() - t_start,
        model_name=model, loro_baseline=loro.baseline, loro_final=loro.final,
        crossval=crossval, adequacy=adequacy, between=run_.between, refit=refit,
        recording_specific=_specific(run_, loro.specific), base_choice=base_choice,
        after_steps=after_steps)


def _baseline(ctx: FitContext, base: str, n_operators: int, auto_resolution: bool
              ) -> tuple[Fit, Fit, BaseChoice]:
    """The baseline PI at its resolution, then (``base="auto"``) its base family: the base
    fit, the fit at the requested resolution and the base choice."""
    base_fit, requested = fit_baseline(ctx, n_operators, auto_resolution)
    if base not in ("auto", "pi"):
        raise ParameterError(f"base {base!r} is not known; use 'auto' or 'pi'")
    base_fit, base_choice = (choose_base_family(ctx, base_fit, n_operators)
                             if base == "auto" else (base_fit, BaseChoice("pi", (), 0)))
    return base_fit, requested, base_choice


#: Bases that obey Masing's rule (their branches after a reversal are the first loading
#: doubled): where the recordings break it, such a base cannot follow how a history's first
#: visit settles (:attr:`~core.diagnosis.context.FitContext.unsettled_memory`).
MASING_BASES = ("pi", "stop-pi", "preisach")


def _start_run(ctx: FitContext, base_fit: Fit, todo: list[str], max_effects: int,
               windows: bool, say: Progress) -> tuple[Run, list[str]]:
    """The run's state before the first round (noise floor, untestable effects, the
    between-recordings plan) and the effects left to test once the untestable are out."""
    noise = _noise_rms(ctx, base_fit)
    ctx.unsettled_memory = (base_fit.structure.base_kind in MASING_BASES
                            and masing(ctx.records, noise).departs)
    run_ = Run(ctx, noise, untestable_effects(ctx), max_effects,
               between_plan(ctx, windows=windows), say=say,
               across_recordings=len(ctx.records) >= 2 and not windows)
    if base_fit.structure.stop and rate_effect() in todo and \
            rate_effect() not in run_.untestable_names:
        run_.untestable.append(RATE_ON_STOP)
    todo = [e for e in todo if e not in run_.untestable_names]
    run_.rate_testable = rate_effect() in todo
    return run_, todo


def _rounds(run_: Run, cur: Fit, todo: list[str], max_effects: int, n_max: int
            ) -> tuple[Fit, list[str]]:
    """Rounds of search, judgement and acceptance until nothing passes or ``max_effects``
    are in: the model holding the accepted effects and the effects still untested."""
    for rnd in range(max_effects):
        cands, rows = search_round(run_, cur, todo, rnd)
        if not cands:
            break
        cands, rows, passing = judge_round(run_, cur, cands, rows, rnd,
                                           tuple(f.name for f in run_.findings))
        if not passing:  # two effects that hide each other (acceptance rule 6)?
            cands, rows, passing = lookahead(run_, cur, cands, rows, todo, rnd)
        if not passing:
            run_.rounds.extend(rows)
            break
        best = fewer_parameters_on_same_rows(
            run_.ctx, cands, passing, choose(passing, {n: cands[n].choice_gain for n in passing}))
        cur = accept_best(run_, cur, cands, passing, best, rows, rnd, n_max)
        todo = remaining(todo, best)
    return cur, todo


@dataclass(frozen=True)
class _AcrossRecordings:
    """Leave-one-recording-out scores of the baseline and the final model (``None`` with one
    recording or explicit windows) and the effects found recording-specific."""

    baseline: dict[str, Any] | None
    final: dict[str, Any] | None
    specific: list[RecordingSpecific]


def _across_recordings(run_: Run, base_fit: Fit, cur: Fit, windows: bool
                       ) -> tuple[Fit, _AcrossRecordings]:
    """With several recordings and no windows: each recording predicted from the others,
    the recording-specific effects dropped (acceptance rule 8) and each parameter's spread
    over the recordings; the final model and the scores."""
    ctx = run_.ctx
    if len(ctx.records) < 2 or windows:
        return cur, _AcrossRecordings(None, None, [])
    loro_b, loro_f = loro_scores(ctx, base_fit, cur, run_.findings)
    cur, loro_f, specific = drop_recording_specific(run_, base_fit, cur, loro_b,
                                                    filled(loro_f))
    run_.say(0.91, "estimating each parameter from the other recordings")
    spread_over_recordings(ctx, base_fit, cur, run_.findings)
    return cur, _AcrossRecordings(loro_b, loro_f, specific)


def _specific(run_: Run, dropped: list[RecordingSpecific]) -> list[RecordingSpecific]:
    """The effects rule 8 refused: per-recording levels refused in their round and not in
    the final model, then those dropped from the final model."""
    out = {f.name for f in run_.findings} | {d.name for d in dropped}
    return [r for n, r in run_.recording_specific.items() if n not in out] + dropped


def _refit_everywhere(ctx: FitContext, cur: Fit) -> Fit:
    """The selected structure refitted on every row (train and test blocks): the interleaved
    test blocks served selection and scoring; the saved model uses all the data."""
    every = [a | b for a, b in zip(ctx.train, ctx.test, strict=True)]
    full = FitContext(ctx.records, every, [np.zeros_like(m) for m in every], parent=ctx)
    return full.fit(cur.structure, cur)


def _unexcited_mode(records: list, pred: list, findings: list[EffectFinding],
                    tested: list[str], suggested: list[str]) -> list[Untestable]:
    """The untestable entry of a lightly damped mode the input does not excite
    (:func:`~core.diagnosis.residualpeak.residual_peak` of the model's prediction
    ``pred``), when the resonance was tested and neither named, nor left ambiguous with
    what was named, nor suggested (``suggested``: the improvement that failed the
    significance rules, or the kind too few input steps show); else nothing.

    A suggested resonance is one statement already: the input drove a mode enough for its
    fit to improve the held-out rows (or the steps to ring), which is a test, suggestive,
    so "untestable" would contradict it; the suggestion and its experiment stand alone."""
    if _RESONANCE not in tested or _RESONANCE in suggested or any(
            f.name == _RESONANCE or _RESONANCE in f.ambiguous_with for f in findings):
        return []
    pk = residual_peak(records, pred)
    return [] if pk is None else [unexcited_mode_entry(pk)]


def _speaking_of(run_: Run, suggested: list[str]) -> list[str]:
    """Effects the report already speaks of: named, ambiguous with a name, suggested, or
    said untestable."""
    return sorted({f.name for f in run_.findings}
                  | {n for f in run_.findings for n in f.ambiguous_with}
                  | {n for a in run_.ambiguous for n in a["effects"]}
                  | set(suggested) | set(run_.untestable_names))


def _effects_to_test(model: str, effects: Sequence[str] | None) -> list[str]:
    if model != "pi":
        raise ParameterError(f"model {model!r} is not supported by diagnose yet; use 'pi'")
    todo = list(EFFECTS if effects is None else effects)
    for e in todo:
        if e not in EFFECTS:
            raise ParameterError(f"unknown effect {e!r}; known: {', '.join(EFFECTS)}")
    return todo


def _context(records: list, train, test, crossfit: bool | None) -> tuple[FitContext, str]:
    """Train/test rows, cross-fitting folds and the split description."""
    trm, tem, desc = split_masks(records, train, test)
    if crossfit is None:
        crossfit = train is not None
    ctx = FitContext(records, trm, tem, folds=crossfit_folds(records, trm) if crossfit else None)
    # strict hold-out: with an explicit test window every decision (baseline grid, free
    # weights, effects, look-alikes) rests on cross-fitted training blocks; the test window
    # is only scored
    ctx.strict = bool(ctx.folds) and train is not None
    if train is not None and test is None and not ctx.strict:
        raise ParameterError(
            "without a test window the effects are selected by cross-fitting blocks of the "
            "training rows, but the training rows after the wipe-out time are too short for "
            "two blocks of 0.5 s; give a longer --train window, or a --test window"
            + (" (and do not turn cross-fitting off)" if crossfit is False else ""))
    if ctx.strict:
        desc += (f"; selection by cross-fitting {len(ctx.folds)} training blocks, the test "
                 "window is never used for selection")
    elif ctx.folds:
        desc += f"; significance also on {len(ctx.folds)} cross-fitted training blocks"
    note = screening_note(records, trm)
    if note:
        desc += "; " + note
    return ctx, desc


def _noise_rms(ctx: FitContext, base: Fit) -> float:
    """White-noise floor of the baseline residual (training rows with strict hold-out)."""
    return float(np.sqrt(np.mean([noise_floor(e[m]) ** 2 for e, m in zip(
        ctx.all_res(base), ctx.train if ctx.strict else ctx.test, strict=True)])))
