"""Results of a diagnosis: one finding per accepted effect and the whole outcome (JSON via
``to_dict``, text via ``summary``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._typing import Float1D
from ..base import Model
from ..exceptions import ParameterError
from ..fitting.metrics import percent_of_range
from ..recordings import Recording
from .acceptance import RULE
from .adequacy import Adequacy
from .bases import BASE_KINDS, MP
from .between import BetweenPlan
from .candidates import build_candidate
from .context import FitContext
from .eventresponse import StepSuggestion
from .registry import EFFECTS
from .specs import Untestable
from .stats import HeldOut, ljung_box
from .structure import Fit, PIStageOutputs, Structure

__all__ = ["ACCEPT_RULE", "RESULT_FORMAT", "RESULT_VERSION", "BaseChoice", "BaseRival",
           "BaseTrial", "DiagnosisResult", "EffectFinding", "RecordingSpecific", "RoundRow",
           "StopBase", "Untestable", "pooled_mse"]


#: Acceptance thresholds (documented in the JSON output; :data:`core.diagnosis.acceptance.RULE`).
ACCEPT_RULE: dict[str, float] = RULE.as_dict()

#: Optional keys of a round row's JSON form, in the order they are written.
_ROW_EXTRA = ("fold_mse_reductions", "parameter_cv", "per_recording", "dm_z_pooled",
              "signed_rank_p_pooled", "mse_reduction_pooled")


@dataclass(frozen=True)
class RoundRow:
    """One candidate of one round of the diagnosis, with its held-out statistics and the
    decision about it (a row of ``tested`` in the JSON document).

    Attributes
    ----------
    round : int
        1-based round of the forward selection (refinement rows carry the round they follow).
    effect : str
        Effect name, or ``resolution:N`` / ``recheck:NAME`` for the refinement steps.
    heldout_mse_reduction, dm_z, signed_rank_p : float
        Effect-size and significance statistics on the evidence rows (``evidence``); NaN for a
        deferred candidate.
    passes : bool
        Every acceptance rule holds (:func:`core.diagnosis.acceptance.decide`).
    decision : str
        ``accepted``, ``ambiguous`` (a look-alike the recordings do not separate from the
        accepted one), ``passes`` (passed, another effect was chosen), ``rejected``,
        ``deferred`` (not needed this round), ``not earned`` (passed on the test rows as a
        further effect but not against the model holding the accepted ones, cross-fitted),
        ``contradicted`` (passed, but the discriminator of its look-alikes points elsewhere:
        the reversible/hysteretic split for a delay or lag, the step-sign locking for creep).
    parameters : dict
        The candidate's fitted parameters.
    evidence : str or None
        The rows the statistics were computed on.
    reasons : tuple of str or None
        Why it failed, in words.
    extra : tuple of (str, object)
        Cross-fitting / between-recordings details (keys of :data:`_ROW_EXTRA`).
    """

    round: int
    effect: str
    heldout_mse_reduction: float
    dm_z: float
    signed_rank_p: float
    passes: bool
    decision: str | None = None
    parameters: dict[str, Any] = field(default_factory=dict)
    evidence: str | None = None
    reasons: tuple[str, ...] | None = None
    extra: tuple[tuple[str, Any], ...] = ()

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RoundRow:
        """A row from its JSON form (e.g. the refinement rows of the engine helpers)."""
        return cls(int(d["round"]), str(d["effect"]), float(d["heldout_mse_reduction"]),
                   float(d["dm_z"]), float(d["signed_rank_p"]), bool(d["passes"]),
                   d.get("decision"), dict(d.get("parameters", {})), d.get("evidence"),
                   None if d.get("reasons") is None else tuple(d["reasons"]),
                   tuple((k, d[k]) for k in _ROW_EXTRA if k in d))

    def detail(self, key: str, default: Any = None) -> Any:
        """One of the :attr:`extra` details by name."""
        return dict(self.extra).get(key, default)

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (a row of ``tested``, see :meth:`DiagnosisResult.to_dict`)."""
        d: dict[str, Any] = {"round": self.round, "effect": self.effect,
                             "heldout_mse_reduction": self.heldout_mse_reduction,
                             "dm_z": self.dm_z, "signed_rank_p": self.signed_rank_p}
        if self.evidence is not None:
            d["evidence"] = self.evidence
        d.update(self.extra)
        d.update({"passes": self.passes, "parameters": self.parameters})
        if self.reasons is not None:
            d["reasons"] = list(self.reasons)
        if self.decision is not None:
            d["decision"] = self.decision
        return d

    # read-only mapping view of the JSON form, for callers that index rows by key
    def __getitem__(self, key: str) -> Any:
        return self.to_dict()[key]

    def __contains__(self, key: object) -> bool:
        return key in self.to_dict()

    def get(self, key: str, default: Any = None) -> Any:
        return self.to_dict().get(key, default)


