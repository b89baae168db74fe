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

The loop itself is :func:`diagnose`: read → baseline → rounds of :func:`_search` (fit every
candidate, collect its evidence), :func:`_judge` (acceptance rules, typed rows) and
:func:`_accept` (finding, look-alikes, refinement) → final scoring → adequacy → result.

Effects that the recordings cannot excite are reported as *untestable* with the recording
that would make them testable.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..base import Chain
from ..csvio import ColumnSpec
from ..exceptions import ParameterError
from ..fitting.choice import FREE_SIGN_GAIN, PREISACH_MIN_GAIN, PREISACH_OVER_MAP
from ..fitting.metrics import percent_of_range
from ..fitting.orientation import loop_orientation
from ..fitting.stop import branch_features
from ..stop import StopPIModel
from ..validation import filled
from .acceptance import (
    RULE,
    Decision,
    beyond_loop_shape_ok,
    clearly_better,
    decide,
    earns_place,
    enough_events,
    generalises,
    harmless_elsewhere,
    pair_beats_single,
    second_stage_named,
    signatures_separable,
    split_supports_transport,
    trend_follows_steps,
    yields_to_lookalike,
)
from .acceptance import size_ok as effect_size_ok
from .adequacy import assess, fold_mse
from .bases import BW_MIN_GAIN, bouc_wen_elements, fit_stop_gap, saturations, stop_stage
from .between import (
    BetweenPlan,
    between_plan,
    between_recordings,
    leave_one_recording_out,
)
from .candidates import PAIR_MAXFEV, build_candidate, nelder_mead, sigma_from_curvature
from .candidates import stage_pair as build_pair
from .context import FitContext
from .crossfitting import (
    ambiguous_parameters,
    combine_uncertainty,
    compare_heldout,
    crossfit_candidate,
    crossfit_summary,
    effect_uncertainty,
    recording_spread,
    screen_gain,
)
from .data import as_records, crossfit_folds, split_masks
from .events import event_windows, excitation
from .grid import baseline_thresholds
from .locate import residual_maps, where_improved
from .lookalikes import (
    beyond_loop_shape,
    lookalike_evidence,
    score_statistic,
    sign_locking,
    untestable_effects,
)
from .misspecification import base_sensitivity, describe_alternative, recording_jackknife
from .periodic import steady_state_history
from .registry import EFFECTS, output_dynamics, rate_effect, stage_pairs
from .results import (
    ACCEPT_RULE,
    BaseChoice,
    DiagnosisResult,
    EffectFinding,
    RecordingSpecific,
    RoundRow,
    pooled_mse,
)
from .shapes import loop_shape, shape_thresholds
from .specs import DECIDING_EXPERIMENT, FAMILY_PRIORITY
from .stats import HeldOut, heldout_comparison, noise_floor
from .structure import Fit, Structure, dynamics_stages, pack_dynamics

__all__ = ["ACCEPT_RULE", "DiagnosisResult", "EffectFinding", "diagnose"]

def _lead_bound(lead: tuple[str, float] | None, name: str) -> float:
    """Smallest gain with which ``name`` could still be chosen over the leading passing
    family (:func:`_choose`: a later family needs ``family_lead`` times its gain); 0 when
    unbounded."""
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


def _deferred_row(rnd: int, name: str, params: dict | None = None,
                  screen: float | None = None) -> RoundRow:
    """Row of a candidate left for the next round: because a higher-priority family passed
    and it could not explain 1.5 times as much, or (``screen``, its training-RSS reduction,
    below zero) because it does not lower the training error at all."""
    why = ("not needed: an effect of a higher-priority family passed, and this one could not "
           f"explain {RULE.family_lead:g} times as much") if screen is None else (
        f"not tested further: it does not lower the training error (change "
        f"{100 * screen:+.1f} %), so it cannot pass held out")
    return RoundRow(rnd + 1, name, float("nan"), float("nan"), float("nan"), False,
                    "deferred", params or {}, why)


def _evidence_label(ctx: FitContext, name: str, cf: dict[str, Any] | None,
                    bt: dict[str, Any] | None = None) -> str:
    if bt is not None:
        return (f"each of {bt['folds']} recordings predicted from the others "
                "(leave-one-recording-out, parameters searched without it)")
    if EFFECTS[name].before_wipeout:
        return ("training rows before the wipe-out time (in-sample, 1-2 parameters)"
                if ctx.strict else "rows before the wipe-out time")
    if ctx.strict:
        return (f"{cf['folds']} cross-fitted training blocks" if cf is not None else
                "training-RSS screen (below the effect-size rule, not cross-fitted)")
    return "test rows"


# ----------------------------------------------------------------------------- main entry
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
        each recording (or half of one) from the rest clearly better (:func:`_choose_base`);
        ``"pi"``: always the PI.
    auto_resolution : bool
        Also try 2x and 4x as many operators and keep them while the held-out fit improves
        (≥ 2 %, z ≥ 2): an under-resolved baseline must not be mistaken for missing physics.
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
        cross-fitted against the model holding the accepted ones (:func:`_earns_place`).
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
    say = _Progress(progress)
    records = as_records(recordings, time=time, input=input, output=output, run=run,
                         resample=resample)
    say(0.0, f"read {len(records)} recording(s), {sum(r.n_samples for r in records)} samples; "
        "fitting the baseline")
    ctx, split = _context(records, train, test, crossfit)
    base_fit, requested = _baseline(ctx, n_operators, auto_resolution)
    if base not in ("auto", "pi"):
        raise ParameterError(f"base {base!r} is not known; use 'auto' or 'pi'")
    base_fit, base_choice = (_choose_base_family(ctx, base_fit, n_operators) if base == "auto"
                             else (base_fit, BaseChoice("pi", (), 0)))
    say(0.1, f"baseline: {len(base_fit.structure.thresholds)} operators")
    run_ = _Run(ctx, _noise_rms(ctx, base_fit), untestable_effects(ctx), max_effects,
                between_plan(ctx, windows=train is not None or test is not None), say=say)
    if base_fit.structure.stop and rate_effect() in todo and \
            rate_effect() not in run_.untestable_names:
        run_.untestable.append(_RATE_ON_STOP)
    todo = [e for e in todo if e not in run_.untestable_names]
    run_.rate_testable = rate_effect() in todo
    cur = base_fit
    for rnd in range(max_effects):
        cands, rows = _search(run_, cur, todo, rnd)
        if not cands:
            break
        cands, rows, passing = _judge(run_, cur, cands, rows, rnd,
                                      tuple(f.name for f in run_.findings))
        if not passing:  # two effects that hide each other (acceptance rule 6)?
            cands, rows, passing = _lookahead(run_, cur, cands, rows, todo, rnd)
        if not passing:
            run_.rounds.extend(rows)
            break
        best = _choose(passing, {n: cands[n].heldout.gain for n in passing})
        cur = _accept(run_, cur, cands, passing, best, rows, rnd,
                      4 * n_operators if auto_resolution else 0)
        todo = _remaining(todo, best)
    cur = _polish_dynamics(ctx, cur, run_.findings)
    say(0.9, "scoring the final model" + (f" ({', '.join(f.name for f in run_.findings)})"
                                          if run_.findings else ""))
    loro_b, loro_f = (_loro_scores(ctx, base_fit, cur, run_.findings)
                      if len(records) >= 2 and train is None and test is None else (None, None))
    specific: list[RecordingSpecific] = []
    if loro_b is not None:
        cur, loro_f, specific = _drop_recording_specific(run_, base_fit, cur, loro_b,
                                                         filled(loro_f))
        say(0.91, "estimating each parameter from the other recordings")
        _spread_over_recordings(ctx, base_fit, cur, run_.findings)
    _widen_for_base(ctx, cur, run_.findings)
    say(0.92, "judging the base model against the noise floor")
    tried = [r.effect for r in run_.rounds if r.round == 1 and ":" not in r.effect]
    adequacy = assess(records, ctx.train, ctx.test, cur.pred, run_.noise, tried or list(todo),
                      base_fit.structure.free_weights, found=cur.structure.effects)
    crossval = _crossval(ctx, base_fit, cur)
    refit = _refit_everywhere(ctx, cur) if train is None and test is None else None
    say(1.0, "done")
    everywhere = [np.ones(r.n_samples, bool) for r in records]
    return DiagnosisResult(
        records=records, train=ctx.train, test=ctx.test, baseline=base_fit, final=cur,
        requested=requested, effects=run_.findings, untestable=run_.untestable,
        ambiguous=run_.ambiguous, rounds=run_.rounds,
        maps_before=residual_maps(records, ctx.all_res(base_fit), ctx.coords, everywhere),
        maps_after=residual_maps(records, ctx.all_res(cur), ctx.coords, everywhere),
        split=split, noise_rms=run_.noise, elapsed_s=_time.perf_counter() - t_start,
        model_name=model, loro_baseline=loro_b, loro_final=loro_f,
        crossval=crossval, adequacy=adequacy, between=run_.between, refit=refit,
        recording_specific=specific, base_choice=base_choice)


