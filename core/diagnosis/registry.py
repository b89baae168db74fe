"""The registry of diagnosable effects: each effect declares itself once.

An effect is one :class:`DiagnosableEffect` registered with :func:`register` by its own module
in :mod:`core.diagnosis.effects`: what it is (family, explanation, equation, the experiment
that makes it testable), the model class of the stage it adds, how it is searched (the
candidate builder), which :class:`~core.diagnosis.structure.Structure` field switches it on,
when the recordings cannot test it and what it looks like then, for output dynamics the
stage's parameters, model and transfer function, and for a static effect its linear terms
(:class:`StaticTerm`: its columns, their bounds, its coefficients and the stage it adds; the
numpy.polynomial idiom, each family brings its own functions). The engine, the structure fit,
the reports and the untestable rules read this registry; none of them names an effect.

Adding an effect: write ``core/diagnosis/effects/NAME.py`` with its builder and one
``register(DiagnosableEffect(...))``, import it in ``core/diagnosis/effects/__init__.py``
(the order there is the order the effects are tried in), and test it
(``docs/pages/architecture.md`` has the recipe).

This module imports nothing from the diagnosis, so every other module may import it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ..base import Model
    from ..recordings import Recording

__all__ = ["EFFECTS", "DiagnosableEffect", "OutputDynamics", "SignatureRows", "StaticTerm",
           "TermFit", "TermRows",
           "dynamics_of", "effect", "output_dynamics", "parameter_words", "rate_effect",
           "register", "stage_pairs", "static_terms", "term_of"]


@dataclass(frozen=True)
class OutputDynamics:
    """An output dynamics stage: the structure holds it as ``(name, *values)``.

    Attributes
    ----------
    params : tuple of str
        Parameter names, in the order of the values after the name.
    model : callable
        ``model(values) -> Model``: the :mod:`core.stages` stage.
    transfer : callable or None
        ``transfer(values) -> (num, den)``: continuous-time transfer function coefficients
        (highest power first), discretised by first-order hold; ``None`` for a pure
        (fractional) transport delay whose only value is the delay (s).
    valid : callable
        ``valid(values, dt) -> bool``: the values the search may take at sample spacing
        ``dt`` (s).
    lacks_signature : callable or None
        ``lacks_signature(values) -> reason or None``: why fitted values do not show the
        stage's own signature (a mode too damped to ring acts only as a delay), so that a
        look-alike the recordings do not separate from it is named instead
        (:func:`core.diagnosis.recheck.recheck_dynamics`); ``None``: always shows it.
    combines_with : tuple of str
        Output dynamics stages of another kind that may follow this one in series (a lag
        then a mode): the look-alike recheck also fits the pair jointly, and a pair that
        predicts the held-out rows clearly better than the single stage named keeps its
        members from being ruled out (:func:`stage_pairs`).
    lacks_signature_in_series : callable or None
        ``lacks_signature_in_series(values, other_values, dt) -> reason or None``: why the
        fitted values of this stage, in series with the stage it combines with (that stage's
        values ``other_values``; sample period ``dt`` in s), do not show the stage's own
        signature, so that it is not named as a second stage (acceptance rule 12);
        ``None``: no condition beyond :attr:`lacks_signature`.
    """

    params: tuple[str, ...]
    model: Callable[[tuple[float, ...]], Model]
    transfer: Callable[[tuple[float, ...]], tuple[list[float], list[float]]] | None = None
    valid: Callable[[tuple[float, ...], float], bool] = lambda values, dt: True
    lacks_signature: Callable[[tuple[float, ...]], str | None] | None = None
    combines_with: tuple[str, ...] = ()
    lacks_signature_in_series: Callable[[tuple[float, ...], tuple[float, ...], float],
                                        str | None] | None = None


@dataclass(frozen=True)
class TermFit:
    """What every static term of one structure fit shares.

    Attributes
    ----------
    n_records : int
        Number of recordings fitted together.
    center, scale : float
        Centre and half range of the measured output on the training rows (output units):
        an output map's normalised coordinate is ``(x - center) / scale``.
    """

    n_records: int
    center: float
    scale: float


@dataclass(frozen=True)
class TermRows:
    """What a static term's columns are formed from, for one recording.

    Attributes
    ----------
    record : Recording
        The recording (``t``, ``u``, ``dt``).
    k : int
        Its index among the recordings fitted together.
    rows : ndarray of int, shape (m,)
        The increasing sample indices the weights are solved on.
    x : ndarray, shape (N,), or None
        The PI-stage output (the base states weighted: output units) from sample 0 up to
        the last solved row, for a term that acts before the output dynamics
        (:attr:`StaticTerm.through_dynamics`); ``None`` for the others.
    fit : TermFit
        What the structure fit shares.
    """

    record: Recording
    k: int
    rows: np.ndarray
    x: np.ndarray | None
    fit: TermFit


@dataclass(frozen=True)
class StaticTerm:
    """A static effect's terms: linear in their weights for fixed settings.

    The structure (:class:`~core.diagnosis.structure.Structure`) holds each switched-on
    term's *settings* (a flag, a degree, a bank of time constants) by effect name; the
    structure fit (:func:`~core.diagnosis.structure.fit_structure`) asks every registered
    term for its columns, solves all weights at once, hands each term its slice of the
    solution (:attr:`coefficients`), and :func:`~core.diagnosis.structure.build_model` asks
    it for the :mod:`core.stages` stage the coefficients make. The columns of the terms
    follow the play-bank columns in :attr:`DiagnosableEffect.stage_order` (those acting
    before the output dynamics first), and the stages sit in the chain in that order.

    Attributes
    ----------
    off : object
        The settings of the term switched off (``False``, ``0``, ``()``); a structure holds
        only settings that differ from it.
    width : callable
        ``width(settings, n_records) -> int``: number of columns (0: no columns, no stage).
        A term may have columns when off (the one common bias of the offset term).
    columns : callable
        ``columns(settings, rows: TermRows) -> ndarray``: the columns of one recording.
        Through the output dynamics: shape ``(rows.x.size, width)``, every sample of the
        PI-stage output ``rows.x`` (the structure fit filters them and picks the solved
        rows); otherwise shape ``(rows.rows.size, width)``, on the solved rows.
    coefficients : callable
        ``coefficients(settings, w, fit: TermFit) -> object``: the term's coefficients
        from its slice ``w`` (shape ``(width,)``) of the solved weights; kept in
        :attr:`~core.diagnosis.structure.Fit.terms` under the effect's name.
    stage : callable
        ``stage(settings, coefficients, k, record) -> Model``: the stage of recording ``k``
        in the saved chain.
    lower : float
        Lower bound of every weight of the term (``-inf``: free; unbounded weights of a
        column without solved rows get a tiny ridge).
    through_dynamics : bool
        Acts on the PI-stage output before the output dynamics: the columns read it (they
        are bilinear in the play weights, refreshed from the previous solve) and pass
        through the dynamics.
    sample_spacing : bool
        The columns depend on the sample spacing (a filter): a search is never run on a
        decimated copy of the recordings while the term is on.
    per_recording : bool
        The coefficients differ between recordings (a level): cannot be known for a
        recording the fit never saw.
    level_degree : callable or None
        ``level_degree(settings) -> int``: for a per-recording level, the Legendre degree in
        time of the level a left-out recording gets of its own (0: a constant).
    unseen : callable or None
        ``unseen(settings, coefficients, j) -> coefficients``: the coefficients for
        recording ``j`` when the fit did not see it (its own ones replaced); ``None``: kept.
    bank : bool
        The width grows with the settings (a bank of lags): counted in the training rows a
        recording fitted alone needs; the few weights of the other terms are in a fixed
        allowance (:data:`~core.diagnosis.crossfitting.SPREAD_ROWS_PER_WEIGHT`).
    refit_parameters : callable or None
        ``refit_parameters(settings, coefficients) -> dict``: the parameters reported when
        the term, its settings kept, is re-solved on another base (only its weights move).
    """

    off: Any
    width: Callable[[Any, int], int]
    columns: Callable[[Any, TermRows], np.ndarray]
    coefficients: Callable[[Any, np.ndarray, TermFit], Any]
    stage: Callable[[Any, Any, int, Any], Model]
    lower: float = -np.inf
    through_dynamics: bool = False
    sample_spacing: bool = False
    per_recording: bool = False
    level_degree: Callable[[Any], int] | None = None
    unseen: Callable[[Any, Any, int], Any] | None = None
    bank: bool = False
    refit_parameters: Callable[[Any, Any], dict[str, float]] | None = None


@dataclass(frozen=True)
class SignatureRows:
    """The rows an effect's signature lives in, and how residuals are compared there.

    Attributes
    ----------
    masks : list of ndarray of bool, each of shape (n_samples,)
        One mask per recording: the rows (for a drift, the cycles of a repeated input).
    words : str
        Which rows, for the report ("cycle to cycle after the first (...)").
    previous : list of (ndarray of int, shape (n_samples,)) or None
        Per recording, for every row of its mask, the row one input cycle earlier (the same
        input and input history under a repeated cycle), or the row of an earlier branch
        of the same input history it is paired with (each branch in one pair at most:
        :func:`~core.diagnosis.periodic.same_history`); -1 elsewhere. When given, each
        row's residual is compared as its change from that row's (``e[t] - e[previous[t]]``):
        a rate-independent model repeats itself from cycle to cycle, so its misfit, however
        large, cancels, and what is left is what changed with time (the noise twice).
    block : tuple of int
        With ``previous``, per recording (empty: 1 in each): each compared value is the mean
        of the residual over ``block`` rows ending at the row (``e`` over
        ``t - block + 1 .. t``), against the same mean
        ending at ``previous[t]`` (:func:`~core.diagnosis.effects.creep.hold_signature`:
        inside a hold, a slow change over a block grows with it while the mean's noise
        falls); 1: the rows' own residuals.
    beyond_history : bool
        The rows are compared with rows of the same input history picked from the history
        itself (value, direction, unwiped extrema: :func:`~core.diagnosis.periodic.same_history`),
        so what the comparison finds is already beyond any misfit that depends on the input's
        state and history alone: acceptance rule 17 is met by the evidence and not repeated on
        every test row (where a tapered input's reversal values change with time and the
        history part takes a drift). False from cycle to cycle (rule 17 kept as before).
        True inside the holds after input changes too
        (:func:`~core.diagnosis.effects.creep.hold_signature`): the input's value and
        history do not change along a hold.
    raw_fit : bool
        With ``previous``: the term is solved on the raw training rows with the rest of the
        structure, not on the changes between these rows
        (:func:`~core.diagnosis.changes.changed_terms`): the pairs between branches of the
        same input history cover a short stretch of each recording, and a polynomial in
        time fitted on them is extrapolated to the rows it is judged on.
    """

    masks: list[np.ndarray]
    words: str
    previous: list[np.ndarray] | None = None
    block: tuple[int, ...] = ()
    beyond_history: bool = False
    raw_fit: bool = False

    @property
    def noise_factor(self) -> float:
        """The white-noise variance of a compared value, in units of one row's: 1 for the
        rows' own residuals, 2 for a change between two rows (the noise of both enters),
        ``2 / block`` for a change between two means of ``block`` rows (the mean over the
        compared rows of every recording where the blocks differ)."""
        if self.previous is None:
            return 1.0
        if not self.block:
            return 2.0
        n = np.array([m.sum() for m in self.masks], dtype=np.float64)
        f = 2.0 / np.asarray(self.block, dtype=np.float64)
        return float(f @ n / n.sum()) if n.sum() > 0 else float(f.mean())

    def block_of(self, k: int) -> int:
        """The block (rows) of recording ``k``."""
        return self.block[k] if self.block else 1


@dataclass(frozen=True)
class DiagnosableEffect:
    """Everything the diagnosis knows about one effect.

    Attributes
    ----------
    name : str
        Effect name (the ``--effects`` value, the JSON ``name``).
    family : str
        Look-alike family (``"dynamics"``, ``"slow"``, ``"static"``, ``"static-offset"``,
        ``"memory"``): inside a family the winner must beat the runner-up.
    explanation : str
        The physics in words (SAY).
    equation : str
        What is added to the model (MODEL).
    build : callable
        ``build(ctx, cur) -> (fit, parameters, uncertainty)`` or ``None``: the effect fitted
        on top of the current fit (``None`` when it is already there or does not apply).
    model_type : type
        The :mod:`core` model class of the stage the effect adds to the saved model.
    structure_field : str or None
        The :class:`~core.diagnosis.structure.Structure` field that switches it on
        (``"terms"`` for a static term, :attr:`term`); ``None`` for loop shapes, which are
        part of the hysteresis and never switched off.
    experiment : str or None
        The recording that would make it testable when it is not.
    time_dependent : bool
        Needs a time axis (untestable on index-only recordings).
    between_recordings : bool
        Changes the loop from one excitation rate to the next: with several recordings at
        different rates it is judged by predicting each recording from the others
        (:func:`core.diagnosis.between.between_recordings`).
    amplitude_dependent : bool
        Changes the loop from one input amplitude to the next beyond what the PI's own
        memory does: with several recordings of one amplitude each it is judged by
        predicting each recording from the others.
    lookalikes : tuple of str
        Effects of another family that the recordings may not separate from this one: when
        this effect is chosen, such a candidate that meets the effect-size rules and
        explains nearly as much is reported ambiguous with it.
    untestable : callable or None
        ``untestable(ctx) -> reason, (reason, experiment) or None``: when the recordings of
        ``ctx`` cannot test it (with another experiment than :attr:`experiment` where the
        reason calls for one); ``None``: always testable (time-dependent effects are also
        untestable on recordings without a time axis).
    mimicked_by : tuple or None
        ``(names, why)``: when this effect is untestable, an accepted effect of ``names``
        may be it in disguise; ``why`` (with ``{best}`` for the accepted one) says how.
    partly_tested : callable or None
        ``partly_tested(ctx) -> why or None``: when the effect is testable but its test does
        not reach where the effects of :attr:`mimicked_by` live (creep from cycle to cycle:
        only the settling of its slow lags), why an accepted one of them may still be it in
        disguise (reported as :attr:`mimicked_by` is for an untestable effect).
    before_wipeout : bool
        Its evidence lives before the wipe-out time (the unknown initial memory): judged on
        those rows, never cross-fitted or compared with further effects on the test rows.
    dynamics : OutputDynamics or None
        For output dynamics (delay, lag, resonance): the stage.
    transport : bool
        Acts on the whole output slope, reversible and hysteretic alike (a delay, a lag):
        acceptance rule 5 checks the reversible/hysteretic split before naming it.
    sign_locked : bool
        Follows the sign of the last input step (creep): acceptance rule 7 checks the
        residual trend after the holds.
    inseparable_from : tuple or None
        ``(other, reason, experiment)``: a cause that (u, y) can never separate from this
        effect, reported ambiguous with it whenever it is chosen.
    rate_dependent_hysteresis : bool
        The hysteresis itself changes with the input rate (the rival of a transport effect
        in rule 5).
    linear : bool
        Its parameters are linear weights (one least-squares solve per jackknife fold).
    stage_order : int
        Place of its stage in the saved model's chain (after the hysteresis); effects of
        one ``stage_order`` exclude each other (one output dynamics stage).
    signature : callable or None
        ``signature(ctx) -> SignatureRows or None``: the rows its signature lives in
        (:class:`SignatureRows`: cycles of a repeated input for a drift); its effect size
        and significance are then judged on the test rows among them, and it must not make
        the other test rows worse (:func:`core.diagnosis.search.candidate_evidence`).
        ``None`` (or a ``None`` result): every test row.
    systematic : callable or None
        ``systematic(ctx, cur, fit) -> ({parameter: sigma}, words)``: the uncertainty the
        effect's own discretisation leaves (a creep bank's placement of its time constants),
        added in quadrature to the statistical sigma of the accepted effect ``fit`` (fitted
        on top of ``cur``); ``words`` say how it was obtained.
    deciding : tuple of (str, str)
        ``(other, experiment)``: the experiment that tells this effect from the look-alike
        ``other`` (each pair declared by one of its two effects;
        :data:`core.diagnosis.specs.DECIDING_EXPERIMENT` reads them).
    term : StaticTerm or None
        For a static effect that adds linear terms (asymmetry, creep, drift, offset): its
        columns, bounds, coefficients and stage; ``structure_field`` is then ``"terms"``.
    history_experiment : str or None
        For an effect that claims a change with time or rate (acceptance rule 17,
        :func:`core.diagnosis.history.says_time`): the experiment that would tell it from a
        base that misses the plant's loops, named when the rule refuses it; ``None``: an
        input that revisits its states at other times.
    parameter_words : tuple of (str, str, str)
        ``(parameter, words, unit)`` for the fitted parameters whose names are symbols of
        the code (``a2``): what the value does to the loop, in words, and its unit
        (``"output"``, ``"input"``, ``"1/input"`` for the recording's units, ``""`` for none).
        The findings a person reads (:func:`parameter_words`) say these words instead of
        the name.
    """

    name: str
    family: str
    explanation: str
    equation: str
    build: Callable[[Any, Any], Any]
    model_type: type
    structure_field: str | None
    experiment: str | None = None
    time_dependent: bool = False
    between_recordings: bool = False
    amplitude_dependent: bool = False
    lookalikes: tuple[str, ...] = ()
    untestable: Callable[[Any], str | tuple[str, str] | None] | None = None
    mimicked_by: tuple[frozenset[str], str] | None = None
    partly_tested: Callable[[Any], str | None] | None = None
    before_wipeout: bool = False
    dynamics: OutputDynamics | None = None
    transport: bool = False
    sign_locked: bool = False
    inseparable_from: tuple[str, str, str] | None = None
    rate_dependent_hysteresis: bool = False
    linear: bool = False
    stage_order: int = 0
    signature: Callable[[Any], SignatureRows | None] | None = None
    systematic: Callable[[Any, Any, Any], tuple[dict[str, float], str]] | None = None
    deciding: tuple[tuple[str, str], ...] = ()
    term: StaticTerm | None = None
    history_experiment: str | None = None
    parameter_words: tuple[tuple[str, str, str], ...] = ()


#: Every registered effect by name, in the order they are tried.
EFFECTS: dict[str, DiagnosableEffect] = {}


def register(e: DiagnosableEffect) -> DiagnosableEffect:
    """Add ``e`` to :data:`EFFECTS` (a name may be registered once)."""
    if e.name in EFFECTS:
        raise ValueError(f"effect {e.name!r} is registered twice")
    EFFECTS[e.name] = e
    return e


def effect(name: str) -> DiagnosableEffect:
    """The registered effect ``name``.

    Raises
    ------
    KeyError
        With the known names, when ``name`` is not registered.
    """
    try:
        return EFFECTS[name]
    except KeyError:
        raise KeyError(f"unknown effect {name!r}; known: {', '.join(EFFECTS)}") from None


def parameter_words(name: str, parameter: str) -> tuple[str, str] | None:
    """``(words, unit)`` of the fitted ``parameter`` of effect ``name`` as it declared them
    (:attr:`DiagnosableEffect.parameter_words`); ``None`` when it declared none."""
    e = EFFECTS.get(name)
    for k, words, unit in (e.parameter_words if e is not None else ()):
        if k == parameter:
            return words, unit
    return None


def output_dynamics() -> tuple[str, ...]:
    """Names of the registered output dynamics stages (their look-alikes are re-compared at
    the refined resolution)."""
    return tuple(n for n, e in EFFECTS.items() if e.dynamics is not None)


def stage_pairs() -> tuple[tuple[str, str], ...]:
    """Pairs ``(first, second)`` of output dynamics stages that may act in series
    (:attr:`OutputDynamics.combines_with` of ``first``)."""
    return tuple((n, o) for n, e in EFFECTS.items() if e.dynamics is not None
                 for o in e.dynamics.combines_with)


def rate_effect() -> str:
    """The registered effect whose hysteresis changes with the input rate."""
    return next(n for n, e in EFFECTS.items() if e.rate_dependent_hysteresis)


def static_terms() -> list[tuple[str, StaticTerm, int]]:
    """``(name, term, stage_order)`` of the registered static terms in the order of their
    columns and stages: those acting through the output dynamics first, then by
    :attr:`DiagnosableEffect.stage_order` (registration order among equals)."""
    out = [(n, e.term, e.stage_order) for n, e in EFFECTS.items() if e.term is not None]
    return sorted(out, key=lambda t: (not t[1].through_dynamics, t[2]))


def term_of(name: str) -> StaticTerm:
    """The static term of the registered effect ``name`` (a name a structure holds in its
    ``terms``).

    Raises
    ------
    TypeError
        ``name`` is an output dynamics stage, without a static term.
    """
    term = EFFECTS[name].term
    if term is None:
        raise TypeError(f"the effect {name!r} has no static term")
    return term


def dynamics_of(name: str) -> OutputDynamics:
    """The output dynamics of the registered effect ``name`` (a stage of a structure's
    ``dynamics``).

    Raises
    ------
    TypeError
        ``name`` is a static term, without output dynamics.
    """
    dynamics = EFFECTS[name].dynamics
    if dynamics is None:
        raise TypeError(f"the effect {name!r} has no output dynamics")
    return dynamics