@dataclass
class EffectFinding:
    """One accepted effect (SAY / MODEL / SHOW)."""

    name: str
    parameters: dict[str, Any]
    uncertainty: dict[str, Any]
    where: dict[str, Any]
    explanation: str
    equation: str
    heldout: HeldOut
    heldout_rmse_before: float
    heldout_rmse_after: float
    score_lm: float
    discriminators: dict[str, Any] = field(default_factory=dict)
    ambiguous_with: list[str] = field(default_factory=list)
    runner_up: dict[str, Any] = field(default_factory=dict)
    crossfit: dict[str, Any] | None = None
    uncertainty_method: str = "profile curvature"
    structure: Structure | None = None
    loro: dict[str, Any] | None = None
    caveats: list[str] = field(default_factory=list)
    #: the rows the acceptance statistics (``heldout``) were computed on
    evidence: str = "test rows"
    #: leave-one-recording-out estimates and their jackknife sigmas
    #: (:func:`~core.diagnosis.crossfitting.recording_spread`), with several recordings
    recording_spread: dict[str, Any] | None = None
    #: the estimates with each recording left out in turn and their jackknife sigmas
    #: (:func:`~core.diagnosis.misspecification.recording_jackknife`)
    recording_jackknife: dict[str, Any] | None = None
    #: the parameters refitted on the other base families, and the systematic 1-sigma their
    #: shifts give (:func:`~core.diagnosis.misspecification.base_sensitivity`)
    base_sensitivity: dict[str, Any] | None = None
    #: parameters the data do not fix to a number (1-sigma beyond
    #: :data:`~core.diagnosis.crossfitting.AMBIGUOUS_REL_SIGMA` of the value)
    ambiguous_parameters: list[str] = field(default_factory=list)
    #: the effect's term was to be fitted on changes between rows of the same input history
    #: (from cycle to cycle) and was fitted on all the training rows instead, because that
    #: fit left the training rows worse than no such term (:attr:`Fit.raw_fallback`), in
    #: the fit the effect was judged with, which :attr:`parameters` come from (its term's
    #: coefficients); the final model's own fallback is :attr:`DiagnosisResult.final`'s
    #: ``raw_fallback``, and the report says when the two differ
    #: (:func:`~core.diagnosis.report.final_fit_words`)
    fitted_on_all_rows: bool = False

    def to_dict(self, y_range: float) -> dict[str, Any]:
        """JSON-ready form (see :meth:`DiagnosisResult.to_dict`)."""
        h = self.heldout
        return {
            "name": self.name,
            "family": EFFECTS[self.name].family,
            "parameters": _jsonable(self.parameters),
            "uncertainty": _jsonable(self.uncertainty),
            "uncertainty_method": self.uncertainty_method,
            "ambiguous_parameters": list(self.ambiguous_parameters),
            "fitted_on_all_rows": self.fitted_on_all_rows,
            "recording_spread": _jsonable(self.recording_spread),
            "recording_jackknife": _jsonable(self.recording_jackknife),
            "base_sensitivity": _jsonable(self.base_sensitivity),
            "leave_one_recording_out": _jsonable(self.loro),
            "caveats": list(self.caveats),
            "where": _jsonable(self.where),
            "explanation": self.explanation,
            "equation": self.equation,
            "heldout_rmse_before": self.heldout_rmse_before,
            "heldout_rmse_after": self.heldout_rmse_after,
            "heldout_rmse_before_pct": 100 * self.heldout_rmse_before / y_range,
            "heldout_rmse_after_pct": 100 * self.heldout_rmse_after / y_range,
            "heldout_mse_reduction": h.gain,
            "dm_z": h.z,
            "signed_rank_p": h.sign_p,
            "evidence": self.evidence,
            "score_lm": self.score_lm,
            "discriminators": _jsonable(self.discriminators),
            "ambiguous_with": list(self.ambiguous_with),
            "runner_up": _jsonable(self.runner_up),
            "crossfit": _jsonable(self.crossfit),
        }


@dataclass(frozen=True)
class BaseRival:
    """The richer base a static-map alternative of the base choice was compared with (a row
    of :attr:`BaseChoice.tried` whose base is the PI with a static output map or a loop
    shape, which the effect search names instead).

    Attributes
    ----------
    base : str
        The richer base's kind (``"preisach"`` or ``"menegotto-pinto"``: a key of
        :data:`~core.diagnosis.bases.BASE_KINDS`).
    mse_reduction : float
        Its MSE reduction against the alternative, each recording predicted from the others.
    mse_reduction_with_dynamics : float, optional
        The same with each of the two followed by the output dynamics stage that predicts
        its folds best, where :attr:`mse_reduction` is below the margin
        (:data:`~core.fitting.choice.PREISACH_OVER_MAP`); ``None`` where not compared so.
    """

    base: str
    mse_reduction: float
    mse_reduction_with_dynamics: float | None = None

    @property
    def key(self) -> str:
        """The JSON key of :attr:`mse_reduction` in the row's JSON form
        (``"preisach_mse_reduction_over_it"``, ``"menegotto_pinto_..."``)."""
        return f"{self.base.replace('-', '_')}_mse_reduction_over_it"