def _refit_everywhere(ctx: FitContext, cur: Fit) -> Fit:
    """The selected structure refitted on every row (train and test blocks): the interleaved
    test blocks served selection and scoring; the saved model uses all the data."""
    every = [a | b for a, b in zip(ctx.train, ctx.test, strict=True)]
    full = FitContext(ctx.records, every, [np.zeros_like(m) for m in every], parent=ctx)
    return full.fit(cur.structure, cur)


# ----------------------------------------------------------------------------- engine steps
class _Progress:
    """``progress(fraction, message)`` with the fraction clipped to [0, 1] (or nothing)."""

    def __init__(self, progress: Callable[[float, str], None] | None) -> None:
        self.progress = progress

    def __call__(self, frac: float, msg: str) -> None:
        if self.progress is not None:
            self.progress(float(min(max(frac, 0.0), 1.0)), msg)


@dataclass(frozen=True)
class _Candidate:
    """One effect fitted on top of the current model, with its evidence.

    ``heldout`` holds the effect-size statistics (test rows; with strict hold-out, or between
    recordings, the pooled evidence rows), ``crossfit`` the output of :func:`crossfit_candidate` and
    ``between`` that of :func:`~core.diagnosis.between.between_recordings` when used.
    """

    name: str
    fit: Fit
    parameters: dict[str, Any]
    uncertainty: dict[str, Any]
    heldout: HeldOut
    crossfit: dict[str, Any] | None = None
    between: dict[str, Any] | None = None
    #: meets the effect-size rules (set by :func:`_judge`)
    size_ok: bool = False
    #: the acceptance decision and the row's decision word (set by :func:`_judge`)
    decision: Decision | None = None
    verdict: str | None = None
    #: judged on top of this other candidate (acceptance rule 6), else None
    given: str | None = None
    #: judged on the rows its signature lives in (these words say which), else None
    where: str | None = None
    #: the comparison on the other test rows when judged where it lives (rule 13)
    elsewhere: HeldOut | None = None

    @property
    def family(self) -> str:
        return EFFECTS[self.name].family

    @property
    def evidence_rows(self) -> HeldOut:
        """The comparison the significance rule uses (cross-fitted when available)."""
        return self.crossfit["pooled"] if self.crossfit is not None else self.heldout


@dataclass
class _Run:
    """What one diagnosis accumulates over its rounds (findings, ambiguities, rows)."""

    ctx: FitContext
    noise: float
    untestable: list[dict[str, str]]
    max_effects: int
    #: rate- / amplitude-dependent effects judged by predicting each recording from the others
    between: BetweenPlan
    say: _Progress
    #: rate-dependent hysteresis is among the effects tested (acceptance rule 5 applies)
    rate_testable: bool = False
    findings: list[EffectFinding] = field(default_factory=list)
    ambiguous: list[dict[str, Any]] = field(default_factory=list)
    rounds: list[RoundRow] = field(default_factory=list)
    #: training-block folds of acceptance rule 4 (built on first use)
    earn_folds: list | None = None
    #: training-block folds in every recording of acceptance rule 12 (built on first use)
    stage_folds: list | None = None
    #: memo of rule 5: the fit the split was computed for, and its verdict
    split_for: Fit | None = None
    split: bool = True

    @property
    def untestable_names(self) -> set[str]:
        return {u["name"] for u in self.untestable}

    def step(self, rnd: int, frac: float, msg: str) -> None:
        """Progress inside round ``rnd`` (``frac`` of the round done)."""
        self.say(0.1 + 0.8 / max(self.max_effects, 1) * (rnd + frac), f"round {rnd + 1}: {msg}")


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
    return ctx, desc


def _baseline(ctx: FitContext, n_operators: int, auto_resolution: bool) -> tuple[Fit, Fit]:
    """Baseline PI fit and the fit at the requested resolution.

    Saturating loops (friction) need play weights of either sign: switch when the
    sign-constrained PI is clearly worse on the held-out rows (MSE at least halved). Then the
    under-resolution check (notes E13): double the grid while the held-out MSE drops by
    >= 2 % (model selection of a nuisance, not a physics claim: no significance needed),
    keeping at least two training rows per weight.
    Periodic steady-state recordings start from the memory their own cycle leaves.
    """
    records, trm = ctx.records, ctx.train
    r = baseline_thresholds(records, trm, n_operators)
    hist0 = tuple(steady_state_history(rec) for rec in records)
    s0 = Structure(tuple(float(x) for x in r), hist0)
    f_nn, f_free = ctx.fit(s0), ctx.fit(s0.with_(free_weights=True))
    free = compare_heldout(ctx, f_nn, f_free).gain >= FREE_SIGN_GAIN
    base: Fit | None = None
    requested: Fit | None = None
    for n_try in (n_operators, 2 * n_operators, 4 * n_operators):
        if base is not None and 2 * (n_try + 2) > ctx.n_train:
            break  # at least two training rows per weight (a short single loop)
        r = baseline_thresholds(records, trm, n_try)
        s_try = Structure(tuple(float(x) for x in r), hist0, free_weights=free)
        f_try = (f_free if free else f_nn) if n_try == n_operators else ctx.fit(s_try)
        if base is None:
            requested = f_try
        elif compare_heldout(ctx, base, f_try).gain < 0.02:
            break
        base = f_try
        if not auto_resolution:
            break
    assert base is not None and requested is not None
    return base, requested


#: A Preisach base replaces the PI one when it lowers the MSE of predicting each recording
#: from the others by at least PREISACH_MIN_GAIN (a choice of the base, like the resolution:
#: no significance needed, but a margin) and lowers it by PREISACH_OVER_MAP against the PI
#: with a static output map or a loop shape (which the effect search names). Measured (each
#: recording predicted from the others): gains against the PI of the benchmark's Preisach
#: plants 0.88-0.98, Duhem 0.25-0.55, Bouc-Wen and B-PI <= 0.10; B-PI + asymmetry 0.89
#: against the PI, but ~0 against PI + asymmetry. The margins live in core.fitting.choice,
#: so that `hyst fit --model auto` chooses its base by the same numbers.
#: (level segments, smoothness) of the Preisach bases tried (uniform level knots over the
#: training input range; on the benchmark's Bouc-Wen, Preisach and Duhem nulls the
#: cross-fitted gains vary by < 0.1 over smoothness 0.01-0.1, 3-5 segments)
PREISACH_GRID: tuple[tuple[int, float], ...] = ((3, 0.1), (5, 0.01))


