"""What one diagnosis carries from step to step (:func:`core.diagnosis.engine.diagnose`).

:class:`Run` accumulates the findings, ambiguities and round rows and memoises the folds and
the rule-5 verdict; :class:`Candidate` is one effect fitted on top of the current model with
its evidence; :func:`round_row` and :func:`deferred_row` are the typed rows a round reports.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from .acceptance import RULE, Decision, floor_mse
from .between import BetweenPlan, BetweenRecordings
from .context import FitContext
from .crossfitting import CrossFit
from .registry import EFFECTS
from .results import EffectFinding, RecordingSpecific, RoundRow
from .specs import Untestable
from .stats import HeldOut
from .structure import Fit

__all__ = ["Candidate", "Progress", "Run", "deferred_row", "evidence_label", "excess_of",
           "round_row"]


class Progress:
    """``progress(fraction, message)`` with the fraction clipped to [0, 1] (or nothing)."""

    def __init__(self, progress: Callable[[float, str], None] | None) -> None:
        self.progress = progress

    def __call__(self, frac: float, msg: str) -> None:
        if self.progress is not None:
            self.progress(float(min(max(frac, 0.0), 1.0)), msg)


@dataclass(frozen=True)
class Candidate:
    """One effect fitted on top of the current model, with its evidence.

    ``heldout`` holds the effect-size statistics (test rows; with strict hold-out, or between
    recordings, the pooled evidence rows), ``crossfit`` the output of
    :func:`~core.diagnosis.crossfitting.crossfit_candidate` and ``between`` that of
    :func:`~core.diagnosis.between.between_recordings` when used.
    """

    name: str
    fit: Fit
    parameters: dict[str, Any]
    uncertainty: dict[str, Any]
    heldout: HeldOut
    crossfit: CrossFit | None = None
    between: BetweenRecordings | None = None
    #: meets the effect-size rules (set by :func:`~core.diagnosis.judge.judge_round`)
    size_ok: bool = False
    #: meets them only because acceptance rule 19 waived the excess share (set there too)
    share_waived: bool = False
    #: the acceptance decision and the row's decision word (set by
    #: :func:`~core.diagnosis.judge.judge_round`)
    decision: Decision | None = None
    verdict: str | None = None
    #: judged on top of this other candidate (acceptance rule 6), else None
    given: str | None = None
    #: judged on the rows its signature lives in (these words say which), else None
    where: str | None = None
    #: the comparison on the other test rows when judged where it lives (rule 13)
    elsewhere: HeldOut | None = None
    #: the comparison on all the test rows when judged where it lives, which the choice
    #: between families reads (:attr:`choice_gain`)
    overall: HeldOut | None = None
    #: judged where it lives: the white-noise variance of a compared value in units of one
    #: row's (:attr:`~core.diagnosis.registry.SignatureRows.noise_factor`: 2 on rows compared
    #: as changes from an earlier row), what the noise floor there is counted in
    #: (:func:`~core.diagnosis.acceptance.floor_mse`)
    noise_factor: float = 1.0
    #: judged where it lives on rows compared within the same input history
    #: (:attr:`~core.diagnosis.registry.SignatureRows.beyond_history`): acceptance rule 17
    #: is met by that evidence
    beyond_history: bool = False

    def judged_as(self, judged: Candidate, given: str) -> Candidate:
        """This candidate with the judgement of ``judged``, the same effect fitted and
        judged on top of ``given`` (acceptance rule 6): the comparison's numbers, the rows it
        was judged on and what was decided come from ``judged``, so the finding's evidence
        describes the comparison that decided. What belongs to this candidate's own fit stays
        its own: the fit, parameters and uncertainty, and the cross-fitted folds and the
        predictions between recordings (``crossfit``, ``between``), from which the finding's
        parameter spread and its look-alike comparisons are computed beside those parameters.
        """
        if judged.name != self.name:
            raise ValueError(f"cannot give {self.name} the judgement of {judged.name}")
        return replace(self, heldout=judged.heldout, size_ok=judged.size_ok,
                       share_waived=judged.share_waived, decision=judged.decision,
                       verdict=judged.verdict, given=given, where=judged.where,
                       elsewhere=judged.elsewhere, overall=judged.overall,
                       beyond_history=judged.beyond_history,
                       noise_factor=judged.noise_factor)

    @property
    def family(self) -> str:
        return EFFECTS[self.name].family

    @property
    def choice_gain(self) -> float:
        """The held-out MSE reduction the choice between passing candidates of different
        families compares (:func:`~core.diagnosis.judge.choose`): on all the test rows,
        ``overall``'s for a candidate judged where its signature lives (its own comparison
        is on other rows, a creep's on changes inside the holds, and a share of one row set
        says nothing against a share of another), else its own comparison's."""
        return (self.overall or self.heldout).gain

    @property
    def evidence_rows(self) -> HeldOut:
        """The comparison the significance rule uses (cross-fitted when available)."""
        return self.crossfit.pooled if self.crossfit is not None else self.heldout