@dataclass(frozen=True)
class BaseTrial:
    """One alternative of the base choice and how it predicted the recordings (a row of
    :attr:`BaseChoice.tried`).

    Attributes
    ----------
    base : str
        What was tried: a base kind (``"preisach"``, ``"bouc-wen"``, ``"menegotto-pinto"``)
        or a static-map alternative (``"mpi (static output map)"``, ``"pi + saturation"``).
    operators : int
        Its plays, or its elements (Bouc-Wen, Menegotto-Pinto); 0 for the modified PI.
    level_segments : int
        Level segments of a Preisach base (1 otherwise).
    smoothness : float
        Smoothness of a Preisach base's level segments (0 otherwise).
    cv_mse_reduction : float
        Its MSE reduction against the PI (or stop) base, each recording predicted from the
        others.
    rival : BaseRival, optional
        For a static-map alternative, the richer base it was compared with.
    cv_mse_reduction_with_dynamics : float, optional
        :attr:`cv_mse_reduction` with each base followed by the output dynamics stage that
        predicts its folds best: a bank base better than the PI (or stop) base but short
        of its margin (:class:`~core.diagnosis.basechoice._EqualFooting`); ``None`` where
        not compared so.
    """

    base: str
    operators: int
    level_segments: int
    smoothness: float
    cv_mse_reduction: float
    rival: BaseRival | None = None
    cv_mse_reduction_with_dynamics: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (a row of ``tried`` of :meth:`BaseChoice.to_dict`): ``{"base",
        "operators", "level_segments", "smoothness", "cv_mse_reduction"}``, with a rival its
        ``"<rival>_mse_reduction_over_it"`` and, where compared so, the same
        ``..._with_dynamics``, and ``"cv_mse_reduction_with_dynamics"`` where set."""
        d: dict[str, Any] = {"base": self.base, "operators": self.operators,
                             "level_segments": self.level_segments,
                             "smoothness": self.smoothness,
                             "cv_mse_reduction": self.cv_mse_reduction}
        if self.cv_mse_reduction_with_dynamics is not None:
            d["cv_mse_reduction_with_dynamics"] = self.cv_mse_reduction_with_dynamics
        r = self.rival
        if r is not None:
            d[r.key] = r.mse_reduction
            if r.mse_reduction_with_dynamics is not None:
                d[f"{r.key}_with_dynamics"] = r.mse_reduction_with_dynamics
        return d

    def text(self) -> str:
        """The row in words, as the base choice's :attr:`~BaseChoice.text` lists it."""
        mse = f"MSE {-100 * self.cv_mse_reduction + 0.0:+.0f} %"
        if self.base == "preisach":
            return (f"preisach ({self.operators} plays x {self.level_segments} level "
                    f"segments) {mse}")
        if self.base in ("bouc-wen", MP):
            dyn = self.cv_mse_reduction_with_dynamics
            return (f"{self.base} ({self.operators} elements) {mse}"
                    + ("" if dyn is None else
                       f", {-100 * dyn + 0.0:+.0f} % with each its best output dynamics"))
        r = self.rival
        if r is None:
            return f"{self.base} {mse}"
        who = BASE_KINDS[r.base].short if r.base in BASE_KINDS else r.base
        return f"{self.base} {mse}, the {who} {-100 * r.mse_reduction + 0.0:+.0f} % against it"