def _base_folds(ctx: FitContext) -> list[tuple[list[np.ndarray], list[np.ndarray]]]:
    """Folds of the base choice, which must predict away from the rows it was fitted on:
    each recording from the others. With one recording there are none and the PI stays:
    blocks of one recording let a base with many level cells interpolate (on the real piezo,
    interleaved blocks and halves both favoured a Preisach base, gain 0.5-0.6, whose final
    model was worse on the later test window: 0.168 % against 0.149 %)."""
    recs, tr = ctx.records, ctx.train
    if len(recs) < 2:
        return []
    none = [np.zeros(r.n_samples, dtype=bool) for r in recs]
    return [([none[k] if k == j else m for k, m in enumerate(tr)],
             [m if k == j else none[k] for k, m in enumerate(tr)])
            for j in range(len(recs)) if tr[j].any()]


def _choose_base(ctx: FitContext, base: Fit, n_operators: int) -> tuple[Fit, BaseChoice]:
    """Cross-validate a Preisach base (level-dependent memory, E10) against the PI base by
    predicting each recording from the others (:func:`_base_folds`; the test rows are not
    used), so that concealed effects are judged against a base that is not itself the
    largest error. The Preisach replaces the PI when it lowers that MSE by
    :data:`PREISACH_MIN_GAIN` and also beats, by :data:`PREISACH_OVER_MAP`, the PI with a
    static output map or a loop shape (asymmetry, saturation, dead-zone: notes §4.2, "does
    a static map reconcile all minor loops? If not, the memory itself is level-dependent"),
    which the effect search names instead."""
    folds = _base_folds(ctx)
    s0 = base.structure
    if not folds or loop_shape(s0.shape) or s0.beta_s is not None:
        return base, BaseChoice(s0.base_kind, (), len(folds))
    sub = FitContext(ctx.records, ctx.train, ctx.test, folds=folds, parent=ctx)
    sub.strict = True
    w = [r.u[m] for r, m in zip(ctx.records, ctx.train, strict=True) if m.any()]
    lo, hi = min(float(x.min()) for x in w), max(float(x.max()) for x in w)
    n_p = max(4, min(25, n_operators))
    r = baseline_thresholds(ctx.records, ctx.train, n_p)
    best, h_best, tried = base, None, []
    for m, smooth in PREISACH_GRID:
        if 2 * ((n_p + 1) * m + 2) > ctx.n_train:
            continue  # at least two training rows per weight
        knots = tuple(float(x) for x in lo + (hi - lo) * np.arange(1, m) / m)
        sp = Structure(tuple(float(x) for x in r), s0.history, levels=knots,
                       level_smooth=smooth)
        fp = ctx.fit(sp)
        h = compare_heldout(sub, base, fp)
        tried.append({"base": "preisach", "operators": n_p, "level_segments": m,
                      "smoothness": smooth, "cv_mse_reduction": float(h.gain)})
        if h.gain >= PREISACH_MIN_GAIN and (h_best is None or h.gain > h_best.gain):
            best, h_best = fp, h
    if h_best is None:
        return base, BaseChoice(s0.base_kind, tuple(tried), len(folds))
    # Kuhnen's modified PI (a PI followed by one-sided output dead-zones: a static output
    # map), fitted by its own estimator on the same folds
    mse_mpi = fold_mse("mpi", ctx.records, folds, s0.free_weights)
    if np.isfinite(mse_mpi):
        over = 1.0 - h_best.mse_after / max(mse_mpi, 1e-300)
        tried.append({"base": "mpi (static output map)", "operators": 0, "level_segments": 1,
                      "smoothness": 0.0,
                      "cv_mse_reduction": float(1.0 - mse_mpi / max(h_best.mse_before,
                                                                    1e-300)),
                      "preisach_mse_reduction_over_it": float(over)})
        if over < PREISACH_OVER_MAP:
            return base, BaseChoice(s0.base_kind, tuple(tried), len(folds))
    best_dyn: Fit | None = None
    for name in (n for n, e in EFFECTS.items() if e.family == "static"):
        got = build_candidate(ctx, name, base)
        if got is None:
            continue
        alt = got[0]
        over = compare_heldout(sub, alt, best).gain
        tried.append({"base": f"pi + {name}", "operators": len(s0.thresholds),
                      "level_segments": 1, "smoothness": 0.0,
                      "cv_mse_reduction": float(compare_heldout(sub, base, alt).gain),
                      "preisach_mse_reduction_over_it": float(over)})
        if over >= PREISACH_OVER_MAP:
            continue
        # the loop shape may only look as good as the Preisach because an output dynamics
        # stage (a resonance of the fast recordings) dominates both misfits: compare the two
        # again, each with the output dynamics that predicts its folds best
        best_dyn = best_dyn or _with_output_dynamics(ctx, sub, best)
        over_dyn = compare_heldout(sub, _with_output_dynamics(ctx, sub, alt), best_dyn).gain
        tried[-1]["preisach_mse_reduction_over_it_with_dynamics"] = float(over_dyn)
        if over_dyn < PREISACH_OVER_MAP:
            return base, BaseChoice(s0.base_kind, tuple(tried), len(folds))
    return best, BaseChoice(best.structure.base_kind, tuple(tried), len(folds))


def _with_output_dynamics(ctx: FitContext, sub: FitContext, fit: Fit) -> Fit:
    """``fit`` with the output dynamics stage (delay, lag, resonance) that lowers the MSE of
    predicting each training fold of ``sub`` most, or ``fit`` itself when none lowers it.
    Used only to compare two bases on an equal footing; the effect search still has to find
    and prove the stage."""
    out, gain = fit, 0.0
    for name in output_dynamics():
        got = build_candidate(ctx, name, fit)
        if got is None:
            continue
        g = compare_heldout(sub, fit, got[0]).gain
        if g > gain:
            out, gain = got[0], g
    return out


#: Rate-dependent hysteresis on a stop-operator base (not modelled: its elements sit behind
#: the gap's input map, which has no rate-dependent form), reported as untestable.
_RATE_ON_STOP = {
    "name": "rate",
    "reason": ("the loops run clockwise and the base is stop operators behind a backlash gap, "
               "for which rate-dependent thresholds are not modelled"),
    "experiment": ("a run with --base pi (the PI with weights of either sign, on which "
                   "rate-dependent thresholds are modelled) on recordings at >= 2 rates a "
                   "decade apart"),
}

def _stop_base(ctx: FitContext, base: Fit) -> tuple[Fit, dict[str, Any]] | None:
    """The stop-operator base of clockwise loops (:mod:`core.diagnosis.bases`), or ``None``
    on counter-clockwise ones: the loops' orientation and the backlash gap are the fit
    side's (:func:`core.fitting.orientation.loop_orientation` on the training rows,
    :class:`~core.fitting.stop.StopPIRegressor` ``gap="auto"``, as ``hyst fit --model auto``
    chooses the ``stop-pi`` kind), the bank as many stop operators as the PI baseline has
    plays, on the input behind that gap, weights ``k >= eps``, ``w_i >= 0`` solved on the
    training rows. Tried only where the PI baseline itself needed weights of either sign
    (:func:`_baseline`: a saturating loop) and the training rows' loops run clockwise (the
    shipped B-H loops: their interleaved training blocks alone have a clockwise signed area,
    but their PI keeps non-negative weights). It replaces the PI baseline unless the PI with
    weights of either sign lowers its held-out MSE by :data:`FREE_SIGN_GAIN` (the fit's rule
    for free signs over the sign rule of the loops' orientation; the PI stays on a dead band
    at a fixed travel after every reversal)."""
    recs = ctx.records
    s0 = base.structure
    if not s0.free_weights or not loop_orientation(
            [r.u for r in recs], [r.y for r in recs], ctx.train).clockwise:
        return None
    if loop_shape(s0.shape) or s0.beta_s is not None or s0.levels or s0.bouc_wen:
        return None
    model = fit_stop_gap(recs, ctx.train, ctx.test, len(s0.thresholds))
    if model is None:
        return None
    shape = (stop_stage(model),)
    r = shape_thresholds(shape, recs, ctx.train, len(s0.thresholds))
    fs = ctx.fit(Structure(tuple(float(x) for x in r), s0.history, shape=shape))
    h = compare_heldout(ctx, fs, base)
    chosen = h.gain < FREE_SIGN_GAIN
    m0 = fs.models[0]
    hyst = m0.stages[0] if isinstance(m0, Chain) else m0
    assert isinstance(hyst, StopPIModel)
    info = {"gap": float(model.gap), "elements": len(r),
            "friction_plateau": float(branch_features(hyst).plateau),
            "heldout_mse_reduction": float(1.0 - h.mse_before / max(h.mse_after, 1e-300)),
            "chosen": bool(chosen)}
    return (fs if chosen else base), info


