"""Fits of recordings: the explorer's fit and the steps ``hyst fit`` and the batch worker
share (no viser / fastapi imports).

Every fit is :func:`core.fitting.fit_recordings`, the one fitting entry point, with the
command line's defaults. A session's fit is a job (:func:`app.services.jobs.tasks.fit_task`),
the only fit path of the web page, the REST API and the viser GUI.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict

import numpy as np

from app.services.analysis.loops import file_recordings
from app.services.runs.inputs import CommandError, parse_window
from app.services.words import unit_words

if TYPE_CHECKING:  # core.fitting is imported when a fit runs (scipy: 0.5 s)
    from app.services.explore.figures import FigureJSON
    from app.services.runs.progress import Progress
    from core.fitting import FitOutcome, TimeWindow
    from core.fitting.metrics import FitReport, PartStats
    from core.paramset import ParameterSet
    from core.recordings import Recording

__all__ = [
    "FitResult",
    "check_n_operators",
    "fit_errors",
    "fit_outcome",
    "fit_recording",
    "fit_report_from_dict",
    "fit_result",
    "FitSource",
    "fit_source",
    "fitted_output",
    "say_fit",
    "time_window",
]


@dataclass(frozen=True)
class FitResult:
    """A session's fit as the pages show it (the fit job's result, shared by the REST API
    and the viser GUI; its JSON is made by the routers, ``routers/schemas.py::fit_json``).

    Attributes
    ----------
    outcome : FitOutcome
        The fit (:func:`fit_recording`): model, report, warnings, parameter set.
    rms_error, max_error : float
        Errors of its model on the whole recording (output units).
    nrmse_percent : float
        ``rms_error`` in % of the recording's output range.
    output_unit : str
        The output's unit in words (``""`` when unknown).
    figure : FigureJSON or None
        The overlay of the measured and the fitted output.
    """

    outcome: FitOutcome
    rms_error: float
    max_error: float
    nrmse_percent: float
    output_unit: str
    figure: FigureJSON | None = None

    @property
    def n_operators(self) -> int | None:
        """The number of operators asked for (as ``hyst fit -n`` records it)."""
        n = (self.outcome.parameter_set.provenance.fit or {}).get("n_operators")
        return None if n is None else int(n)


def fit_recording(rec: Recording, n: int | None, kind: str = "pi") -> FitOutcome:
    """Fit a model of ``kind`` with ``n`` operators to ``rec``: the outcome without its
    estimator: what a session keeps (:meth:`~app.services.session.sessions.Session.set_fit`;
    it pickles, so a job's worker sends it back as it is; the store keeps its parameter set
    and rebuilds it with :func:`fit_outcome`).

    The fit is :func:`core.fitting.fit_recordings` (the one entry point ``hyst fit`` and
    ``hyst batch fit`` use) with ``hyst fit -n N --model KIND``'s defaults: the last 20 %
    held out and the initial memory as the kind's default (``"exclude"``: the training rows
    before the wipe-out time left out of the weight fit, where the kind can; the report's
    ``memory_note`` says so). Its ``model`` is the fitted output offset included, as a
    chain. ``n`` ``None`` chooses the number of operators by cross-validation and ``kind``
    ``"auto"`` the model (``hyst fit``'s defaults). The recordings fitted are those ``hyst
    fit`` reads from the file (:func:`.loops.file_recordings`): each run of an upload that
    kept them all, on sample numbers where the file has no time column.

    Raises
    ------
    ParameterError
        If ``kind`` is not one of :func:`core.models.fit_kinds` (those of ``hyst fit
        --model``, declared by the model registry).
    """
    from core.fitting import fit_recordings

    out = fit_recordings(file_recordings(rec), kind, n_operators=n)
    return replace(out, estimator=None)


def fitted_output(out: FitOutcome, rec: Recording) -> np.ndarray:
    """The output of the fit ``out``'s model over ``rec``, shape ``(n_samples,)``: each run
    (:func:`.loops.file_recordings`) started as the fit started it: from the memory its own
    cycle leaves when it is in periodic steady state (the warm-up run first, its output
    dropped), else relaxed at its first sample."""
    from core.fitting.steadystate import SteadyStart

    runs = file_recordings(rec)
    return np.concatenate(SteadyStart.of(runs).predict(out.model, runs))


def fit_result(out: FitOutcome, rec: Recording, figure: FigureJSON | None = None
               ) -> FitResult:
    """The :class:`FitResult` of the fit ``out`` of ``rec``: its model's errors on the whole
    recording (each run started as the fit started it: :func:`fitted_output`), the output
    unit in words, and ``figure``."""
    res = rec.y - fitted_output(out, rec)
    rms = float(np.sqrt(np.mean(res**2)))
    return FitResult(out, rms, float(np.max(np.abs(res))),
                     float(100 * rms / (float(np.ptp(rec.y)) or 1.0)),
                     unit_words(rec.units.get("output")), figure)


def fit_outcome(ps: ParameterSet) -> FitOutcome:
    """The :class:`~core.fitting.FitOutcome` a fit's parameter set describes (its
    ``provenance.fit``: kind, report, warnings; no estimator).

    Raises
    ------
    ValueError, TypeError, KeyError
        ``provenance.fit`` is not a fit's.
    """
    from core.fitting.entry import FitOutcome

    fit = ps.provenance.fit
    if fit is None:
        raise ValueError("the parameter set has no fit")
    report = fit_report_from_dict(fit["report"])
    mem = report.extra.get("initial_memory")
    return FitOutcome(str(fit["model"]), ps.model, report,
                      tuple(str(w) for w in fit.get("warnings") or ()),
                      str(mem["summary"]) if isinstance(mem, dict) else "", ps, None)


def _number(x: Any) -> float:
    """A stored float (JSON has no NaN: a missing value was stored as ``null``)."""
    return math.nan if x is None else float(x)


def _part(d: Any) -> PartStats:
    from core.fitting.metrics import PartStats

    return PartStats(int(d["n_samples"]), _number(d["rmse"]), _number(d["max_abs"]),
                     _number(d["output_range"]), _number(d["rmse_pct"]),
                     _number(d["inverse_input_rmse"]), _number(d["input_range"]),
                     _number(d["inverse_input_rmse_pct"]))


def fit_report_from_dict(d: Any) -> FitReport:
    """Inverse of ``FitReport.to_dict()`` (its JSON, ``null`` for what was not finite).

    Raises
    ------
    ValueError, TypeError, KeyError
        ``d`` is not a fit report.
    """
    from core.fitting.metrics import FitReport

    return FitReport(
        model_type=str(d["model_type"]), n_parameters=int(d["n_parameters"]),
        train=_part(d["train"]), test=None if d.get("test") is None else _part(d["test"]),
        compensation_max_abs=_number(d["compensation_max_abs"]),
        compensation_rmse=_number(d["compensation_rmse"]),
        invertible=bool(d["invertible"]), min_slope=_number(d["min_slope"]),
        condition_number=_number(d["condition_number"]), solver=str(d["solver"]),
        extra=dict(d.get("extra") or {}), warnings=tuple(d.get("warnings") or ()))


def time_window(text: str | None, what: str) -> TimeWindow | None:
    """The :class:`~core.fitting.TimeWindow` of ``--<what> T0:T1`` (``None`` without one)."""
    from core.fitting import TimeWindow

    if text is None:
        return None
    t0, t1 = parse_window(text, what)
    return TimeWindow(t0, t1, text)


class FitSource(TypedDict):
    """The provenance keywords of :func:`core.fitting.fit_recordings` (:func:`fit_source`)."""

    files: list[str]
    source: str


def fit_source(files: Sequence[str | Path]) -> FitSource:
    """The provenance of a ``hyst fit`` of ``files``: ``{"files", "source"}`` of
    :func:`core.fitting.fit_recordings`."""
    names = [Path(f).name for f in files]
    return {"files": names, "source": "hyst fit " + " ".join(names)}


def check_n_operators(n: object) -> None:
    """``-n``: ``None`` (chosen by cross-validation) or a positive integer (CommandError)."""
    if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
        raise CommandError(f"-n must be a positive number of operators, got {n}")


@contextmanager
def fit_errors() -> Iterator[None]:
    """Report an empty window as ``hyst fit`` does (``--train window selects no samples``)."""
    from core.fitting import EmptyWindowError

    try:
        yield
    except EmptyWindowError as exc:
        raise CommandError(f"--{exc.which} window selects no samples; check it against the "
                           "t column") from None


def say_fit(progress: Progress, out: FitOutcome) -> None:
    """Report the fit's warnings and what was done about the initial memory."""
    for m in out.warnings:
        progress(f"warning: {m}")
    if out.memory_note:
        progress(out.memory_note)
