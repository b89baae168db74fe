"""One fitting entry point: recordings and options in, a typed outcome out.

:func:`fit_recordings` is what ``hyst fit``, the explorer's fit and ``hyst batch fit`` call:
it builds the estimator of a fit kind (:func:`core.models.estimator_class`) with the one
keyword set every estimator takes (``n_operators``, ``constraint``, ``initial_memory``),
turns the time windows into masks, fits, records the warnings the fit raised and builds the
parameter-set document (:class:`core.paramset.ParameterSet`) with the fit report in its
provenance. Reading files and printing are the callers' business.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..exceptions import ParameterError
from ..recordings import Recording
from ..threads import with_thread_limit
from ..warning_filters import FILTERS
from ._data import Prepared, prepare
from .adequacy import Misfit, misfit
from .choice import AUTO, BaseChoice, choose_base
from .extrapolation import Extrapolation, extrapolation
from .orientation import loop_orientation
from .physicsleft import physics_left_sentence
from .steadystate import SteadyStart

if TYPE_CHECKING:
    from ..base import Model
    from ..paramset import ParameterSet
    from .metrics import FitReport

__all__ = ["EmptyWindowError", "FitOutcome", "TimeWindow", "fit_recordings"]

#: ``warnings.catch_warnings`` changes process-wide state (Python < 3.14), so fits in
#: threads of one process take turns recording their warnings; each outcome then holds
#: exactly the warnings of its own fit (the one lock of :mod:`core.warning_filters`).
_WARNINGS_LOCK = FILTERS


class EmptyWindowError(ParameterError):
    """A training or test window selects no sample of any recording.

    Attributes
    ----------
    which : {"train", "test"}
        The window that is empty.
    """

    def __init__(self, which: str, window: TimeWindow) -> None:
        super().__init__(f"the {which} window {window.text} selects no samples; check it "
                         "against the t column")
        self.which = which


@dataclass(frozen=True)
class TimeWindow:
    """The samples with ``start <= t < stop`` (s); either side may be open.

    Parameters
    ----------
    start, stop : float
        Window edges in seconds (``-inf`` / ``inf``: open).
    label : str, optional
        The text the window was given as (``"0:8"``), kept verbatim in the provenance;
        default: formatted from the edges.

    Raises
    ------
    ParameterError
        Unless ``start < stop``.
    """

    start: float = -math.inf
    stop: float = math.inf
    label: str | None = None

    def __post_init__(self) -> None:
        if not float(self.start) < float(self.stop):
            raise ParameterError(f"time window {self.start}:{self.stop}: the start must be "
                                 "smaller than the stop")

    @property
    def text(self) -> str:
        """``label``, else ``"T0:T1"`` with an open side left empty."""
        if self.label is not None:
            return self.label
        edge = [f"{x:g}" if math.isfinite(x) else "" for x in (self.start, self.stop)]
        return ":".join(edge)

    def mask(self, t: np.ndarray) -> np.ndarray:
        """Boolean mask of shape ``t.shape``: ``start <= t < stop`` (``t`` in s)."""
        return (t >= self.start) & (t < self.stop)


@dataclass(frozen=True, eq=False)
class FitOutcome:
    """What :func:`fit_recordings` returns.

    Attributes
    ----------
    kind : str
        The fit kind (one of :func:`core.models.fit_kinds`).
    model : Model
        The estimator's ``full_model_`` (the fitted output offset included; exact
        ``inverse()``), input in the recordings' input unit, output in their output unit.
    report : FitReport
        Training / held-out errors (output units and % of the output range), inverse check,
        solver and model-specific numbers (``report.extra``).
    warnings : tuple of str
        The messages of the warnings the fit raised (e.g. :class:`~core.exceptions.FitWarning`).
    memory_note : str
        What was done about the unknown initial memory (``report.extra["initial_memory"]
        ["summary"]``); empty for kinds that do not report it.
    parameter_set : ParameterSet
        The document ``hyst fit`` writes: the model, the first recording's units and the fit
        provenance (kind, files, recordings, columns, windows, ``n``, report, warnings).
    estimator : object
        The fitted estimator (its other fitted attributes, e.g. ``cv_scores_``).
    """

    kind: str
    model: Model
    report: FitReport
    warnings: tuple[str, ...]
    memory_note: str
    parameter_set: ParameterSet
    estimator: Any

    def summary(self) -> str:
        """The readable fit report (what ``hyst fit`` prints)."""
        return self.report.summary()


def _initial_memory_rule(cls: type, rule: str | None) -> str:
    """``rule``, or for ``None`` ``"exclude"`` where ``cls`` can apply it, else ``"keep"``."""
    if rule is not None:
        return rule
    return "exclude" if "exclude" in cls.initial_memory_rules else "keep"  # type: ignore[attr-defined]


def _masks(recs: Sequence[Recording], window: TimeWindow | None,
           which: str) -> list[np.ndarray]:
    if window is None:
        return []
    masks = [window.mask(r.t) for r in recs]
    if not any(m.any() for m in masks):
        raise EmptyWindowError(which, window)
    return masks


@with_thread_limit
def fit_recordings(
    recordings: Recording | Sequence[Recording],
    kind: str | None = None,
    *,
    n_operators: int | None = None,
    constraint: str | None = None,
    train: TimeWindow | None = None,
    test: TimeWindow | None = None,
    initial_memory: str | None = None,
    files: Sequence[str] | None = None,
    source: str | None = None,
) -> FitOutcome:
    """Fit a model of fit kind ``kind`` to recordings.

    Parameters
    ----------
    recordings : Recording or sequence of Recording
        The recordings (``t`` in s, ``u`` and ``y`` of shape ``(n_samples,)`` each); several
        are fitted jointly, each starting from the relaxed state at its first sample, or,
        in periodic steady state, from the memory its own cycle leaves (the model run over
        a warm-up input first: :class:`core.fitting.steadystate.SteadyStart`; the report's
        ``initial_memory`` says which and how to replay it).
    kind : str, optional
        One of :func:`core.models.fit_kinds` (``hyst fit --model``), or ``"auto"``: the
        base chosen as the diagnosis chooses it (:func:`core.fitting.choice.choose_base`;
        the report's ``base_choice`` says how); default
        :data:`core.models.DEFAULT_FIT_KIND`.
    n_operators : int, optional
        Play operators (thresholds); ``None``: chosen by cross-validation.
    constraint : {"nonnegative", "slopes"}, optional
        Invertibility constraint; ``None``: ``"nonnegative"``.
    train, test : TimeWindow, optional
        Training and held-out samples; without them the estimator holds out the last 20 %
        of every recording.
    initial_memory : {"exclude", "keep"}, optional
        ``"exclude"`` leaves the training rows before the wipe-out time out of the weight
        fit, ``"keep"`` fits them from the relaxed state. ``None`` (``hyst fit``'s default):
        ``"keep"`` when every recording is in periodic steady state (no memory is unknown),
        else ``"exclude"`` for the kinds that can apply it (``estimator.initial_memory_rules``),
        else ``"keep"``.
    files : sequence of str, optional
        File names for the provenance; default: the recordings' names.
    source : str, optional
        The provenance's ``source``; default ``"fit " + files``.

    Returns
    -------
    FitOutcome
        Its report's ``warnings`` hold the fit's warnings and, when the held-out RMSE is
        above 5 white-noise floors, that the model misses structure and where
        (:mod:`core.fitting.adequacy`).

    Raises
    ------
    ParameterError
        An unknown kind, an empty window (:class:`EmptyWindowError`) or a bad option; an
        ``initial_memory`` the kind cannot use raises
        :class:`~core.exceptions.UnsupportedOptionError`.
    """
    from ..models import DEFAULT_FIT_KIND, estimator_class
    from ..paramset import ParameterSet, clean_unit

    recs = [recordings] if isinstance(recordings, Recording) else list(recordings)
    if not recs:
        raise ParameterError("fit_recordings needs at least one recording")
    kind = DEFAULT_FIT_KIND if kind is None else kind
    trains = _masks(recs, train, "train")
    tests = _masks(recs, test, "test")
    start = SteadyStart.of(recs)
    if start.warm:
        # the warm-up rows are neither fitted nor scored: the rows are fixed on the
        # recordings themselves (the default split included), then the warm-up is put before
        trains, tests = start.rows(recs, trains, tests)
    fitted = start.padded(recs)
    choice = None
    if kind == AUTO:
        with _WARNINGS_LOCK:  # its candidate fits silence their warnings (process-wide state)
            choice = choose_base(recs, trains or None, tests or None, n_operators=n_operators,
                                 constraint=constraint)
        kind, constraint = choice.kind, choice.constraint
    cls = estimator_class(kind)
    if initial_memory is None and start.warm and all(w.size for w in start.warm):
        initial_memory = "keep"  # every recording starts from its cycle's memory: none unknown
    est = cls(n_operators=n_operators, constraint=constraint or "nonnegative",
              initial_memory=_initial_memory_rule(cls, initial_memory))
    multi = len(recs) > 1
    rows = _FitRows(None if not trains else trains if multi else trains[0],
                    None if not tests else tests if multi else tests[0])
    ptr, pte = start.pad_masks(trains), start.pad_masks(tests)
    us = [r.u for r in fitted]
    ys = [r.y for r in fitted]
    with _WARNINGS_LOCK, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        est.fit(us if multi else us[0], ys if multi else ys[0],
                train=(ptr if multi else ptr[0]) if ptr else None,
                test=(pte if multi else pte[0]) if pte else None)
    extra, msgs = _notes(est, recs, rows, kind, choice, tuple(str(w.message) for w in caught),
                         start)
    est.report_ = dataclasses.replace(est.report_, extra=extra, warnings=msgs)
    mem = est.report_.extra.get("initial_memory")
    first = recs[0]
    names = [r.name for r in recs] if files is None else list(files)
    # a header's unit that is not a unit (see core.paramset.unit_problem) becomes unknown
    units = {k: clean_unit(first.units.get(k) or d)
             for k, d in (("input", "V"), ("output", "um"), ("time", "s"))}
    fit_info = {
        "model": kind,
        "files": names,
        "recordings": [r.name for r in recs],
        "columns": {k: first.columns.get(k, "") for k in ("time", "input", "output")},
        "train": None if train is None else train.text,
        "test": None if test is None else test.text,
        "n_operators": n_operators,
        "report": est.report_.to_dict(),
        "warnings": list(msgs),
    }
    ps = ParameterSet.from_model(est.full_model_, units=units,
                                 source=source or "fit " + " ".join(names), fit=fit_info)
    return FitOutcome(kind, est.full_model_, est.report_, msgs,
                      mem["summary"] if isinstance(mem, dict) else "", ps, est)


@dataclass(frozen=True)
class _FitRows:
    """The masks ``fit`` was given (one recording: an array; several: a list; ``None``: the
    estimator's default split)."""

    train: Any
    test: Any


def _notes(est: Any, recs: Sequence[Recording], rows: _FitRows, kind: str,
           choice: BaseChoice | None, msgs: tuple[str, ...], start: SteadyStart
           ) -> tuple[dict[str, Any], tuple[str, ...]]:
    """The fitted ``est``'s report extras with what the entry point adds (the stop branch
    in the data's units, the base choice, the loops' orientation, the white-noise floor,
    the recordings started in their periodic steady state) and its warnings with the entry
    point's (clockwise loops, a misfit and where)."""
    extra = dict(est.report_.extra)
    if start.warm:
        extra["initial_memory"] = start.note(recs, extra.get("initial_memory"))
    preds = start.predict(est.predict, recs)
    feats = getattr(est, "features_", None)  # a stop-operator branch, in the data's units
    if feats is not None:
        extra["branch"] = feats.text(recs[0].units.get("input") or "input units",
                                     recs[0].units.get("output") or "output units")
    if choice is not None:
        extra["base_choice"] = choice.text
        extra["base_choice_scores"] = choice.to_dict()
    if "orientation" not in extra:
        extra["orientation"], cw = _orientation(est, recs, rows)
        if cw and getattr(est, "constraint", "") != "slopes":
            # (with free-sign weights a play-based kind can flatten its branches)
            msgs = (*msgs, CLOCKWISE_WARNING.format(kind=kind))
    beyond = _extrapolation(est, recs, rows, extra)
    if beyond is not None:
        msgs = (*msgs, beyond.text(dict(recs[0].units)) + ".")
    miss = _misfit(est, recs, rows, preds)
    if miss is not None:
        extra["noise_floor"] = miss.floor
        extra["rmse_over_noise_floor"] = miss.ratio
        if miss.exceeds:
            pct = est.report_.test.rmse_pct if est.report_.test is not None else None
            said = miss.text(pct, "" if choice is None else choice.advice,
                             dict(recs[0].units)).rstrip()
            msgs = (*msgs, said + ("" if said.endswith(".") else ".")
                    + _rate_text(est, recs, rows, preds) + _left_text(est, recs, preds)
                    + physics_left_sentence(recs, miss.floor))
    inv = _inverse_text(est.report_, dict(recs[0].units))
    return extra, (msgs if inv is None else (*msgs, inv))


#: Inverse-input RMSE (% of the input range) above which :func:`fit_recordings` warns that
#: the fitted model's inverse does not recover the input from the measured output.
INVERSE_WARN_PCT = 10.0


def _inverse_text(report: Any, units: dict[str, str]) -> str | None:
    """A warning when the fitted model's inverse, applied to the measured output, misses the
    measured input by more than :data:`INVERSE_WARN_PCT` % of its range (on the held-out
    rows, else the training rows), or ``None``. The model may still be invertible: where
    the output stays nearly constant while the input moves (a friction plateau, a
    saturated actuator), the output does not determine the input, and the inverse turns
    the output's noise into large input swings."""
    part = report.test if report.test is not None else report.train
    if not report.invertible or not part.inverse_input_rmse_pct > INVERSE_WARN_PCT:
        return None
    where = "held-out" if report.test is not None else "training"
    u = units.get("input") or "input units"
    return (f"the inverse of this model does not recover the input from the measured output: "
            f"on the {where} rows it misses the input by {part.inverse_input_rmse:.4g} {u} "
            f"RMS, {part.inverse_input_rmse_pct:.3g} % of the input's range "
            f"{part.input_range:.4g} {u}. Where the output hardly changes while the input "
            "moves (a friction plateau, saturation), the output does not tell the input, and "
            "the inverse amplifies the output's noise; do not use this model as a "
            "compensator for that range.")


def _rate_text(est: Any, recs: Sequence[Recording], rows: _FitRows,
               preds: list[np.ndarray]) -> str:
    """How the held-out residual grows with the recordings' input rate, in words
    (:func:`core.fitting.adequacy.rate_trend`, as the diagnosis's verdict says it), or
    ``""`` (``preds``: the fitted model's output on each recording)."""
    from .adequacy import rate_trend, rate_words

    if len(recs) < 2:
        return ""
    prep = _rows(est, recs, rows)
    words = rate_words(recs, rate_trend(recs, preds, list(prep.test_masks)))
    return f" Across the recordings, {words}." if words else ""


def _left_text(est: Any, recs: Sequence[Recording], preds: list[np.ndarray]) -> str:
    """What the fit leaves on the longest recording with a time axis, in words
    (:func:`core.fitting.leftover.leftover`), and where its fast part peaks across the
    recordings (:func:`core.fitting.leftover.fast_across`), or ``""``."""
    from .leftover import leftover_on

    if not any(r.has_time and r.is_uniform for r in recs):
        return ""
    left = leftover_on(recs, preds)
    flat = ("the sliding plateaus" if getattr(est, "features_", None) is not None
            else "the flat stretches of the branches")
    out = "" if left.leftover is None else f" On {left.name}, {left.leftover.text(flat)}."
    if left.across is not None:
        text = left.across.text(flat)
        out += f" {text[0].upper()}{text[1:]}."
    return out


def _rows(est: Any, recs: Sequence[Recording], rows: _FitRows) -> Prepared:
    """The training and held-out rows the estimator used (its masks, or its default split)."""
    us, ys = [r.u for r in recs], [r.y for r in recs]
    multi = len(recs) > 1
    return prepare(us if multi else us[0], ys if multi else ys[0], rows.train,
                   rows.test, validation=getattr(est, "validation", 0.2), min_train=1)


#: The warning of a kind whose loops run counter-clockwise only, on clockwise data.
CLOCKWISE_WARNING = (
    "the {kind} kind's loops run counter-clockwise only (the output lags the input, as in a "
    "piezo actuator): it cannot follow these clockwise loops (the output leads, as friction or "
    "a stress-strain material gives); fit --model stop-pi (Maxwell-slip elements: the friction "
    "plateau and a backlash gap) or --model bouc-wen, which fit both orientations, or --model "
    "auto, which chooses among them")


def _orientation(est: Any, recs: Sequence[Recording], rows: _FitRows) -> tuple[str, bool]:
    """The orientation line of a kind that does not report its own (the training rows' loops,
    and on clockwise data that the kind's loops run the other way) and whether they run
    clockwise (the kind cannot follow them)."""
    prep = _rows(est, recs, rows)
    o = loop_orientation(prep.us, prep.ys, prep.train_masks)
    return o.text + ("; this kind's loops run counter-clockwise (play operators)"
                     if o.clockwise else ""), o.clockwise


def _extrapolation(est: Any, recs: Sequence[Recording], rows: _FitRows,
                   extra: dict[str, Any]) -> Extrapolation | None:
    """Held-out rows whose inputs leave the range of the rows the weights were fitted on
    (the training rows, without those before the wipe-out time where the initial-memory
    rule left them out: ``extra["initial_memory"]``)."""
    if est.report_.test is None:
        return None
    prep = _rows(est, recs, rows)
    fitted = list(prep.train_masks)
    mem = extra.get("initial_memory")
    excluded = isinstance(mem, dict) and bool(mem.get("excluded_train_rows"))
    if excluded:
        assert isinstance(mem, dict)
        fitted = [m & (np.arange(m.size) >= int(tw))
                  for m, tw in zip(fitted, mem["wipeout_index"], strict=True)]
    return extrapolation([r.u for r in recs], [r.t for r in recs], fitted,
                         list(prep.test_masks), [r.name for r in recs],
                         [r.has_time for r in recs], excluded=excluded)


def _misfit(est: Any, recs: Sequence[Recording], rows: _FitRows,
            preds: list[np.ndarray]) -> Misfit | None:
    """The held-out error of a fitted estimator against its noise floor (the rows its
    report's ``test`` part scored: the ``test`` masks, or the estimator's default split;
    ``preds``: its output on each recording)."""
    if est.report_.test is None:
        return None
    us, ys = [r.u for r in recs], [r.y for r in recs]
    prep = _rows(est, recs, rows)
    return misfit([r.t for r in recs], us, ys, preds, prep.test_masks,
                  [r.name for r in recs], [r.has_time for r in recs])