def _choose_base_family(ctx: FitContext, base: Fit, n_operators: int
                        ) -> tuple[Fit, BaseChoice]:
    """The stop-operator base on clockwise loops (:func:`_stop_base`), then
    :func:`_choose_base` against it, then a Bouc-Wen base cross-validated on the same folds
    (each recording predicted from the others, training rows only): it replaces the chosen
    base when it lowers the MSE there by :data:`BW_MIN_GAIN` against the PI (or stop) base
    and beats the chosen base."""
    got = _stop_base(ctx, base)
    ref, stop = (got[0], got[1]) if got is not None else (base, None)
    best, choice = _choose_base(ctx, ref, n_operators)
    choice = replace(choice, stop=stop)
    folds = _base_folds(ctx)
    s0 = base.structure
    if not folds or s0.shape or s0.beta_s is not None:
        return best, choice
    sub = FitContext(ctx.records, ctx.train, ctx.test, folds=folds, parent=ctx)
    sub.strict = True
    span = max(float(np.ptp(r.u[m])) for r, m in zip(ctx.records, ctx.train, strict=True)
               if m.any())
    el = bouc_wen_elements(span)
    if span <= 0 or 2 * (len(el) + 3) > ctx.n_train:
        return best, choice
    sb = Structure(saturations(el), s0.history, free_weights=s0.free_weights, bouc_wen=el)
    fb = ctx.fit(sb)
    h = compare_heldout(sub, ref, fb)
    chosen_gain = max((t["cv_mse_reduction"] for t in choice.tried if t["base"] == "preisach"),
                      default=0.0) if choice.kind == "preisach" else 0.0
    tried = (*choice.tried, {"base": "bouc-wen", "operators": len(el), "level_segments": 1,
                             "smoothness": 0.0, "cv_mse_reduction": float(h.gain)})
    if h.gain >= BW_MIN_GAIN and h.gain > chosen_gain:
        return fb, BaseChoice("bouc-wen", tried, choice.folds or len(folds), stop)
    return best, BaseChoice(choice.kind, tried, choice.folds or len(folds), stop)


def _noise_rms(ctx: FitContext, base: Fit) -> float:
    """White-noise floor of the baseline residual (training rows with strict hold-out)."""
    return float(np.sqrt(np.mean([noise_floor(e[m]) ** 2 for e, m in zip(
        ctx.all_res(base), ctx.train if ctx.strict else ctx.test, strict=True)])))


def _search(run: _Run, cur: Fit, todo: list[str], rnd: int
            ) -> tuple[dict[str, _Candidate], list[RoundRow]]:
    """Fit every effect of ``todo`` on top of ``cur`` and collect its evidence.

    With strict hold-out the highest-priority families go first; once one passes, a later
    family can only be chosen with 1.5 times its gain (:func:`_choose`), so hopeless
    candidates are deferred to the next round without their (costly) cross-fitting.
    Returns the candidates and the rows of the deferred ones.
    """
    ctx = run.ctx
    order = sorted(todo, key=lambda n: FAMILY_PRIORITY[EFFECTS[n].family]) if (
        ctx.strict) else todo
    lead: tuple[str, float] | None = None
    cands: dict[str, _Candidate] = {}
    deferred: list[RoundRow] = []
    for i, name in enumerate(order):
        bound = _lead_bound(lead, name)
        if bound > 1.0:
            deferred.append(_deferred_row(rnd, name))
            continue
        frac = 0.5 * i / max(len(todo), 1)
        run.step(rnd, frac, f"fitting {name}")
        got = build_candidate(ctx, name, cur)
        if got is None:
            continue
        c = _Candidate(name, *got, heldout=screen_gain(got[0], cur))
        if ctx.strict and not EFFECTS[name].before_wipeout and c.heldout.gain < bound:
            deferred.append(_deferred_row(rnd, name, c.parameters,
                                          None if bound > 0 else c.heldout.gain))
            continue
        judged = _evidence(run, cur, c, rnd, frac + 0.25 / max(len(todo), 1))
        if judged is None:
            continue
        c = judged
        cands[name] = c
        cv = (c.crossfit or {}).get("parameter_cv")
        if ctx.strict and decide(c.heldout, c.heldout.mse_before - run.noise**2, len(todo),
                                 cv).passes:
            lead = _new_lead(lead, name, c.heldout.gain)
    return cands, deferred


