"""Acceptance of a candidate effect: the rules, and a typed decision that says which held.

A candidate is accepted when **all** of these hold (missing-physics notes §5, N1):

1. *Effect size*: its held-out MSE reduction is at least ``min_gain`` (5 %), and at least
   ``min_excess_share`` (20 %) of the current model's excess over the white-noise floor.
   Where the evidence rows' MSE is not above the floor (the noise level estimated for them
   is at or above their error, which a significant improvement contradicts), the share is
   counted over their whole MSE instead of being met by any reduction; where the excess is
   positive but below ``min_gain`` of the MSE, the floor is trusted in part, so that what is
   asked rises to that without a jump (:func:`share_needed`).
2. *Significance*: the batch-means Diebold–Mariano statistic ``z >= min_z`` (3), or the
   Wilcoxon signed-rank test of the batch means gives ``p < sign_p / K`` (Bonferroni over the
   ``K`` candidates tested in the round).
3. *Fold agreement*: with cross-fitting, each nonlinear parameter's coefficient of variation
   across the folds is below ``max_param_cv`` (30 %).
4. *A further effect earns its place* (:func:`earns_place`): once effects are accepted, a
   candidate that passes 1-3 on the test rows must pass 1-2 again on blocked cross-fitted
   training blocks alone (the model holding the accepted effects and that model plus the
   candidate refitted without each block, the candidate's nonlinear parameters kept): the
   test rows have already been used to choose the effects before it.
5. *Transport look-alikes* (:func:`split_supports_transport`): a delay or a lag acts on the
   whole output slope, the reversible (``r = 0``) part included. When rate-dependent
   hysteresis is testable too, a delay or lag is named only if the residual's regression on
   the reversible and hysteretic slopes gives the reversible one at least
   ``min_rev_share`` (15 %) of the hysteretic coefficient, with the same sign (notes §4.1:
   about 1 for a delay or lag before the refit, about 0 for rate-dependent thresholds).
6. *Effects that hide each other* (:func:`core.diagnosis.judge.lookahead`): when nothing passes, the
   largest candidate that failed significance alone is put in tentatively; if another
   effect passes on top of it (rules 1-5, 7), the first is judged again on top of that one and
   accepted when it passes there.
7. *Creep follows the step sign* (:func:`trend_follows_steps`): creep is named only when the
   residual trend after the holds follows the sign of the step before them in at least
   ``min_sign_locking`` (80 %) of the holds (with at least 4 holds); a drift continues
   across steps whatever their sign (about half follow it; notes §4.2).
8. *Only what generalises* (:func:`generalises`): see there.
9. *A stage without its signature yields* (:func:`yields_to_lookalike`): an output dynamics
   stage whose fitted values lack its own signature (a mode too damped to ring) is not
   named when a look-alike that shows its own leaves at most ``lacks_signature_margin``
   (10 %) more held-out MSE, even when the small difference is significant: what the stage
   adds over the look-alike does not come from its own mechanism.
10. *Look-alikes not clearly beaten stay open* (:func:`clearly_better`): once an output
    dynamics stage is named, a look-alike stage refitted on the same structure (every
    accepted effect besides the stage) is reported ambiguous with it unless the named one
    predicts the held-out rows significantly better **and** the look-alike leaves more
    than ``clear_margin`` (10 %) more held-out MSE: a significant but small difference
    decides nothing when other effects (creep, drift) shape the residual too.
11. *Two stages in series* (:func:`pair_beats_single`): a pair of output stages the
    registry lets act in series (a lag then a mode), fitted jointly on the same structure,
    that predicts the held-out rows better than the named single stage by the effect size
    and significance of rules 1-2 (its stages each showing their own signature) keeps its
    members from being ruled out: they are reported ambiguous with the named stage.
12. *A second stage in series is named* (:func:`second_stage_named`): both stages of such a
    pair are named (and the single stage replaced by them) only when rule 11 holds, each
    stage shows its own signature in the pair (rule 9, and
    :attr:`~core.diagnosis.registry.OutputDynamics.lacks_signature_in_series`: a lag whose
    corner lies far above the mode, or below half a sample, is not one), and for each stage
    the pair beats the *other* stage alone, re-optimised alone with the optimiser budget
    the pair had, by the effect size and significance of rules 1-2 on the held-out rows
    (where the pair changes the prediction most) **and** on cross-fitted training blocks
    (rule 4: the held-out rows already chose the first stage). A stage gets credit only
    for what it adds, not for the refit of the other stage's parameters it came with.
13. *Judged where it lives, harmless elsewhere* (:func:`harmless_elsewhere`): an effect
    that declares the rows its signature lives in
    (:attr:`~core.diagnosis.registry.DiagnosableEffect.signature`: a drift, from cycle to
    cycle of a repeated input) meets rules 1-2 on the test rows among them (the excess over
    the noise floor is theirs too, but see rule 19; where they are compared with an earlier
    row the floor is twice the noise variance, :func:`floor_mse`), and must not make the
    other test rows
    worse by more than ``max_harm_elsewhere`` (5 %) with a Diebold-Mariano z of ``-min_z``
    or below.

14. *Several events for a dynamic name* (:func:`enough_events`): with one recording, an
    output dynamics stage (delay, lag, mode) is named only when it lowers the MSE by
    ``min_gain`` in at least ``min_events`` (3) of the windows from one input event (step,
    reversal) to the next (:mod:`core.diagnosis.events`), each window held out in turn (the
    model with and without the stage refitted on the training rows outside it): a
    signature seen after one step, or in the first loading from rest only, is suggestive,
    not a name.

15. *Look-alike stages told apart by their own signatures* (:func:`signatures_separable`):
    a dead time shows no response after a step, a lag an immediate smooth one, a mode its
    ringing; across excitation rates a lag's phase saturates while a delay's grows. When
    the recordings hold fewer than ``min_events`` steps and one excitation rate (slowest
    over fastest time between reversals below ``min_rate_ratio``), a look-alike of the
    named delay / lag / mode stays open (ambiguous, with the deciding experiment) however
    the held-out MSE compares: the difference then comes from how each absorbs the base's
    misfit, not from its mechanism.

17. *Time earned against history* (:func:`beyond_history_ok`): a name that says the output
    changes with time (drift, creep, an initial memory) or with rate is accepted only when
    the candidate still lowers the held-out MSE by ``min_gain``, significantly, once each
    residual's part that depends on the input's state and history alone (its value,
    direction and last two reversals, the first loading from rest apart; pooled over the
    recordings, :mod:`core.diagnosis.history`) is removed. A rate-independent plant whose
    loops the base cannot follow leaves a misfit that changes with the input's history,
    which under a decaying or growing excitation changes with time as well; what a time
    name adds must show where the input revisits a state with the same history (cycle to
    cycle, along a hold, across first loadings from rest) or, for rate, the same loop at
    other rates.

18. *The look-alike named first is the one the steps show* (:mod:`core.diagnosis.eventresponse`):
    when rule 15 keeps delay, lag and mode open (one recording, fewer than ``min_events``
    steps, one rate) and every input step, judged on its own rows, shows one kind (a dead
    time, an immediate smooth response, a ringing) that predicts the step's fast part
    better than each other kind by :data:`~core.diagnosis.eventresponse.Z_ONE_SIDED`
    standard deviations (first differences, against the colour of the noise where the
    input rests before the step; on the rows each kind was fitted on, so an in-sample
    ordering of look-alikes that stay open, not a held-out test), and its parameters show
    its own signature (rule 9), that kind is the one named, with the others still
    ambiguous; the finding says which events the evidence came from. A step never makes
    a dynamic name by itself: with fewer than ``min_events`` events it is suggestive, and
    nothing is named when rules 1-16 name no output dynamics. Then, with fewer than
    ``min_events`` steps all showing one kind, that kind is reported as suggestive, not
    claimed, with its values fitted on the steps, the steps it was seen after and the
    experiment that would decide (more input steps).

19. *A local effect is not measured against what does not repeat* (:func:`harmless_beyond_noise`):
    an effect judged on the test rows its signature lives in (rule 13) needs ``min_gain``
    and significance there, but not ``min_excess_share`` of their excess, when the other
    test rows show it harmless, an equivalence test: on at least
    ``min_independent_batches`` (10) independent batches, the one-sided
    ``1 - equivalence_p`` (95 %) upper confidence bound of their MSE rise
    (:func:`harm_bound`) is at most ``max_harm_elsewhere`` (5 %). Not significantly worse
    is not enough: with few batches anything passes that. The finding's evidence says
    which rows it was judged on, the bound, and that the share was waived.

The statistics come from :func:`core.diagnosis.stats.heldout_comparison`; which rows they are
computed on (test rows, cross-fitted training blocks) is the engine's business.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass

import numpy as np

from .stats import HeldOut

__all__ = ["RULE", "AcceptRule", "Decision", "beyond_history_ok", "clearly_better", "decide",
           "earns_place", "enough_events", "floor_mse", "generalises", "harm_bound",
           "harm_words", "harmless_beyond_noise",
           "harmless_elsewhere", "pair_beats_single",
           "second_stage_named", "share_needed", "signatures_separable", "size_ok",
           "split_supports_transport",
           "trend_follows_steps", "yields_to_lookalike"]


@dataclass(frozen=True)
class AcceptRule:
    """Thresholds of the acceptance rules (documented in the JSON output).

    Attributes
    ----------
    min_gain : float
        Smallest relative held-out MSE reduction.
    min_excess_share : float
        Smallest share of the excess MSE over the noise floor that must be removed. Where
        the excess is not positive the floor estimate is contradicted (any significant
        reduction goes below it) and the share is counted over the rows' whole MSE, the
        floor taken as unknown. Between the two, continuously: ``min_gain`` is the smallest
        reduction, as a share of the rows' MSE, that counts at all, so where the floor leaves
        less than ``min_gain`` of the MSE to explain, every reduction that counts removes
        more than the whole excess, which a right floor forbids, and the smaller the excess
        the more the floor is in doubt. There the floor is counted with the weight
        ``excess / (min_gain * MSE)``: whole where the excess is ``min_gain`` of the MSE
        (a reduction of ``min_gain`` removes exactly the excess), none where it is 0 (the
        share is then ``min_excess_share`` of the whole MSE, as beyond). Before, the floor
        was whole down to an excess of 0, so that only ``min_gain`` was asked there, and
        the share jumped to ``min_excess_share`` of the MSE at 0 (:func:`share_needed`).
    min_z : float
        Diebold–Mariano z that suffices on its own.
    sign_p : float
        Signed-rank level before the Bonferroni division by the number of candidates.
    family_margin : float
        A look-alike within this relative margin of the winner's gain is ambiguous.
    max_param_cv : float
        Largest coefficient of variation of a nonlinear parameter across folds.
    outside_worse : float
        RMS ratio on the rows outside train/test above which a caveat is printed.
    min_rev_share : float
        Smallest ratio of the reversible to the hysteretic rate coefficient of the residual
        for a delay or a lag while rate-dependent hysteresis is testable.
    min_sign_locking : float
        Smallest share of holds whose residual trend follows the preceding step's sign, for
        creep.
    max_loro_loss : float
        With several recordings (no windows), largest relative worsening of the
        leave-one-recording-out MSE an accepted effect may cause; beyond it the effect is
        recording-specific, not physics (:func:`generalises`).
    lacks_signature_margin : float
        Largest relative excess of held-out MSE with which a look-alike that shows its own
        signature is named instead of an output stage whose fitted values lack theirs
        (:func:`yields_to_lookalike`).
    clear_margin : float
        Smallest relative excess of held-out MSE a look-alike output stage must leave, besides
        a significant difference, to be ruled out against the named one
        (:func:`clearly_better`).
    max_harm_elsewhere : float
        Largest relative increase of the held-out MSE outside the rows where an effect's
        signature lives that it may cause while judged on those rows (:func:`harmless_elsewhere`);
        for rule 19 (:func:`harmless_beyond_noise`) the equivalence margin its upper
        confidence bound must stay below.
    min_independent_batches : int
        Fewest independent batches (:attr:`~core.diagnosis.stats.HeldOut.n_independent`) of
        the other test rows that can show an effect harmless there (rule 19).
    equivalence_p : float
        Level of the one-sided upper confidence bound of the MSE rise on the other test rows
        (rule 19, :func:`harm_bound`).
    min_events : int
        With one recording, fewest input events (steps, reversals) after which an output
        dynamics stage must lower the held-out MSE by ``min_gain`` to be named
        (:func:`enough_events`).
    min_rate_ratio : float
        Smallest ratio of the slowest to the fastest excitation (time between reversals)
        that separates output dynamics look-alikes by their own signatures without
        ``min_events`` steps (:func:`signatures_separable`).
    family_lead : float
        A candidate of a later family (:data:`core.diagnosis.specs.FAMILY_PRIORITY`) is
        chosen over the leading passing family's best only with this many times its
        held-out MSE reduction (and is deferred without cross-fitting when it cannot reach
        that).
    resolution_gain, resolution_z : float
        Once an effect is in, the play grid is doubled while the held-out MSE falls by
        ``resolution_gain`` with a Diebold-Mariano z of ``resolution_z`` (or a signed-rank
        p below ``sign_p``): a choice of resolution, not a claim, hence the lower bar. The
        baseline's own grid (before any effect) is doubled by ``resolution_gain`` alone.
    """

    min_gain: float = 0.05
    min_excess_share: float = 0.20
    min_z: float = 3.0
    sign_p: float = 0.01
    family_margin: float = 0.10
    max_param_cv: float = 0.30
    outside_worse: float = 1.25
    min_rev_share: float = 0.15
    min_sign_locking: float = 0.80
    max_loro_loss: float = 0.05
    lacks_signature_margin: float = 0.10
    clear_margin: float = 0.10
    max_harm_elsewhere: float = 0.05
    min_independent_batches: int = 10
    equivalence_p: float = 0.05
    min_events: int = 3
    min_rate_ratio: float = 3.0
    family_lead: float = 1.5
    resolution_gain: float = 0.02
    resolution_z: float = 2.0

    def as_dict(self) -> dict[str, float]:
        """The thresholds by name."""
        return asdict(self)


#: The rule the engine uses.
RULE = AcceptRule()


@dataclass(frozen=True)
class Decision:
    """Outcome of :func:`decide` for one candidate.

    Attributes
    ----------
    passes : bool
        Every rule holds.
    size_ok, significant, stable : bool
        Effect-size rules; significance (DM or Bonferroni signed-rank); fold agreement.
    reasons : tuple of str
        Why it failed, in words (empty when it passes).
    """

    passes: bool
    size_ok: bool
    significant: bool
    stable: bool
    reasons: tuple[str, ...]


def enough_events(event_gains: list[float], rule: AcceptRule = RULE) -> bool:
    """Acceptance rule 14: at least ``min_events`` of the per-event relative MSE reductions
    ``event_gains`` (one per event window with enough test rows) reach ``min_gain``."""
    return sum(1 for g in event_gains if np.isfinite(g) and g >= rule.min_gain) >= (
        rule.min_events)


def signatures_separable(steps: int, rate_ratio: float, rule: AcceptRule = RULE) -> bool:
    """Acceptance rule 15: recordings with ``steps`` input steps and excitation rates
    spanning ``rate_ratio`` can tell output dynamics look-alikes apart by their signatures."""
    return steps >= rule.min_events or rate_ratio >= rule.min_rate_ratio


def beyond_loop_shape_ok(beyond: HeldOut, rule: AcceptRule = RULE) -> bool:
    """Acceptance rule 16: with one recording at one excitation rate, does an output dynamics
    stage explain what a rate-independent loop-shape misfit of the base cannot?

    ``beyond``: the current model against the one with the stage, each with its residual's
    loop-shape part (a function of the input, its direction and the last reversal; see
    :func:`~core.diagnosis.lookalikes.beyond_loop_shape`) removed. True when the stage still
    lowers the held-out MSE by ``min_gain``, significantly (DM ``z >= min_z`` or signed-rank
    ``p < sign_p``). At one rate a lag's, a dead time's or a mode's residual is a function of
    where the input is on the loop, as a loop-shape misfit's is (measured on the development
    set's Bouc-Wen slow sine alone: a lag lowered the held-out MSE by 11 %, beyond the loop
    shape by 5.7 % with DM z 1.2 and signed-rank p 0.03); a step, a hold or a second rate
    is what a loop shape cannot follow (the shipped piezo's lag: 19 %, z 4.4).
    """
    return bool(beyond.gain >= rule.min_gain) and _significant(beyond, rule)


def beyond_history_ok(beyond: HeldOut, rule: AcceptRule = RULE) -> bool:
    """Acceptance rule 17: does a time or rate effect explain what a misfit depending on the
    input's state and history alone cannot?

    ``beyond``: the current model against the one with the effect, each with its residual's
    history part (:func:`~core.diagnosis.history.beyond_history`) removed. True when the
    effect still lowers the held-out MSE by ``min_gain``, significantly (DM ``z >= min_z``
    or signed-rank ``p < sign_p``).
    """
    return bool(beyond.gain >= rule.min_gain) and _significant(beyond, rule)


def harmless_elsewhere(h: HeldOut | None, rule: AcceptRule = RULE) -> bool:
    """Acceptance rule 13: the comparison ``h`` on the test rows outside the ones an effect
    was judged on (``None``: there are none) shows no harm: the candidate raises their MSE
    by at most ``max_harm_elsewhere`` or the increase is not significant (DM z above
    ``-min_z``)."""
    if h is None or not np.isfinite(h.gain):
        return True
    return h.gain >= -rule.max_harm_elsewhere or not (np.isfinite(h.z) and h.z <= -rule.min_z)


def harm_bound(h: HeldOut | None, rule: AcceptRule = RULE) -> float:
    """The one-sided ``1 - equivalence_p`` upper confidence bound of the relative MSE rise
    ``mse_after / mse_before - 1`` of the comparison ``h`` (dimensionless; NaN when ``h``
    is ``None`` or has no finite standard error, fewer than two independent batches or no
    MSE before): the rise plus Student's t quantile (``n_independent - 1`` degrees of
    freedom) times the batch-means standard error of the MSE difference over
    ``mse_before``."""
    from scipy.stats import t as student_t

    if h is None or not (np.isfinite(h.gain) and np.isfinite(h.se)
                         and np.isfinite(h.n_independent)) or not (
            h.n_independent >= 2.0 and h.mse_before > 0.0):
        return float("nan")
    q = float(student_t.ppf(1.0 - rule.equivalence_p, h.n_independent - 1.0))
    return float(-h.gain + q * h.se / h.mse_before)


def harmless_beyond_noise(h: HeldOut | None, rule: AcceptRule = RULE) -> bool:
    """Acceptance rule 19: does the comparison ``h`` on the test rows outside an effect's
    signature rows show that the effect is harmless there (an equivalence test)?

    True when those rows exist (``h`` is not ``None``), hold at least
    ``min_independent_batches`` independent batches (:attr:`HeldOut.n_independent`: batch
    means correlated from batch to batch count as fewer), and the one-sided
    ``1 - equivalence_p`` upper confidence bound of their MSE rise (:func:`harm_bound`) is at
    most ``max_harm_elsewhere`` (5 %): the data bound the harm below the margin, rather than
    merely failing to show it (a "not significantly worse" test passes anything with few
    batches). It is what replaces the excess share for an effect judged where it lives
    (:func:`size_ok`). An effect that is really local (a trend from cycle to cycle, ringing
    after a step) changes the other rows' prediction by about nothing, and their held-out
    error then moves by sampling noise only, which enough batches bound; a candidate that
    buys its gain on the signature rows by bending the rest (absorbing the base misfit)
    raises the bound above the margin. With no other test rows, or too few batches,
    nothing shows harmlessness and the excess share applies.
    """
    if h is None or not (np.isfinite(h.n_independent)
                         and h.n_independent >= rule.min_independent_batches):
        return False
    b = harm_bound(h, rule)
    return bool(np.isfinite(b) and b <= rule.max_harm_elsewhere)


def floor_mse(noise: float, factor: float = 1.0) -> float:
    """The white-noise floor of the MSE the excess share is counted above (output units²).

    ``noise``: the white-noise level (output units, RMS; the one estimate of
    :func:`~core.diagnosis.stats.noise_floor`). ``factor``: the white-noise variance of a
    compared value in units of one row's
    (:attr:`~core.diagnosis.registry.SignatureRows.noise_factor`): 1 for rows as they are;
    2 for rows compared as each row's change from an earlier row
    (:attr:`~core.diagnosis.registry.SignatureRows.previous`), ``e[t] - e[previous[t]]``,
    where the noise of both rows enters (independent, far apart); ``2 / block`` for changes
    between means of ``block`` rows. With the floor counted once on changes, the excess
    held one noise variance that no effect can remove, and the 20 % share asked the effect
    to remove a fifth of it too.
    """
    return factor * noise**2


def share_needed(h: HeldOut, excess: float | None, rule: AcceptRule = RULE) -> float:
    """The MSE reduction (output units²) the excess share asks of the candidate compared in
    ``h``: ``min_excess_share`` of ``excess``, the evidence rows' MSE over the noise floor
    (:func:`floor_mse`); ``None``: no share is asked (0).

    Where ``excess`` is not positive, the noise level estimated for those rows is at or
    above their whole MSE: by that estimate nothing is left to explain beyond noise, and any
    reduction would meet a share of it. A candidate that lowers their held-out MSE
    significantly shows the estimate too high there (an overestimated noise level: a
    recording's quantisation or chatter counted as noise), so the estimate says nothing
    about how much of the error is left to explain; the share is then counted over the rows'
    whole MSE (``h.mse_before``; the floor taken as unknown, zero), not met by any reduction.

    Where ``excess`` is positive but below ``min_gain`` of ``h.mse_before`` (``q = excess /
    mse_before < min_gain``), a reduction that meets ``min_gain`` removes more than the
    whole excess the floor leaves, so the floor is in doubt too, the more the smaller
    ``q``: it is counted with the weight ``q / min_gain``, and the share is
    ``min_excess_share * (mse_before - (q / min_gain) * (mse_before - excess))``, the share
    of the excess at ``q = min_gain`` and of the whole MSE at ``q = 0``, continuous in the
    excess (see :attr:`AcceptRule.min_excess_share`). With ``min_gain`` (also required),
    the reduction asked rises from 5 % of the MSE at ``q`` about 0.04 to 20 % at 0.
    """
    if excess is None:
        return 0.0
    m = h.mse_before
    if excess <= 0.0:
        return rule.min_excess_share * m
    if excess >= rule.min_gain * m or not m > 0.0:
        return rule.min_excess_share * excess
    weight = excess / (rule.min_gain * m)
    return rule.min_excess_share * (m - weight * (m - excess))


def size_ok(h: HeldOut, excess: float | None, rule: AcceptRule = RULE,
            elsewhere: HeldOut | None = None) -> bool:
    """Effect-size rules only (``excess``: current MSE minus the noise floor², units²;
    ``None``: no excess share asked, :func:`share_needed`).

    ``elsewhere``: for a candidate judged on the test rows its signature lives in (``h``
    on those rows), the comparison on the other test rows. When it shows the candidate
    harmless there (:func:`harmless_beyond_noise`, rule 19) the excess share is not
    required: the excess on the signature rows is then what the model leaves there that does
    not repeat from one branch to the next, which a local effect cannot remove however real
    it is (a friction damper's chatter, 3 % of range, against a drift judged from cycle to
    cycle), so only ``min_gain`` applies there. On rows compared with an earlier branch
    (``SignatureRows.previous``) the noise enters twice, and the floor the excess is
    counted above is twice the noise variance there (:func:`floor_mse`).
    """
    if h.gain < rule.min_gain:
        return False
    return harmless_beyond_noise(elsewhere, rule) or (
        h.mse_before - h.mse_after) >= share_needed(h, excess, rule)


def decide(
    h: HeldOut,
    excess: float | None,
    n_tests: int,
    param_cv: Mapping[str, float] | None = None,
    rule: AcceptRule = RULE,
    significance: HeldOut | None = None,
    elsewhere: HeldOut | None = None,
) -> Decision:
    """Apply every acceptance rule to the held-out comparison ``h`` of one candidate.

    Parameters
    ----------
    h : HeldOut
        Current model vs the candidate on the evidence rows.
    excess : float or None
        Current MSE minus the white-noise floor squared (output units²); ``None``: no
        excess share is asked (:func:`share_needed`).
    n_tests : int
        Candidates tested in the round (Bonferroni divisor), ``>= 1``.
    param_cv : mapping of str to float, optional
        Coefficient of variation of each nonlinear parameter across cross-fitting folds.
    rule : AcceptRule
    significance : HeldOut, optional
        Comparison for the significance rule when it differs from ``h`` (test rows pooled
        with cross-fitted blocks); the effect-size rules always use ``h``.
    elsewhere : HeldOut, optional
        For a candidate judged on its signature rows, the comparison on the other test rows
        (:func:`size_ok`: harmless there, the excess share is not required).

    Returns
    -------
    Decision
    """
    reasons = []
    sz = size_ok(h, excess, rule, elsewhere)
    if h.gain < rule.min_gain:
        reasons.append(f"MSE reduction {100 * h.gain:.1f} % < {100 * rule.min_gain:.0f} %")
    elif not sz:
        why = (f"removes less than {100 * rule.min_excess_share:.0f} % of the excess over "
               "the noise floor")
        if excess is not None and excess <= 0.0:
            why = (f"removes less than {100 * rule.min_excess_share:.0f} % of these rows' "
                   "mean squared error (the noise level estimated for them is at or above "
                   "that error, so it cannot say how much of it is left to explain)")
        elif excess is not None and excess < rule.min_gain * h.mse_before:
            why = (f"removes less than {100 * share_needed(h, excess, rule) / h.mse_before:.1f}"
                   " % of these rows' mean squared error (the noise level estimated for "
                   f"them leaves only {100 * excess / h.mse_before:.1f} % of that error to "
                   f"explain, less than the {100 * rule.min_gain:.0f} % any reduction must "
                   "remove, so it is trusted only in part)")
        if elsewhere is not None and np.isfinite(elsewhere.gain):
            why += f" (not waived: {harm_words(elsewhere, rule)})"
        reasons.append(why)
    g = h if significance is None else significance
    level = rule.sign_p / max(int(n_tests), 1)
    sig = g.z >= rule.min_z or g.sign_p < level
    if not sig:
        reasons.append(f"not significant (z = {g.z:.2f} < {rule.min_z:g} and signed-rank "
                       f"p = {g.sign_p:.2g} >= {level:.2g})")
    unstable = {k: v for k, v in (param_cv or {}).items() if not v < rule.max_param_cv}
    if unstable:
        reasons.append("parameters disagree across folds (" + ", ".join(
            f"{k} CV {100 * v:.0f} %" for k, v in unstable.items()) + ")")
    return Decision(sz and sig and not unstable, sz, sig, not unstable, tuple(reasons))


def harm_words(h: HeldOut, rule: AcceptRule = RULE) -> str:
    """What the comparison ``h`` on the other test rows shows for rule 19, in words: the
    relative held-out MSE change and its upper confidence bound (:func:`harm_bound`)."""
    b = harm_bound(h, rule)
    words = f"on the other test rows its held-out MSE changes by {-100 * h.gain:+.1f} %"
    if not np.isfinite(b):
        return words + ", with no confidence bound"
    words += (f", its upper {100 * (1 - rule.equivalence_p):.0f} % confidence bound "
              f"{100 * b:+.1f} % over {h.n_independent:.0f} independent batches")
    if h.n_independent < rule.min_independent_batches:
        words += f" (fewer than {rule.min_independent_batches})"
    return words


def earns_place(crossfitted: HeldOut, n_tests: int, param_cv: Mapping[str, float] | None,
                accepted: tuple[str, ...], rule: AcceptRule = RULE) -> Decision:
    """Rule 4: a further effect, judged on cross-fitted training blocks alone.

    Parameters
    ----------
    crossfitted : HeldOut
        The model holding the ``accepted`` effects against it plus the candidate, both
        refitted without each block, pooled over the blocks.
    n_tests : int
        Candidates tested in the round (Bonferroni divisor).
    param_cv : mapping, optional
        Coefficient of variation of each nonlinear parameter across the folds.
    accepted : tuple of str
        Effects already in the model (for the reason text).

    Returns
    -------
    Decision
        The effect-size rules use no excess share (the blocks' noise floor is not known
        separately); the reasons say it was a further effect that did not earn its place.
    """
    d = decide(crossfitted, None, n_tests, param_cv, rule)
    if d.passes:
        return d
    why = (f"as a further effect on top of {', '.join(accepted)} it is not confirmed on "
           "cross-fitted training blocks: ")
    return Decision(False, d.size_ok, d.significant, d.stable, (why + "; ".join(d.reasons),))


def split_supports_transport(a_rev_s: float, a_hys_s: float, rule: AcceptRule = RULE) -> bool:
    """Rule 5: does the residual lag on the reversible slope as a delay or lag would?

    ``a_rev_s``, ``a_hys_s``: coefficients (s) of the residual regressed on the reversible
    slope ``p0 du/dt`` and on the hysteretic slope (the rest of the model's output rate),
    the base model partialled out. True when ``a_rev_s / a_hys_s >= min_rev_share``
    (same sign); a residual that does not load on the reversible slope points to
    rate-dependent hysteresis instead.
    """
    if not (np.isfinite(a_rev_s) and np.isfinite(a_hys_s)) or a_hys_s == 0.0:
        return True  # no hysteretic rate term to compare with: nothing contradicts it
    return a_rev_s / a_hys_s >= rule.min_rev_share


def generalises(loro_mse_reduction: float | None, rule: AcceptRule = RULE) -> bool:
    """Rule 8: an accepted effect must not make the prediction of unseen recordings worse:
    its leave-one-recording-out MSE reduction (each recording predicted by the structure
    refitted on the others, with and without the effect) is at least ``-max_loro_loss``.
    ``None`` (one recording, or explicit windows) cannot contradict it."""
    return loro_mse_reduction is None or loro_mse_reduction >= -rule.max_loro_loss


def trend_follows_steps(share: float | None, holds: int, rule: AcceptRule = RULE) -> bool:
    """Rule 7: ``share`` of the ``holds`` (>= 0.5 s after a step) whose residual trend in
    log time has the sign of the step before it. Creep is supported when the share is at
    least ``min_sign_locking``; with fewer than 4 holds nothing contradicts it (measured on
    the benchmark: 0.9-1.0 for hidden creep, 0.5-0.7 for hidden drift, 10 holds)."""
    if share is None or holds < 4:
        return True
    return share >= rule.min_sign_locking


def yields_to_lookalike(mse_lacking: float, mse_lookalike: float, rule: AcceptRule = RULE
                        ) -> bool:
    """Rule 9: does an output stage whose fitted values lack its own signature (a mode too
    damped to ring, damping >= 1/2) yield to a look-alike that shows its own?

    ``mse_lacking``, ``mse_lookalike``: their held-out MSE (output units²). True when the
    look-alike leaves at most ``lacks_signature_margin`` more: the rest of what the stage
    explains is a low-pass shape, not the mechanism its name claims (measured on the
    Maxwell-slip actuator with a 0.125 ms delay: a "resonance" at 1.76 kHz with damping
    0.69 left 0.5 % less held-out MSE than the delay, signed-rank p 0.003).
    """
    return bool(np.isfinite(mse_lookalike)) and (
        mse_lookalike <= (1.0 + rule.lacks_signature_margin) * mse_lacking)


def _significant(h: HeldOut, rule: AcceptRule) -> bool:
    """Diebold-Mariano ``z >= min_z`` or signed-rank ``p < sign_p`` (no Bonferroni)."""
    return bool(h.z >= rule.min_z or h.sign_p < rule.sign_p)


def clearly_better(named_vs_other: HeldOut, rule: AcceptRule = RULE) -> bool:
    """Rule 10: is the named output stage clearly better than a look-alike stage?

    ``named_vs_other``: the look-alike (before) against the named stage (after) on the
    held-out rows, both fitted on the same structure. True when the named stage is
    significantly better (DM ``z >= min_z`` or signed-rank ``p < sign_p``) and the
    look-alike leaves more than ``clear_margin`` more held-out MSE than it; otherwise the
    look-alike is reported ambiguous with it (measured on the B-PI plant with a 0.1 ms
    delay, creep and drift: a lag named with DM z 3.1 over the delay, both within a few
    per cent of each other's held-out MSE).
    """
    h = named_vs_other
    return _significant(h, rule) and h.mse_before > (1.0 + rule.clear_margin) * h.mse_after


def pair_beats_single(single_vs_pair: HeldOut, rule: AcceptRule = RULE) -> bool:
    """Rule 11: do two output stages in series predict the held-out rows better than the
    named single stage?

    ``single_vs_pair``: the single stage (before) against the pair (after), both fitted on
    the same structure. True when the pair reduces the held-out MSE by at least
    ``min_gain`` and significantly (DM ``z >= min_z`` or signed-rank ``p < sign_p``)
    (measured on a Bouc-Wen actuator with a 1 ms lag and a 200 Hz mode: a single 1.1 ms
    delay was named, and neither the lag nor the mode was ruled out by it).
    """
    h = single_vs_pair
    return bool(h.gain >= rule.min_gain) and _significant(h, rule)


def second_stage_named(alone_vs_pair: HeldOut, alone_vs_pair_blocks: HeldOut,
                       rule: AcceptRule = RULE) -> bool:
    """Rule 12: does a stage of a pair in series earn its name over the other stage alone?

    ``alone_vs_pair``: the other stage alone, re-optimised alone (before), against the pair
    (after) on the held-out rows (where the two differ most); ``alone_vs_pair_blocks``: the
    same on cross-fitted training blocks. True when both reduce the MSE by at least
    ``min_gain`` significantly (DM ``z >= min_z`` or signed-rank ``p < sign_p``) (measured
    on a Bouc-Wen actuator with a 568 Hz mode and no lag: the pair, with a 2.9 us "lag",
    leaves 26 % less held-out MSE than the mode as first fitted (DM z 10.2), but 0.3 % more
    than the mode re-optimised alone: the joint refit of the mode took the credit).
    """
    return pair_beats_single(alone_vs_pair, rule) and pair_beats_single(alone_vs_pair_blocks,
                                                                        rule)