@dataclass(frozen=True)
class StopBase:
    """The stop-operator base of clockwise loops as the base choice tried it
    (:attr:`BaseChoice.stop`; :mod:`core.diagnosis.bases`).

    Attributes
    ----------
    gap : float
        The backlash gap's width (input units).
    elements : int
        Stop operators in the bank.
    friction_plateau : float
        The friction plateau (output units; where the force is positive, when the slip
        force depends on the sliding direction).
    heldout_mse_reduction : float
        Its held-out MSE reduction against the PI with weights of either sign.
    chosen : bool
        It replaced the PI baseline.
    slip_force_ratio : float, optional
        ``g- / g+`` where the slip force depends on the sliding direction
        (:class:`~core.stages.SignedGain` after the bank, as ``hyst fit`` finds it);
        ``None`` with one gain.
    """

    gap: float
    elements: int
    friction_plateau: float
    heldout_mse_reduction: float
    chosen: bool
    slip_force_ratio: float | None = None

    @property
    def friction_plateau_falling(self) -> float | None:
        """The plateau where the force is negative (output units), with a
        :attr:`slip_force_ratio`; else ``None``."""
        r = self.slip_force_ratio
        return None if r is None else self.friction_plateau * r

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (``stop`` of :meth:`BaseChoice.to_dict`): ``{"gap", "elements",
        "friction_plateau", "heldout_mse_reduction", "chosen"}``, and
        ``"slip_force_ratio"`` and ``"friction_plateau_falling"`` with two gains."""
        d: dict[str, Any] = {"gap": self.gap, "elements": self.elements,
                             "friction_plateau": self.friction_plateau,
                             "heldout_mse_reduction": self.heldout_mse_reduction,
                             "chosen": self.chosen}
        if self.slip_force_ratio is not None:
            d |= {"slip_force_ratio": self.slip_force_ratio,
                  "friction_plateau_falling": self.friction_plateau_falling}
        return d

    def plateau_words(self, unit: str = "output units") -> str:
        """The friction plateau in words (in ``unit``, the output's): one height, or one for
        each sign of the force where the slip force depends on the sliding direction."""
        p, ratio = self.friction_plateau, self.slip_force_ratio
        if ratio is None:
            return f"friction plateau {p:.4g} {unit}"
        return (f"the slip force depends on the sliding direction: friction plateau {p:.4g} "
                f"{unit} where the force is positive and {p * ratio:.4g} {unit} where it is "
                f"negative, {ratio:.3g} times as large")


@dataclass(frozen=True)
class BaseChoice:
    """How the base hysteresis was chosen (each recording predicted from the others).

    Attributes
    ----------
    kind : str
        ``"pi"``, ``"stop-pi"`` (stop operators behind a backlash gap, for clockwise loops),
        ``"preisach"`` (level-dependent memory, E10), ``"bouc-wen"`` (a bank of Bouc-Wen
        elements, :mod:`core.diagnosis.bases`) or ``"menegotto-pinto"`` (a bank of smooth
        stop elements with a non-Masing knee, the same module): the family names of
        :func:`core.fitting.choice.base_family`, declared in
        :data:`core.diagnosis.bases.BASE_KINDS`.
    tried : tuple of BaseTrial
        Each alternative and its MSE reduction against the PI (or stop) base on the
        left-out recordings; the static-map alternatives with the richer base they were
        compared with (:class:`BaseRival`).
    folds : int
        Left-out recordings.
    stop : StopBase, optional
        On clockwise loops, the stop-operator base tried first; ``None`` on
        counter-clockwise loops.
    """

    kind: str
    tried: tuple[BaseTrial, ...]
    folds: int
    stop: StopBase | None = None

    @property
    def text(self) -> str:
        """The choice in words (stop base's gap and plateau in "input units" / "output
        units"; :meth:`text_in` names the recordings' units)."""
        return self.text_in()

    def text_in(self, units: Mapping[str, str] | None = None) -> str:
        """:attr:`text` with the stop base's gap and plateau in ``units`` (``"input"``,
        ``"output"``: a recording's :attr:`~core.recordings.Recording.units`)."""
        ui = (units or {}).get("input") or "input units"
        uo = (units or {}).get("output") or "output units"
        alts = "; ".join(t.text() for t in self.tried)
        how = f"each of {self.folds} recordings predicted from the others"
        st = self.stop
        if self.kind == "stop-pi" and st is not None:
            gap = (f"behind a backlash gap {st.gap:.4g} {ui} wide (the force stays "
                   "at zero while the input crosses it)" if st.gap > 0 else
                   "without a backlash gap")
            return (f"stop operators (Maxwell-slip elements, {st.plateau_words(uo)}) {gap}: "
                    "the loops run "
                    "clockwise, as hyst fit --model auto chooses it; held-out MSE "
                    f"{-100 * st.heldout_mse_reduction + 0.0:+.0f} % against the PI with "
                    "weights of either sign"
                    + (f"; no other base predicted the recordings clearly better ({how}, "
                       f"against it: {alts})" if self.tried else "")
                    + "; the effects are judged against it")
        if self.kind == "preisach":
            return ("level-dependent memory (E10): a Preisach base whose relay density varies "
                    f"with the input level predicts the recordings clearly better than the PI "
                    f"and than a PI with a static output map ({how}, against the PI: {alts}); "
                    "the effects are judged against it")
        if self.kind == "bouc-wen":
            return ("Bouc-Wen: a bank of Bouc-Wen elements of fixed shapes (y = k u + sum c_j "
                    "z_j) predicts the recordings clearly better than the PI and than any "
                    f"Preisach base tried ({how}, against the PI: {alts}); the effects are "
                    "judged against it")
        if self.kind == "menegotto-pinto":
            return ("Menegotto-Pinto: a bank of smooth stop elements whose knee rounds with "
                    "the previous plastic excursion (y = k u + sum w_i s_i, non-Masing loops "
                    "such as a steel's) predicts the recordings clearly better than the PI "
                    f"and than the other bases tried ({how}, against the PI: {alts}); the "
                    "effects are judged against it")
        if not self.tried:
            return "PI (no alternative base tried: it needs two or more recordings)"
        return (f"PI, kept: no other base predicted the recordings clearly better ({how}, "
                f"against the PI: {alts})")

    def to_dict(self) -> dict[str, Any]:
        """The JSON form (``baseline.base_choice`` of :meth:`DiagnosisResult.to_dict`):
        ``{"kind", "tried", "folds", "stop", "text"}``, the rows and the stop base as their
        own ``to_dict`` writes them."""
        return {"kind": self.kind, "tried": [t.to_dict() for t in self.tried],
                "folds": self.folds, "stop": None if self.stop is None else self.stop.to_dict(),
                "text": self.text}


@dataclass(frozen=True)
class RecordingSpecific:
    """An effect that passed the acceptance rules on the recordings it was fitted on but made
    the prediction of unseen recordings worse (leave-one-recording-out): reported with the
    numbers, not claimed as physics, and taken out of the final model.

    Attributes
    ----------
    name : str
    parameters : dict
        As fitted (per recording for an offset or a drift).
    loro_mse_reduction : float
        Leave-one-recording-out MSE reduction of the effect (negative: worse).
    loro_rmse_before, loro_rmse_after : float
        Pooled leave-one-recording-out RMSE without and with it (output units).
    per_recording : tuple of dict
        ``{"recording", "rmse_before", "rmse_after"}`` per left-out recording.
    text : str
        What it means, in words.
    """

    name: str
    parameters: dict[str, Any]
    loro_mse_reduction: float
    loro_rmse_before: float
    loro_rmse_after: float
    per_recording: tuple[dict[str, Any], ...]
    text: str

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "parameters": _jsonable(self.parameters),
                "leave_one_recording_out_mse_reduction": self.loro_mse_reduction,
                "leave_one_recording_out_rmse_before": self.loro_rmse_before,
                "leave_one_recording_out_rmse_after": self.loro_rmse_after,
                "per_recording": _jsonable(list(self.per_recording)), "text": self.text}


@dataclass
class DiagnosisResult:
    """Outcome of :func:`diagnose`.

    Attributes
    ----------
    records : list of Recording
    baseline, final : Fit
        The baseline PI fit (at the resolution chosen by the under-resolution check) and the
        fit with every accepted effect.
    requested : Fit
        The PI fit with the requested number of operators.
    effects : list of EffectFinding
        Accepted effects in the order they were found.
    untestable : list of Untestable
        Each effect the recordings cannot excite, with the reason and the experiment.
    ambiguous : list of dict
        ``{"effects", "chosen", "reason", "experiment"}`` per undecided pair.
    rounds : list of RoundRow
        Every candidate tested in every round with its held-out statistics and decision.
    maps_before, maps_after : dict
        Residual maps (LOCATE) of the baseline and the final model on all rows.
    split : str
        How the train/test rows were chosen.
    loro_baseline, loro_final : dict or None
        Leave-one-recording-out scores of the baseline and the final structure (see
        :func:`leave_one_recording_out`); ``None`` with one recording or an explicit
        train/test window.
    """

    records: list[Recording]
    train: list[np.ndarray]
    test: list[np.ndarray]
    baseline: Fit
    final: Fit
    effects: list[EffectFinding]
    untestable: list[Untestable]
    ambiguous: list[dict[str, Any]]
    rounds: list[RoundRow]
    maps_before: dict[str, Any]
    maps_after: dict[str, Any]
    split: str
    noise_rms: float
    elapsed_s: float
    model_name: str = "pi"
    requested: Fit | None = None
    loro_baseline: dict[str, Any] | None = None
    loro_final: dict[str, Any] | None = None
    #: strict hold-out: baseline and final RMSE on the cross-fitted training blocks (the
    #: rows the selection used, so optimistic for the final model); else ``None``
    crossval: dict[str, Any] | None = None
    #: base-model adequacy verdict (noise floor, loop-shape classes tried)
    adequacy: Adequacy | None = None
    #: which effects were judged by predicting each recording from the others, why not
    between: BetweenPlan | None = None
    #: the final structure refitted on every row the user gave (train and test blocks of
    #: the interleaved split, after selection, as a grid search refits its best estimator);
    #: ``None`` with explicit windows (the test window is the user's own hold-out)
    refit: Fit | None = None
    #: effects that passed on the recordings they were fitted on but did not generalise to
    #: unseen recordings (leave-one-recording-out worse): not claimed, not in the model
    recording_specific: list[RecordingSpecific] = field(default_factory=list)
    #: an output dynamics kind the input steps show, on fewer steps than a name needs and
    #: with no output dynamics named (rule 18): suggestive, with where and what would decide
    after_steps: StepSuggestion | None = None
    #: how the base hysteresis was chosen (PI or a Preisach with level-dependent memory)
    base_choice: BaseChoice | None = None

    def __post_init__(self) -> None:
        # the fits' PI-stage outputs are formed on first use from the play banks; a result
        # outlives the diagnosis, so it holds the outputs, not the banks
        for f in (self.baseline, self.final, self.requested, self.refit):
            if f is not None and isinstance(f.x_pi, PIStageOutputs):
                f.x_pi.resolve()

    @property
    def saved_fit(self) -> Fit:
        """The fit behind :attr:`model`: :attr:`refit` when there is one, else :attr:`final`."""
        return self.refit if self.refit is not None else self.final

    @property
    def model(self) -> Model:
        """The final extended model (as fitted to the first recording), refitted on every
        row the user gave when no train/test windows were given (:attr:`refit`); the
        held-out scores of the report are those of :attr:`final` (fitted on the training
        rows only)."""
        return self.saved_fit.models[0]

    @property
    def suggestive(self) -> list[dict[str, Any]]:
        """Effects of the last round that improved the held-out MSE by >= 5 % but failed the
        significance test: worth a targeted experiment, not claimed."""
        return [
            {k: d[k] for k in ("effect", "heldout_mse_reduction", "dm_z", "signed_rank_p",
                               "parameters", "dm_z_pooled", "signed_rank_p_pooled",
                               "parameter_cv") if k in d}
            for r in suggestive_rows(self.rounds) for d in (r.to_dict(),)
        ]

    @property
    def suggestive_rows(self) -> list[RoundRow]:
        """The rows of :attr:`suggestive`, typed (:func:`suggestive_rows` of :attr:`rounds`)."""
        return suggestive_rows(self.rounds)

    @property
    def suggested_names(self) -> list[str]:
        """Names of every effect suggested and not claimed: :attr:`suggestive`, then the kind
        the input steps show (:attr:`after_steps`) when not among them."""
        return suggested_names(self.rounds, self.after_steps)

    def with_effect(self, name: str) -> tuple[Fit, dict[str, Any]]:
        """Fit effect ``name`` on top of the final model although it was not claimed.

        For a user who wants to try a *suggestive* effect (one that improved the held-out fit
        but failed the significance rule). Nothing here is a claim; the held-out RMSE of the
        returned fit is :meth:`heldout_rmse`.

        Returns
        -------
        fit : Fit
        parameters : dict
        """
        if name not in EFFECTS:
            raise ParameterError(f"unknown effect {name!r}; known: {', '.join(EFFECTS)}")
        ctx = FitContext(self.records, self.train, self.test)
        got = build_candidate(ctx, name, self.final)
        if got is None:
            raise ParameterError(f"effect {name!r} is already in the model or not applicable")
        return got[0], got[1]

    @property
    def _req(self) -> Fit:
        return self.requested if self.requested is not None else self.baseline

    @property
    def y_range(self) -> float:
        """Output range of the held-out rows, all recordings pooled: the denominator of every
        held-out "% of range" (:func:`core.fitting.metrics.percent_of_range`, as in the fit
        reports)."""
        ys = [r.y[m] for r, m in zip(self.records, self.test, strict=True) if m.any()]
        return 100.0 / percent_of_range(1.0, ys or [r.y for r in self.records])

    def heldout_rmse(self, fit: Fit) -> float:
        """Held-out RMSE of ``fit`` over every recording (output units); NaN without a test
        window."""
        return float(np.sqrt(pooled_mse([(r.y - p)[m] for r, p, m in zip(
            self.records, fit.pred, self.test, strict=True)])))

    def per_recording(self, fit: Fit) -> list[dict[str, Any]]:
        """Held-out and training RMSE per recording."""
        out = []
        for r, p, tr, te in zip(self.records, fit.pred, self.train, self.test, strict=True):
            e = r.y - p
            out.append(
                {
                    "recording": r.name,
                    "heldout_rmse": float(np.sqrt(np.mean(e[te] ** 2))) if te.any() else None,
                    "train_rmse": float(np.sqrt(np.mean(e[tr] ** 2))) if tr.any() else None,
                }
            )
        return out

    def to_dict(self) -> dict[str, Any]:
        """Machine-readable result (the ``hyst diagnose --json`` document).

        Keys
        ----
        ``format``, ``version``
            ``"hysteresis-explorer/diagnosis"``, 1.
        ``recordings``
            Name, samples, dt of each recording; ``split`` says how train/test were chosen.
        ``baseline``
            ``model`` (``"pi"``), ``n_operators``, ``heldout_rmse`` (output units),
            ``heldout_rmse_pct`` (% of the output range), ``per_recording``, ``noise_rms``,
            ``ljung_box``, the residual maps ``maps`` (LOCATE) and
            ``leave_one_recording_out`` (with >= 2 recordings and the default interleaved
            split, else ``null``): ``{"rule", "rmse", "rmse_pct", "per_recording": [{
            "recording", "samples", "rmse", "rmse_pct"}]}``, each recording predicted by the
            structure refitted on the other recordings only.
        ``effects``
            Accepted effects in order; each has ``name`` (an effect ``type``), ``parameters``,
            ``uncertainty`` (1-sigma, autocorrelation-inflated), ``where`` (time windows,
            input range, branch shares, summary), ``explanation``, ``equation``,
            ``heldout_rmse_before``/``_after`` (output units, and ``_pct``),
            ``heldout_mse_reduction``, ``dm_z``, ``sign_test_p``, ``score_lm``,
            ``discriminators``, ``ambiguous_with``, ``runner_up``, ``crossfit`` (with
            explicit windows: ``folds``, ``dm_z_pooled``, ``signed_rank_p_pooled``,
            ``mse_reduction_pooled``, ``fold_mse_reductions``, ``fold_parameters``,
            ``parameter_cv``; else ``null``), ``uncertainty_method``, ``caveats`` (e.g. the rows
            outside train/test got more than 25 % worse) and
            ``leave_one_recording_out`` (``{"rmse_before", "rmse_after", "mse_reduction",
            "per_recording"}``: the structure up to this effect against the one before it,
            scored as in ``baseline``; ``null`` when not scored).
        ``untestable``
            ``[{"name", "reason", "experiment"}]``.
        ``ambiguous``
            ``[{"effects", "chosen", "reason", "experiment"}]``.
        ``final``
            ``effects`` (names), ``heldout_rmse`` (+ ``_pct``), ``per_recording``, ``model``
            (the extended model's ``to_dict()``), ``maps``, ``leave_one_recording_out``
            (as in ``baseline``, plus ``mse_reduction`` against the baseline's).
        ``suggestive``
            Effects of the last round with >= 5 % held-out MSE reduction that failed the
            significance rule (not claimed).
        ``suggestive_after_steps``
            ``{"effect", "parameters", "steps_s", "ambiguous_with", "text"}``: an output
            dynamics kind every input step shows on fewer steps than a name needs, when no
            output dynamics is named (not claimed); ``null`` otherwise.
        ``tested``
            Every candidate of every round with its held-out gain, z and decision.
        ``accept_rule``
            The thresholds used.
        ``between_recordings``
            ``{"rate": {"tested", "reason"}, "amplitude": {"tested", "reason"}}``: whether
            rate-dependent effects (recordings at different rates) and amplitude-dependent
            ones (recordings at different amplitudes, e.g. B-H loops) were judged by
            predicting each recording from the others, and why not.
        """
        yr = self.y_range
        return _jsonable({
            "format": "hysteresis-explorer/diagnosis",
            "version": 1,
            "crossval": self.crossval,
            "adequacy": None if self.adequacy is None else self.adequacy.to_dict(),
            "between_recordings": None if self.between is None else self.between.to_dict(),
            "recordings": [{"name": r.name, "samples": r.n_samples, "dt_s": r.dt,
                            "time_axis": r.has_time, "cleaning": list(r.cleaning)}
                           for r in self.records],
            "split": self.split,
            "baseline": self._baseline_dict(yr),
            "effects": [e.to_dict(yr) for e in self.effects],
            "untestable": [u.to_dict() for u in self.untestable],
            "recording_specific": [r.to_dict() for r in self.recording_specific],
            "ambiguous": _jsonable(self.ambiguous),
            "final": self._final_dict(yr),
            "suggestive": _jsonable(self.suggestive),
            "suggestive_after_steps": None if self.after_steps is None else {
                "effect": self.after_steps.kind,
                "parameters": self.after_steps.parameters,
                "steps_s": list(self.after_steps.steps_s),
                "ambiguous_with": list(self.after_steps.ambiguous_with),
                "text": self.after_steps.text,
            },
            "tested": _jsonable([r.to_dict() for r in self.rounds]),
            "accept_rule": ACCEPT_RULE,
            "elapsed_s": self.elapsed_s,
        })

    def _baseline_dict(self, yr: float) -> dict[str, object]:
        """The ``baseline`` part of :meth:`to_dict` (``yr``: the output range)."""
        b = self.heldout_rmse(self.baseline)
        rows = self.test if any(m.any() for m in self.test) else self.train
        lb = ljung_box(np.concatenate([(r.y - p)[m][:: max(1, int(m.sum() // 4000))] for r, p, m in
                                       zip(self.records, self.baseline.pred, rows,
                                           strict=True)]))
        return {
            "model": self.baseline.structure.base_kind,
            "base_choice": None if self.base_choice is None else self.base_choice.to_dict(),
            "n_operators": len(self.baseline.structure.thresholds),
            # a fixed-shape element base: its elements (Bouc-Wen: the tagged beta, gamma,
            # n; Menegotto-Pinto: the tagged sign, yield and shape), the operators' count
            **({("menegotto_pinto_elements" if self.baseline.structure.base_kind
                 == "menegotto-pinto" else "bouc_wen_elements"):
                [list(e) for e in self.baseline.structure.bouc_wen]}
               if self.baseline.structure.bouc_wen else {}),
            "weights": "free sign (saturating loop)" if self.baseline.structure.free_weights
            else "nonnegative",
            "heldout_rmse": b,
            "heldout_rmse_pct": 100 * b / yr,
            "requested_n_operators": len(self._req.structure.thresholds),
            "requested_heldout_rmse": self.heldout_rmse(self._req),
            "requested_heldout_rmse_pct": 100 * self.heldout_rmse(self._req) / yr,
            "per_recording": self.per_recording(self.baseline),
            "noise_rms": self.noise_rms,
            "ljung_box": {"Q": lb[0], "lags": lb[1]},
            "model_dict": self.baseline.models[0].to_dict(),
            "maps": _jsonable(self.maps_before),
            "leave_one_recording_out": _jsonable(self.loro_baseline),
        }

    def _final_dict(self, yr: float) -> dict[str, object]:
        """The ``final`` part of :meth:`to_dict` (``yr``: the output range)."""
        f = self.heldout_rmse(self.final)
        return {
            "effects": [e.name for e in self.effects],
            "heldout_rmse": f,
            "heldout_rmse_pct": 100 * f / yr,
            "per_recording": self.per_recording(self.final),
            "model": self.model.to_dict(),
            "model_fitted_on": ("every row (the training and the test blocks), refitted "
                                "after selection; the held-out scores above are those of "
                                "the fit on the training blocks") if self.refit is not None
            else "the training rows",
            "maps": _jsonable(self.maps_after),
            "leave_one_recording_out": _jsonable(self.loro_final),
        }

    def to_json(self) -> dict[str, Any]:
        """The result itself as a versioned JSON document (every field, arrays bit for bit;
        :mod:`core.diagnosis.typed_json`, format :data:`RESULT_FORMAT`): what a session
        stores. :meth:`to_dict` is the report instead (``hyst diagnose --json``).

        Raises
        ------
        core.diagnosis.typed_json.DocumentError
            A field holds a value the format cannot write (names where)."""
        from .typed_json import write_document

        return write_document(self, RESULT_FORMAT, RESULT_VERSION, _json_types())

    @classmethod
    def from_json(cls, doc: Any) -> DiagnosisResult:
        """The result a :meth:`to_json` document holds (equal to the one written).

        Raises
        ------
        core.diagnosis.typed_json.DocumentError
            ``doc`` is not such a document, of a later version, or damaged (says where).
        """
        from .typed_json import read_document

        out: DiagnosisResult = read_document(_upgraded(doc), RESULT_FORMAT, RESULT_VERSION,
                                             _json_types(), cls)
        return out

    def summary(self) -> str:
        """Readable multi-line report (:func:`core.diagnosis.report.summary_text`)."""
        from .report import summary_text

        return summary_text(self)


#: The ``format`` and the version of :meth:`DiagnosisResult.to_json` (a later version is
#: refused on reading).
RESULT_FORMAT = "hysteresis-explorer/diagnosis-result"
RESULT_VERSION = 3


def _upgraded(doc: Any) -> Any:
    """A :meth:`DiagnosisResult.to_json` document of an earlier version as
    :data:`RESULT_VERSION` writes it, step by step: version 1's ``untestable`` entries, plain
    ``{"name", "reason", "experiment"}`` objects then, become
    :class:`~core.diagnosis.specs.Untestable` (no parameters); version 2's base choice,
    whose ``tried`` rows and ``stop`` were plain objects (:meth:`BaseChoice.to_dict`'s
    keys), becomes :class:`BaseTrial` / :class:`BaseRival` rows and a :class:`StopBase`.
    Anything else is returned as it is (a damaged document is told by the reader)."""
    try:
        fields = doc["result"]["fields"]
        # exactly an integer: True == 1, and the reader refuses a boolean version
        version = doc["version"] if type(doc["version"]) is int else None
    except (KeyError, TypeError):
        return doc
    if version == 1:
        entries = fields.get("untestable") if isinstance(fields, dict) else None
        if not isinstance(entries, list):
            return doc
        new = [{"$type": "Untestable", "fields": dict(u)}
               if isinstance(u, dict) and set(u) == {"name", "reason", "experiment"} else u
               for u in entries]
        fields = {**fields, "untestable": new}
        doc, version = {**doc, "version": 2, "result": {**doc["result"], "fields": fields}}, 2
    if version == 2:
        bc = fields.get("base_choice") if isinstance(fields, dict) else None
        if isinstance(bc, dict) and bc.get("$type") == "BaseChoice" \
                and isinstance(bc.get("fields"), dict):
            bc = {**bc, "fields": _base_choice_v3(bc["fields"])}
            fields = {**fields, "base_choice": bc}
        doc = {**doc, "version": 3, "result": {**doc["result"], "fields": fields}}
    return doc


#: The keys of a version 2 document's base-choice row (:func:`_base_choice_v3`).
_TRIAL_KEYS = ("base", "operators", "level_segments", "smoothness", "cv_mse_reduction")
#: The keys of a version 2 document's stop base.
_STOP_KEYS = ("gap", "elements", "friction_plateau", "heldout_mse_reduction", "chosen")


def _base_choice_v3(fields: dict[str, Any]) -> dict[str, Any]:
    """The fields of a version 2 :class:`BaseChoice` (encoded) as version 3 holds them: each
    row of ``tried`` a :class:`BaseTrial` (its ``"<rival>_mse_reduction_over_it"`` key and
    the same ``..._with_dynamics`` a :class:`BaseRival`), ``stop`` a :class:`StopBase`
    (``friction_plateau_falling``, the plateau times the ratio, is derived now). A row or a
    stop of other keys is left as it is, for the reader to refuse."""
    out = dict(fields)
    tried = fields.get("tried")
    rows = tried.get("$tuple") if isinstance(tried, dict) else None
    if isinstance(rows, list):
        out["tried"] = {"$tuple": [_trial_v3(t) for t in rows]}
    st = fields.get("stop")
    if isinstance(st, dict) and "$type" not in st and set(_STOP_KEYS) <= set(st) \
            <= {*_STOP_KEYS, "slip_force_ratio", "friction_plateau_falling"}:
        out["stop"] = {"$type": "StopBase", "fields": {
            **{k: st[k] for k in _STOP_KEYS},
            **({"slip_force_ratio": st["slip_force_ratio"]} if "slip_force_ratio" in st
               else {})}}
    return out


def _trial_v3(t: Any) -> Any:
    """One version 2 row of ``tried`` (a plain object) as a :class:`BaseTrial`."""
    if not isinstance(t, dict) or "$type" in t or not set(_TRIAL_KEYS) <= set(t):
        return t
    rest = {k: v for k, v in t.items() if k not in _TRIAL_KEYS}
    over = [k for k in rest if k.endswith("_mse_reduction_over_it")]
    if len(over) > 1 or set(rest) - {*over, *(f"{k}_with_dynamics" for k in over)}:
        return t
    rival = None
    if over:
        k = over[0]
        rival = {"$type": "BaseRival", "fields": {
            "base": k.removesuffix("_mse_reduction_over_it").replace("_", "-"),
            "mse_reduction": rest[k],
            "mse_reduction_with_dynamics": rest.get(f"{k}_with_dynamics")}}
    return {"$type": "BaseTrial", "fields": {**{k: t[k] for k in _TRIAL_KEYS},
                                             "rival": rival}}


def _json_types() -> tuple[type, ...]:
    """The dataclasses a :meth:`DiagnosisResult.to_json` document may hold."""
    from .adequacy import LoopShapeFit

    return (DiagnosisResult, EffectFinding, RoundRow, BaseChoice, BaseTrial, BaseRival,
            StopBase, RecordingSpecific, Fit,
            Structure, Adequacy, LoopShapeFit, BetweenPlan, HeldOut, Recording, StepSuggestion,
            Untestable)


def suggestive_rows(rounds: Sequence[RoundRow]) -> list[RoundRow]:
    """The rows of the last round whose effect improved the held-out MSE by at least
    ``RULE.min_gain`` but failed the significance rules (the resolution and re-check rows
    left out): :attr:`DiagnosisResult.suggestive`."""
    if not rounds:
        return []
    last = max(r.round for r in rounds)
    return [r for r in rounds
            if r.round == last and not r.passes and r.heldout_mse_reduction >= RULE.min_gain
            and not r.effect.startswith(("resolution", "recheck"))]


def suggested_names(rounds: Sequence[RoundRow], after_steps: StepSuggestion | None
                    ) -> list[str]:
    """Names of every effect suggested and not claimed: the effects of
    :func:`suggestive_rows`, then the kind the input steps show (``after_steps``) when not
    among them (:attr:`DiagnosisResult.suggested_names`)."""
    names = [r.effect for r in suggestive_rows(rounds)]
    if after_steps is not None and after_steps.kind not in names:
        names.append(after_steps.kind)
    return names


def pooled_mse(es: Sequence[Float1D]) -> float:
    """Mean squared value of the pooled residuals (NaN when there are none)."""
    e = np.concatenate(list(es)) if es else np.zeros(0)
    return float(np.mean(e * e)) if e.size else float("nan")


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return [_jsonable(v) for v in x.tolist()]
    if isinstance(x, np.floating | float):
        v = float(x)
        return v if np.isfinite(v) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, HeldOut):
        return {"gain": x.gain, "z": _jsonable(x.z), "sign_p": x.sign_p}
    return x