def _evidence(run: _Run, cur: Fit, c: _Candidate, rnd: int, frac: float) -> _Candidate | None:
    """The held-out evidence of candidate ``c`` (``None``: not applicable on some subset).

    * strict hold-out: the training-RSS screen, then cross-fitting when it can pass;
    * ``initial-memory``: the rows before the wipe-out time (the only rows an initial state
      changes; with strict hold-out the training ones, in-sample, 1-2 parameters), and it
      must not make the held-out (cross-fitted) rows worse;
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
                return replace(c, heldout=cf["pooled"], crossfit=cf)
        return c
    if EFFECTS[name].before_wipeout:
        mm = ([a & b for a, b in zip(ctx.memory_masks, ctx.train, strict=True)] if ctx.strict
              else ctx.memory_masks)
        h = heldout_comparison(ctx.test_res(cur, mm), ctx.test_res(c.fit, mm))
        worse = (compare_heldout(ctx, cur, c.fit).gain if ctx.strict
                 else heldout_comparison(ctx.test_res(cur), ctx.test_res(c.fit)).gain)
        if worse < -0.01:
            h = HeldOut(h.mse_before, h.mse_after, h.gain if ctx.strict else min(h.gain, worse),
                        min(h.z, 0.0), 1.0, h.n_batches)
        return replace(c, heldout=h)
    spec = EFFECTS[name]
    if (run.between.rate and spec.between_recordings) or (
            run.between.amplitude and spec.amplitude_dependent):
        run.step(rnd, frac, f"predicting each recording from the others ({name})")
        bt = between_recordings(ctx, name, cur)
        return None if bt is None else replace(c, heldout=bt["pooled"], between=bt)
    local = _on_its_signature(ctx, cur, c)
    if local is not None:
        return local
    h = heldout_comparison(ctx.test_res(cur), ctx.test_res(c.fit))
    if spec.dynamics is not None:
        h = _where_it_lives(ctx, cur, c.fit, h)
    return replace(c, heldout=h)


#: Fewest test rows among the rows an effect's signature lives in for judging it there.
MIN_SIGNATURE_ROWS = 200


def _on_its_signature(ctx: FitContext, cur: Fit, c: _Candidate) -> _Candidate | None:
    """Candidate ``c`` judged on the test rows its signature lives in (the effect's
    :attr:`~core.diagnosis.registry.DiagnosableEffect.signature`), with the comparison on
    the other test rows kept for acceptance rule 13; ``None`` when the effect declares no
    such rows or too few of them are test rows (:data:`MIN_SIGNATURE_ROWS`)."""
    spec = EFFECTS[c.name]
    sig = spec.signature(ctx) if spec.signature is not None else None
    if sig is None:
        return None
    masks, words, centred = sig
    where = [m & t for m, t in zip(masks, ctx.test, strict=True)]
    if sum(int(w.sum()) for w in where) < MIN_SIGNATURE_ROWS:
        return None
    rest = [~m & t for m, t in zip(masks, ctx.test, strict=True)]

    def on_signature(f: Fit) -> list[np.ndarray]:
        res = ctx.test_res(f, where)
        return [e - e.mean() if centred and e.size else e for e in res]

    h = heldout_comparison(on_signature(cur), on_signature(c.fit))
    other = (heldout_comparison(ctx.test_res(cur, rest), ctx.test_res(c.fit, rest))
             if sum(int(r.sum()) for r in rest) >= MIN_SIGNATURE_ROWS else None)
    return replace(c, heldout=h, where=f"test rows {words}", elsewhere=other)


#: Share of the test rows, those where a delay / lag / resonance changes the prediction most,
#: on which its significance is also tested (:func:`_where_it_lives`).
WHERE_SHARE = 0.2
#: ... only when the Diebold-Mariano z on all the test rows is at least this.
WHERE_MIN_Z = 2.0


def _where_it_lives(ctx: FitContext, cur: Fit, new: Fit, h: HeldOut) -> HeldOut:
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
    if pooled.size < 50 or not np.any(pooled > 0):
        return h
    cut = float(np.quantile(pooled, 1.0 - WHERE_SHARE))
    where = [m & (np.abs(a - b) >= cut) for a, b, m in zip(new.pred, cur.pred, ctx.test,
                                                           strict=True)]
    hw = heldout_comparison(ctx.test_res(cur, where), ctx.test_res(new, where))
    if not (np.isfinite(hw.z) and np.isfinite(hw.sign_p)):
        return h
    return HeldOut(h.mse_before, h.mse_after, h.gain, max(h.z, hw.z),
                   min(1.0, 2.0 * min(h.sign_p, hw.sign_p)), h.n_batches)


def _judge(run: _Run, cur: Fit, cands: dict[str, _Candidate], rows: list[RoundRow], rnd: int,
           accepted: tuple[str, ...], n_tests: int | None = None
           ) -> tuple[dict[str, _Candidate], list[RoundRow], list[str]]:
    """Apply the acceptance rules (:func:`~core.diagnosis.acceptance.decide`) to every
    candidate of the round on top of ``cur`` (which holds the ``accepted`` effects);
    ``n_tests``: the Bonferroni divisor (default: the number of candidates). Returns the
    candidates (with any cross-fitting and their decisions added), the round's rows and the
    names that pass."""
    ctx = run.ctx
    n_tests = len(cands) if n_tests is None else n_tests
    mse_cur = pooled_mse(ctx.test_res(cur))
    excess = {n: (c.heldout.mse_before if ctx.strict or c.between or c.where else mse_cur)
              - run.noise**2 for n, c in cands.items()}
    cands = {n: replace(c, size_ok=effect_size_ok(c.heldout, excess[n]))
             for n, c in cands.items()}
    size_ok = {n: c.size_ok for n, c in cands.items()}
    needs_cf = {n for n in cands if size_ok[n] and ctx.folds and not EFFECTS[n].before_wipeout
                and not ctx.strict}
    skip = _cannot_win({n: c.heldout for n, c in cands.items()}, size_ok, needs_cf, n_tests)
    rows = list(rows)
    passing: list[str] = []
    for name, c in list(cands.items()):
        if name in skip:
            rows.append(_row(ctx, rnd, c, passes=False, decision="deferred",
                             evidence="not needed: an effect of a higher-priority family "
                             "passed and explains at least 2/3 as much"))
            continue
        if name in needs_cf:
            run.step(rnd, 0.5, f"cross-fitting {name}")
            cf = crossfit_candidate(ctx, name, cur, c.fit)
            if cf is not None:
                c = cands[name] = replace(c, crossfit=cf)
        cv = (c.crossfit["parameter_cv"] if c.crossfit else
              c.between["parameter_cv"] if c.between else {})
        dec = decide(c.heldout, excess[name], n_tests, cv, significance=c.evidence_rows)
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
        elif (dec.passes and EFFECTS[name].transport and run.rate_testable
                and not _split_ok(run, cur)):
            dec = replace(dec, passes=False, reasons=(_SPLIT_REASON,))
            decision = "contradicted"
        elif dec.passes and EFFECTS[name].sign_locked and not _locking_ok(run, cur):
            dec = replace(dec, passes=False, reasons=(_LOCKING_REASON,))
            decision = "contradicted"
        elif dec.passes and accepted and _needs_earning(ctx, c):
            run.step(rnd, 0.6, f"cross-fitting {name} against the accepted effects")
            dec = _earns(run, cur, c, n_tests, accepted)
            decision = None if dec.passes else "not earned"
        cands[name] = replace(c, decision=dec, verdict=decision)
        rows.append(_row(ctx, rnd, c, passes=dec.passes, reasons=dec.reasons, decision=decision))
        if dec.passes:
            passing.append(name)
    return cands, rows, passing


#: Fewest test rows in an event window for its MSE reduction to count (acceptance rule 14).
MIN_EVENT_ROWS = 20


def _event_gains(ctx: FitContext, cur: Fit, new: Fit) -> list[float]:
    """Relative MSE reduction of ``new`` over ``cur`` in each event window (from one input
    step or reversal to the next) of the one recording, each window held out in turn: both
    structures are refitted on the training rows outside it (their nonlinear parameters
    kept) and scored on all its rows."""
    rec = ctx.records[0]
    out = []
    for a, b in event_windows(rec):
        if b - a < MIN_EVENT_ROWS:
            continue
        ev = np.zeros(rec.n_samples, dtype=bool)
        ev[a:b] = True
        sub = FitContext(ctx.records, [ctx.train[0] & ~ev], [ev], parent=ctx)
        e0 = (rec.y - sub.fit(cur.structure, cur).pred[0])[ev]
        e1 = (rec.y - sub.fit(new.structure, new).pred[0])[ev]
        before = float(np.mean(e0**2))
        out.append(1.0 - float(np.mean(e1**2)) / before if before > 0 else 0.0)
    return out


def _events_refusal(ctx: FitContext, cur: Fit, c: _Candidate) -> str | None:
    """Why acceptance rule 14 refuses candidate ``c`` (only output dynamics with one
    recording), or ``None`` when it holds."""
    if EFFECTS[c.name].dynamics is None or len(ctx.records) != 1:
        return None
    g = _event_gains(ctx, cur, c.fit)
    if enough_events(g):
        return None
    seen = sum(1 for x in g if x >= RULE.min_gain)
    return (f"seen after only {seen} of {len(g)} input events (steps, reversals) of the one "
            f"recording: a dynamic stage is named when at least {RULE.min_events} "
            "independent events show it (more steps or cycles would decide)")


def _loop_shape_refusal(ctx: FitContext, cur: Fit, c: _Candidate) -> str | None:
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


def _split_ok(run: _Run, cur: Fit) -> bool:
    """Acceptance rule 5 on the current model's residual (memoised per current fit)."""
    if run.split_for is not cur:
        d = lookalike_evidence(run.ctx, cur)
        run.split_for, run.split = cur, split_supports_transport(d["a_rev_s"], d["a_hys_s"])
    return run.split


_LOCKING_REASON = ("the residual trend after the holds does not follow the sign of the step "
                   "before them as creep would (a drift continues across steps)")


def _locking_ok(run: _Run, cur: Fit) -> bool:
    """Acceptance rule 7 on the current model's residual."""
    d = sign_locking(run.ctx, cur)
    return trend_follows_steps(d.get("trend_follows_step_sign"), d["steps_with_hold"])