def excess_of(c: Candidate, mse_cur: float, noise: float, strict: bool) -> float:
    """The excess over the noise floor the share rule of candidate ``c`` is counted in, the
    one definition the judge's verdict (:func:`~core.diagnosis.judge.judge_round`) and the
    search's leading family (:func:`~core.diagnosis.search.search_round`) both use
    (output units²): the MSE of its evidence rows (``c.heldout.mse_before`` with strict
    hold-out, between recordings or on its signature rows; else ``mse_cur``, the current
    model's test-row MSE) minus the floor of those rows
    (:func:`~core.diagnosis.acceptance.floor_mse`: twice ``noise²`` on rows compared with an
    earlier row, ``2 / block`` times it on means of ``block`` rows compared so, ``noise`` the
    white-noise RMS in output units)."""
    before = c.heldout.mse_before if strict or c.between or c.where else mse_cur
    return before - floor_mse(noise, c.noise_factor)


@dataclass
class Run:
    """What one diagnosis accumulates over its rounds (findings, ambiguities, rows)."""

    ctx: FitContext
    noise: float
    untestable: list[Untestable]
    max_effects: int
    #: rate- / amplitude-dependent effects judged by predicting each recording from the others
    between: BetweenPlan
    say: Progress
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
    #: several recordings and no explicit windows: acceptance rule 8 (leave one recording
    #: out) judges a per-recording level when it is chosen, not only in the final model
    across_recordings: bool = False
    #: per-recording levels refused by rule 8 in their round (by name; the last refusal)
    recording_specific: dict[str, RecordingSpecific] = field(default_factory=dict)

    @property
    def untestable_names(self) -> set[str]:
        return {u.name for u in self.untestable}

    def step(self, rnd: int, frac: float, msg: str) -> None:
        """Progress inside round ``rnd`` (``frac`` of the round done)."""
        self.say(0.1 + 0.8 / max(self.max_effects, 1) * (rnd + frac), f"round {rnd + 1}: {msg}")


def evidence_label(ctx: FitContext, name: str, cf: CrossFit | None,
                   bt: BetweenRecordings | None = None) -> str:
    if bt is not None:
        return (f"each of {bt.folds} recordings predicted from the others "
                "(leave-one-recording-out, parameters searched without it)")
    if EFFECTS[name].before_wipeout:
        return ("training rows before the wipe-out time (in-sample, 1-2 parameters)"
                if ctx.strict else "rows before the wipe-out time")
    if ctx.strict:
        return (f"{cf.folds} cross-fitted training blocks" if cf is not None else
                "training-RSS screen (below the effect-size rule, not cross-fitted)")
    return "test rows"


def round_row(ctx: FitContext, rnd: int, c: Candidate, passes: bool,
              decision: str | None = None, evidence: str | None = None,
              reasons: tuple[str, ...] | None = None) -> RoundRow:
    """The round row of candidate ``c`` (cross-fitting and between-recordings details)."""
    h, cf, bt = c.heldout, c.crossfit, c.between
    extra: dict[str, Any] = {}
    label = c.where or evidence_label(ctx, c.name, cf, bt)
    if cf is not None:
        extra.update(fold_mse_reductions=cf.fold_gains, parameter_cv=cf.parameter_cv)
        if not ctx.strict:  # the test rows pooled with the cross-fitted blocks
            p = cf.pooled
            label = f"{c.where or 'test rows'} + {cf.folds} cross-fitted blocks"
            extra.update(dm_z_pooled=p.z, signed_rank_p_pooled=p.sign_p,
                         mse_reduction_pooled=p.gain)
    if bt is not None:
        extra.update(per_recording=bt.per_recording, parameter_cv=bt.parameter_cv)
    return RoundRow(rnd + 1, c.name, h.gain, h.z, h.sign_p, bool(passes), decision,
                    c.parameters, evidence or label, reasons, tuple(extra.items()))


def deferred_row(rnd: int, name: str, params: dict | None = None,
                 screen: float | None = None) -> RoundRow:
    """Row of a candidate left for the next round: because a higher-priority family passed
    and it could not explain ``family_lead`` (1.5) times as much, or (``screen``, its
    training-RSS reduction, below zero) because it does not lower the training error at
    all."""
    why = ("not needed: an effect of a higher-priority family passed, and this one could not "
           f"explain {RULE.family_lead:g} times as much") if screen is None else (
        f"not tested further: it does not lower the training error (change "
        f"{100 * screen:+.1f} %), so it cannot pass held out")
    return RoundRow(rnd + 1, name, float("nan"), float("nan"), float("nan"), False,
                    "deferred", params or {}, why)