def _needs_earning(ctx: FitContext, c: _Candidate) -> bool:
    """Acceptance rule 4 applies: a further effect judged on the test rows (not already on
    cross-fitted blocks alone, between recordings, or on the pre-wipe-out rows)."""
    return not ctx.strict and c.between is None and not EFFECTS[c.name].before_wipeout


def _earns(run: _Run, cur: Fit, c: _Candidate, n_tests: int, accepted: tuple[str, ...]
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


def _blocks_context(run: _Run) -> FitContext | None:
    """The cross-fitted training blocks of acceptance rule 4 (strict hold-out: the test
    rows chose the effects before a further one), or ``None`` with too few blocks."""
    ctx = run.ctx
    if run.earn_folds is None:
        run.earn_folds = (ctx.folds or crossfit_folds(ctx.records, ctx.train, max_blocks=5)
                          # a recording too short for 0.5 s blocks: four shorter ones
                          or crossfit_folds(ctx.records, ctx.train, min_block_s=1e-12,
                                            max_blocks=4))
    if not run.earn_folds:
        return None
    sub = FitContext(ctx.records, ctx.train, ctx.test, folds=run.earn_folds, parent=ctx)
    sub.strict = True
    return sub


def _lookahead(run: _Run, cur: Fit, cands: dict[str, _Candidate], rows: list[RoundRow],
               todo: list[str], rnd: int
               ) -> tuple[dict[str, _Candidate], list[RoundRow], list[str]]:
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
    none: tuple[dict[str, _Candidate], list[RoundRow], list[str]] = (cands, rows, [])
    held = [c for c in cands.values() if c.decision is not None and c.verdict is None
            and c.decision.size_ok and c.decision.stable and not c.decision.significant
            and not EFFECTS[c.name].before_wipeout]
    if ctx.strict or not held:
        return none
    t = max(held, key=lambda c: c.heldout.gain)
    run.step(rnd, 0.8, f"the others on top of {t.name}")
    sub, sub_rows = _search(run, t.fit, _remaining(todo, t.name), rnd)
    ok = _judge(run, t.fit, sub, sub_rows, rnd, (t.name,))[2] if sub else []
    p = _choose(ok, {n: sub[n].heldout.gain for n in ok}) if ok else None
    if p is None or p not in cands:
        return none
    base_p = cands[p].fit
    got = build_candidate(ctx, t.name, base_p)
    tt = None if got is None else _evidence(
        run, base_p, _Candidate(t.name, *got, heldout=screen_gain(got[0], base_p)), rnd, 0.9)
    if tt is None:
        return none
    # judged as a first effect would be (test rows, the round's Bonferroni divisor), on top of p
    tj, t_rows, t_ok = _judge(run, base_p, {t.name: tt}, [], rnd, (), n_tests=len(cands))
    if not t_ok:
        return none
    c = replace(t, heldout=tj[t.name].heldout, decision=tj[t.name].decision, given=p)
    row = replace(t_rows[0], evidence=f"{t_rows[0].evidence}, judged on top of {p} (the two "
                  f"hide each other; {p} passes on top of {t.name})")
    return {**cands, t.name: c}, [r for r in rows if r.effect != t.name] + [row], [t.name]


def _row(ctx: FitContext, rnd: int, c: _Candidate, passes: bool, decision: str | None = None,
         evidence: str | None = None, reasons: tuple[str, ...] | None = None) -> RoundRow:
    """The round row of candidate ``c`` (cross-fitting and between-recordings details)."""
    h, cf, bt = c.heldout, c.crossfit, c.between
    extra: dict[str, Any] = {}
    label = c.where or _evidence_label(ctx, c.name, cf, bt)
    if cf is not None:
        extra.update(fold_mse_reductions=cf["fold_gains"], parameter_cv=cf["parameter_cv"])
        if not ctx.strict:  # the test rows pooled with the cross-fitted blocks
            p = cf["pooled"]
            label = f"{c.where or 'test rows'} + {cf['folds']} cross-fitted blocks"
            extra.update(dm_z_pooled=p.z, signed_rank_p_pooled=p.sign_p,
                         mse_reduction_pooled=p.gain)
    if bt is not None:
        extra.update(per_recording=bt["per_recording"], parameter_cv=bt["parameter_cv"])
    return RoundRow(rnd + 1, c.name, h.gain, h.z, h.sign_p, bool(passes), decision,
                    c.parameters, evidence or label, reasons, tuple(extra.items()))


def _accept(run: _Run, cur: Fit, cands: dict[str, _Candidate], passing: list[str], best: str,
            rows: list[RoundRow], rnd: int, n_max: int) -> Fit:
    """Accept ``best``: record the round's decisions, the finding (where, discriminators,
    uncertainty, caveats), the look-alikes it is ambiguous with; refine the resolution and,
    for dynamics, re-compare the look-alikes at it. Returns the new current fit."""
    ctx = run.ctx
    c, c_spec = cands[best], EFFECTS[best]
    amb, runner = _lookalikes(ctx, c, cands, passing)
    run.rounds.extend(r if r.decision in _KEPT_DECISIONS else replace(r, decision=(
        "accepted" if r.effect == best else "ambiguous" if r.effect in amb else
        "passes" if r.passes else "rejected")) for r in rows)
    run.findings.append(_finding(run, cur, c, amb, runner))
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
        refine: list[dict[str, Any]] = []
        new = _refine_resolution(ctx, c.fit, n_max, refine, rnd + 1)
        run.rounds.extend(RoundRow.from_dict(d) for d in refine)
    fnd = run.findings[-1]
    if c_spec.dynamics is not None and not ctx.strict:
        new = _recheck_dynamics(run, new, fnd, rnd + 1)
    elif not ctx.strict:
        new = _recheck_earlier_dynamics(run, new, rnd)
    if fnd is run.findings[-1]:  # (a second stage named in series set both structures)
        fnd.structure = new.structure
    named = fnd.name  # the dynamics recheck may rename it
    for hidden, e in EFFECTS.items():
        if e.mimicked_by is None:
            continue
        names, why = e.mimicked_by
        if named in names and hidden in run.untestable_names:
            run.ambiguous.append({"effects": [named, hidden], "chosen": named,
                                  "reason": why.format(best=named),
                                  "experiment": EFFECTS[hidden].experiment})
    if (EFFECTS[named].dynamics is not None and new.structure.bouc_wen
            and run.rate_testable):
        # rate-dependent plays are not modelled on a Bouc-Wen base (on a Preisach base they
        # are: the rate candidate widens the levelled plays' thresholds): say so rather than
        # let the dynamics stand in for them unchallenged
        rate = rate_effect()
        run.findings[-1].ambiguous_with.append(rate)
        run.ambiguous.append({
            "effects": [named, rate], "chosen": named,
            "reason": "on a Bouc-Wen base rate-dependent hysteresis is not modelled, so "
            f"{named} was not compared with it",
            "experiment": DECIDING_EXPERIMENT.get(frozenset({named, rate}),
                                                  EFFECTS[rate].experiment)})
    return new


#: Decisions of the acceptance rules that :func:`_accept` keeps as they are.
_KEPT_DECISIONS = ("deferred", "contradicted", "not earned")


def _recheck_earlier_dynamics(run: _Run, new: Fit, rnd: int) -> Fit:
    """Look-alikes against the model that holds every accepted effect: once a slow or static
    effect joins, an earlier delay / lag / resonance finding is compared again with its
    look-alikes (on top of the new model), renamed if one now predicts the held-out rows
    better, and reported ambiguous with those it does not beat."""
    earlier = next((f for f in run.findings[:-1] if EFFECTS[f.name].dynamics is not None),
                   None)
    if earlier is None or len(dynamics_stages(new.structure.dynamics)) > 1:
        return new  # (two stages in series: each was judged against the other, rule 12)
    old, rmse_after = earlier.name, earlier.heldout_rmse_after
    new = _recheck_dynamics(run, new, earlier, rnd + 1)
    earlier.heldout_rmse_after = rmse_after  # its own step's score stays
    if earlier.name != old and earlier.structure is not None:
        earlier.structure = earlier.structure.with_(dynamics=new.structure.dynamics)
    return new


def _lookalikes(ctx: FitContext, c: _Candidate, cands: dict[str, _Candidate],
                passing: list[str]) -> tuple[list[str], dict[str, Any]]:
    """Same-family candidates the recordings do not separate from the chosen ``c``, and the
    runner-up.

    A runner-up is compared with the winner directly on held-out rows (strict hold-out: on
    the cross-fitted blocks; between recordings: on the left-out recordings). It is
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
            hh = heldout_comparison(o.crossfit["after"], c.crossfit["after"])
        elif o.between is not None and c.between is not None:
            hh = heldout_comparison(o.between["after"], c.between["after"])
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


def _finding(run: _Run, cur: Fit, c: _Candidate, amb: list[str], runner: dict[str, Any]
             ) -> EffectFinding:
    """The finding of accepted candidate ``c`` (SAY / MODEL / SHOW)."""
    ctx, records = run.ctx, run.ctx.records
    disc = (lookalike_evidence(ctx, cur) if c.family == "dynamics" else
            sign_locking(ctx, cur) if c.family == "slow" else {})
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
        evidence=_evidence_label(ctx, c.name, c.crossfit, c.between) + (
            f", judged on top of {c.given}" if c.given else ""),
        ambiguous_parameters=ambiguous_parameters(c.parameters, unc),
    )


def _remaining(todo: list[str], best: str) -> list[str]:
    """Effects still to test after ``best`` joined the model (one dynamics effect besides
    ``rate``: the structure holds one linear block after the hysteresis)."""
    fam = EFFECTS[best].family
    return [e for e in todo if e != best and not (
        EFFECTS[e].dynamics is not None and fam == "dynamics")]


def _loro_scores(ctx: FitContext, base: Fit, cur: Fit, findings: list[EffectFinding]
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


#: Relative resolution (log units) of the final polish of a dynamics stage's parameters.
POLISH_XATOL = 0.002


def _polish_dynamics(ctx: FitContext, cur: Fit, findings: list[EffectFinding]) -> Fit:
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


def _spread_over_recordings(ctx: FitContext, base: Fit, cur: Fit,
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


def _widen_for_base(ctx: FitContext, cur: Fit, findings: list[EffectFinding]) -> None:
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


def _drop_recording_specific(run: _Run, base: Fit, cur: Fit, loro_b: dict[str, Any],
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
        per_rec = st is not None and st.recording_levels() != prev.recording_levels()
        if lo is not None and st is not None and per_rec:
            # a per-recording level (offset, drift) cannot be known for an unseen recording:
            # judge what it does to the shared part, each left-out recording with its own level
            a = leave_one_recording_out(ctx, prev, st.own_level)
            b = leave_one_recording_out(ctx, st, st.own_level)
            lo = {"rule": a["rule"], "rmse_before": a["rmse"], "rmse_after": b["rmse"],
                  "mse_reduction": 1.0 - b["rmse"] ** 2 / max(a["rmse"] ** 2, 1e-300),
                  "per_recording": [{"recording": x["recording"], "rmse_before": x["rmse"],
                                     "rmse_after": y["rmse"]}
                                    for x, y in zip(a["per_recording"], b["per_recording"],
                                                    strict=True)]}
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
        worse = 1.0 - lo["mse_reduction"]
        per = " (one per recording: it differs between the recordings)" if per_rec else ""
        unscored = [r["recording"] for r in lo.get("per_recording", ()) if r.get("scored") is False]
        if unscored:
            per += (f" (scored without {', '.join(unscored)}: without it the others cannot "
                    f"test {f.name})")
        out.append(RecordingSpecific(
            f.name, dict(f.parameters), float(lo["mse_reduction"]), float(lo["rmse_before"]),
            float(lo["rmse_after"]), tuple(lo.get("per_recording", ())),
            f"{f.name}{per} improved the recordings it was fitted on, but predicting each "
            f"recording from the others with it is {worse:.3g} times worse in MSE "
            f"(leave-one-recording-out {-100 * lo['mse_reduction']:+.0f} %): it does not "
            "generalise, so it is specific to these recordings (or stands in for a misfit "
            "of the base model), not claimed as physics and not in the final model"))
    names = {f.name for f, _, _ in drop}
    run.findings[:] = [f for f in run.findings if f.name not in names]
    run.ambiguous[:] = [a for a in run.ambiguous if a.get("chosen") not in names]
    cur = ctx.fit(s, cur)
    lo = loro_b if s == base.structure else leave_one_recording_out(ctx, s)
    loro_f = dict(lo, mse_reduction=1.0 - lo["rmse"] ** 2 / max(loro_b["rmse"] ** 2, 1e-300))
    return cur, loro_f, out


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


def _crossval(ctx: FitContext, base: Fit, cur: Fit) -> dict[str, Any] | None:
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


def _refine_resolution(ctx: FitContext, fit: Fit, n_max: int, rounds: list, rnd: int) -> Fit:
    """Once an effect is in, the baseline may turn out under-resolved: double the play grid
    while the held-out fit improves (``resolution_gain`` and ``resolution_z`` of
    :class:`~core.diagnosis.acceptance.AcceptRule`)."""
    while not fit.structure.bouc_wen and len(fit.structure.thresholds) * 2 <= n_max:
        n2 = 2 * len(fit.structure.thresholds)
        r = shape_thresholds(fit.structure.shape, ctx.records, ctx.train, n2)  # w units
        f2 = ctx.fit(fit.structure.with_(thresholds=tuple(float(x) for x in r)), fit)
        h = compare_heldout(ctx, fit, f2)
        ok = h.gain >= RULE.resolution_gain and (h.z >= RULE.resolution_z
                                                  or h.sign_p < RULE.sign_p)
        rounds.append({"round": rnd, "effect": f"resolution:{n2}", "heldout_mse_reduction": h.gain,
                       "dm_z": h.z, "signed_rank_p": h.sign_p, "passes": bool(ok),
                       "decision": "accepted" if ok else "rejected", "parameters": {}})
        if not ok:
            break
        fit = f2
    return fit


def _recheck_dynamics(run: _Run, cur: Fit, finding: EffectFinding, rnd: int) -> Fit:  # noqa: C901 - look-alike rules 9-12 read together; split with the engine (issue 34)
    """Re-compare delay / lag / resonance at the refined resolution and keep the best; a
    pair of stages in series that beats it (rule 11) is named when each of its stages earns
    its place over the other alone (rule 12, :func:`_name_pair`; only for the stage just
    accepted: ``finding`` is the last finding)."""
    ctx, ambiguous, rounds = run.ctx, run.ambiguous, run.rounds
    base = ctx.fit(cur.structure.with_(dynamics=()), cur)
    te0 = ctx.test_res(base)
    results = {finding.name: (cur, finding.parameters, finding.uncertainty,
                              heldout_comparison(te0, ctx.test_res(cur)))}
    for alt in output_dynamics():
        if alt in results:
            continue
        got = build_candidate(ctx, alt, base)
        if got is not None:
            results[alt] = (got[0], got[1], got[2], heldout_comparison(te0, ctx.test_res(got[0])))

    def undecided_against(b: str) -> dict[str, HeldOut]:
        """Comparison of every other stage with ``b`` on the held-out rows."""
        return {o: heldout_comparison(ctx.test_res(results[o][0]), ctx.test_res(results[b][0]))
                for o in results if o != b}

    def undecided(hh: HeldOut) -> bool:
        return hh.z < RULE.min_z and hh.sign_p >= RULE.sign_p

    best = min(results, key=lambda n: results[n][3].mse_after)
    unnamed = None
    vs = undecided_against(best)
    # a stage whose fitted values lack its own signature (a mode too damped to ring) is not
    # named when a look-alike that shows its own is not significantly worse
    lacks = _lacks_signature(best, results[best][1])
    if lacks:
        # rule 9: a look-alike that shows its own signature is named when it predicts no
        # significantly worse or leaves at most a small margin more held-out MSE
        alts = [o for o, hh in vs.items()
               if (undecided(hh) or yields_to_lookalike(results[best][3].mse_after,
                                                         results[o][3].mse_after))
               and not _lacks_signature(o, results[o][1])]
        if alts:
            unnamed = best
            best = min(alts, key=lambda n: results[n][3].mse_after)
            vs = undecided_against(best)
    fit, params, unc, h = results[best]
    exc = excitation(ctx.records)
    # rule 15: without steps or several rates the look-alikes' signatures cannot show
    unseparated = not signatures_separable(exc.steps, exc.rate_ratio)
    amb = []
    for other, hh in vs.items():
        oh = results[other][3]
        # rule 10: a look-alike not clearly beaten on the same structure stays open
        open_ = not clearly_better(hh) or other == unnamed or unseparated
        rounds.append(RoundRow(rnd, f"recheck:{other}", oh.gain, hh.z, hh.sign_p, False,
                               "ambiguous" if open_ else "rejected", results[other][1]))
        if open_:
            amb.append(other)
    # rule 11: two stages in series that beat the named one keep their members open
    in_pair: dict[str, str] = {}
    beating: list[tuple[str, str, tuple, HeldOut]] = []
    for a, b in stage_pairs():
        if a not in results or b not in results:
            continue
        got = build_pair(ctx, base, (a, results[a][1]), (b, results[b][1]))
        if got is None:
            continue
        # tested also where the pair changes the prediction most, as a single stage is
        hp = _where_it_lives(ctx, fit, got[0], heldout_comparison(ctx.test_res(fit),
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
                if n not in amb:
                    amb.append(n)
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
    finding.heldout_rmse_after = float(np.sqrt(pooled_mse(ctx.test_res(fit))))
    ambiguous[:] = [a for a in ambiguous if not set(a["effects"]) <= set(output_dynamics())]
    for other in amb:
        ho = vs.get(other)
        at = " at the final resolution"
        if other == unnamed and results[other][3].mse_after < h.mse_after:
            why = (f"{other} leaves {100 * (1 - results[other][3].mse_after / h.mse_after):.1f}"
                   f" % less held-out MSE than {best}")
        elif other == unnamed or ho is None or undecided(ho):
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
        ambiguous.append({
            "effects": [best, other],
            "chosen": best,
            "reason": why + at + (
                f"; {other} is not named: {lacks}" if lacks and other == unnamed else ""),
            "experiment": DECIDING_EXPERIMENT.get(frozenset({best, other}),
                                                  "recordings at more frequencies"),
        })
    for a, b, got, hp in beating if finding is run.findings[-1] else ():
        named = _name_pair(run, base, finding, {n: results[n] for n in (a, b)}, got, hp, rnd)
        if named is not None:
            return named
    return fit


#: Contiguous training blocks per recording held out in turn when a second output stage is
#: judged on training rows (acceptance rule 12): the blocks of rule 4 are placed by duration
#: and miss a short recording (the fast sines) where output dynamics live.
STAGE_BLOCKS_PER_RECORDING = 2


def _stage_folds(run: _Run) -> list[tuple[list[np.ndarray], list[np.ndarray]]]:
    """Folds holding out each of :data:`STAGE_BLOCKS_PER_RECORDING` contiguous training
    blocks of every recording in turn (the other rows stay in training; memoised)."""
    if run.stage_folds is None:
        ctx = run.ctx
        none = [np.zeros_like(m) for m in ctx.train]
        run.stage_folds = []
        for j in range(len(ctx.train)):
            only = [m if k == j else none[k] for k, m in enumerate(ctx.train)]
            for _, blk in crossfit_folds(ctx.records, only, min_block_s=1e-12,
                                         max_blocks=STAGE_BLOCKS_PER_RECORDING):
                run.stage_folds.append(([t & ~b for t, b in zip(ctx.train, blk, strict=True)],
                                        blk))
    return run.stage_folds


def _blocks_where_it_lives(ctx: FitContext, folds: list, cur: Fit, new: Fit) -> HeldOut:
    """``cur`` against ``new`` on cross-fitted training blocks (linear weights refitted
    without each block, nonlinear parameters kept, as
    :func:`~core.diagnosis.crossfitting.compare_heldout`), the significance also tested
    where the two predictions differ most, as on the test rows (:func:`_where_it_lives`)."""
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
    if not (np.isfinite(h.z) and h.z >= WHERE_MIN_Z) or pooled.size < 50 or not np.any(
            pooled > 0):
        return h
    cut = float(np.quantile(pooled, 1.0 - WHERE_SHARE))
    keep = [d >= cut for d in diff]
    hw = heldout_comparison([e[k] for e, k in zip(eb, keep, strict=True)],
                            [e[k] for e, k in zip(ea, keep, strict=True)])
    if not (np.isfinite(hw.z) and np.isfinite(hw.sign_p)):
        return h
    return HeldOut(h.mse_before, h.mse_after, h.gain, max(h.z, hw.z),
                   min(1.0, 2.0 * min(h.sign_p, hw.sign_p)), h.n_batches)


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
    x, fx = nelder_mead(obj, x0, 0.2, PAIR_MAXFEV)
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
        keys = EFFECTS[n].dynamics.params  # type: ignore[union-attr]
        sig[n] = {}
        for k, v in zip(keys, vals, strict=True):
            e = np.eye(x0.size)[j] * h
            c = (rss(x0 + e) - 2 * f0 + rss(x0 - e)) / h**2
            sig[n][k] = sigma_from_curvature(ctx, fit, c, float(v))
            j += 1
    return sig


def _name_pair(run: _Run, base: Fit, finding: EffectFinding, alone: dict[str, tuple],
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
    params = {n: dict(zip(EFFECTS[n].dynamics.params, v, strict=True))  # type: ignore[union-attr]
              for n, v in stages}
    why: dict[str, str] = {}
    for n, v in stages:
        other = next(o for o, _ in stages if o != n)
        lacks = EFFECTS[n].dynamics.lacks_signature_in_series  # type: ignore[union-attr]
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
        h = _where_it_lives(ctx, fits[other], pair_fit, h)
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
    c2 = _Candidate(second, pair_fit, params[second], sig[second], heldout=h2)
    f2 = _finding(run, alone_fit, c2, [], {})
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


def _outside(records, e0, e1, used) -> list[dict[str, Any]]:
    """RMS before/after on the rows outside train and test (an independent check)."""
    out = []
    for r, a, b, m in zip(records, e0, e1, used, strict=True):
        o = ~m
        if o.sum() >= 10:
            out.append({"recording": r.name, "samples": int(o.sum()),
                        "rms_before": float(np.sqrt(np.mean(a[o] ** 2))),
                        "rms_after": float(np.sqrt(np.mean(b[o] ** 2)))})
    return out


def _choose(passing: list[str], gains: dict[str, float]) -> str:
    """Highest-priority family with a passing effect (best gain inside the family), unless a
    later family explains at least 1.5 times as much held-out MSE."""
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
    """Candidates whose cross-fitting can be skipped: :func:`_choose` could not pick them.

    When an effect that needs no cross-fitting already passes in the highest-priority family
    that has passing effects, a later family can only be picked with at least 1.5 times that
    family's best gain (:func:`_choose`); families below that bound are left undecided
    ("deferred") in this round and are tested again in the next one.
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


