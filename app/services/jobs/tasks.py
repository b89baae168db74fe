"""The fit and diagnosis jobs of a session: what runs in the worker process and what the
server keeps (no web imports).

:func:`fit_task` and :func:`diagnose_task` build a :class:`~app.services.jobs.worker.Task` from the
session's state at submission (its recording, its typed model). Their work,
:func:`run_fit` and :func:`run_diagnosis`, runs in a worker process (:mod:`.worker`) that a
cancel kills; only a finished, uncancelled result is stored in the session, in the server
(``Task.keep``). The work functions are looked up here when a task is built, so a test may
replace them with its own module-level functions.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from app.services.jobs.worker import Progress, Task
from app.services.runs.cost import DIAGNOSE, FIT
from core.exceptions import ParameterError

if TYPE_CHECKING:
    from app.services.analysis.diagnosis import SessionDiagnosis
    from app.services.analysis.fitting import FitResult
    from app.services.explore.config import Config
    from app.services.explore.payload import FiguresBody
    from app.services.session.sessions import Session
    from core.base import Model
    from core.recordings import Recording

__all__ = ["Refused", "diagnose_task", "fit_task", "run_diagnosis", "run_figures", "run_fit",
           "run_result"]


def run_fit(rec: Recording, n: int | None, kind: str, *, progress: Progress) -> FitResult:
    """Fit ``rec`` (:func:`.fitting.fit_recording`) and draw the overlay figure: the typed
    :class:`~app.services.analysis.fitting.FitResult` (the outcome without its estimator,
    the errors on the whole recording, the figure) goes back to the server as it is, which
    keeps the outcome in the session (:func:`fit_task`)."""
    from app.services.analysis.fitting import fit_recording, fit_result, fitted_output
    from app.services.analysis.loops import on_samples
    from app.services.explore import figures as F
    from app.services.words import type_words

    what = ("choosing the model as hyst fit does" if kind == "auto" else
            f"fitting a {type_words(kind)[:1].lower() + type_words(kind)[1:]}")
    many = "choosing the number of operators" if n is None else f"with {n} operators"
    progress(0.05, f"{what}, {many}")
    out = fit_recording(rec, n, kind)
    progress(0.9, "building the figure")
    used = out.report.extra.get("n_operators", n)
    fig = F.fit_figure(on_samples(rec), fitted_output(out, rec),
                       f"fitted: {type_words(out.kind)}, {used} operators")
    return fit_result(out, rec, fig)


def run_diagnosis(rec: Recording, model: Model, *, progress: Progress) -> SessionDiagnosis:
    """Diagnose ``rec`` against ``model`` (:func:`.diagnosis.run_diagnosis`): the typed
    :class:`~app.services.analysis.diagnosis.SessionDiagnosis` (the core's result and its
    findings in words); progress runs from 0.01 to 0.99."""
    from app.services.analysis.diagnosis import run_diagnosis as diagnose
    from app.services.words import in_words

    progress(0.01, "diagnosing")

    def report(fraction: float = 0.0, message: str = "", *_: Any, **__: Any) -> None:
        # the diagnosis speaks of its candidates by their registry names: words here
        progress(0.01 + 0.98 * float(fraction), in_words(str(message)) or "diagnosing")

    return diagnose(rec, model, report)


@dataclass(frozen=True)
class Refused:
    """What :func:`run_figures` returns instead of raising when the input is at fault: the
    error's class and text, raised again as such in the server (a 422, not a failure)."""

    error: type[Exception]
    message: str


def run_figures(config: Config, names: tuple[str, ...], version: int,
                recording: Recording | None, diagnosed: Model | None, model: Model,
                max_operators: int, max_samples: int, include_data: bool,
                state: int | None = None, *, progress: Progress) -> FiguresBody | Refused:
    """The JSON body of figures ``names`` of ``config`` (``/api/simulate`` and a session's
    figures; ``state``: the digitized view's highlighted row):
    :func:`.simulation.compute` then :func:`.payload.result_payload`, with the
    model already built and priced by the caller. Runs in a request's thread, or in a worker
    process when its priced work is large (:data:`.actions.KILLABLE_WORK`)."""
    from app.services.explore.payload import result_payload
    from app.services.explore.simulation import compute
    from core.exceptions import NotInvertibleError

    try:
        res = compute(config, views=names, version=version, recording=recording,
                      max_operators=max_operators, max_samples=max_samples,
                      diagnosed=diagnosed, model=model)
        return result_payload(res, names, include_data, state=state)
    except (ParameterError, NotInvertibleError) as exc:
        return Refused(type(exc), str(exc))


def run_result(config: Config, views: tuple[str, ...], version: int,
               recording: Recording | None, diagnosed: Model | None, model: Model,
               max_operators: int, max_samples: int, *, progress: Progress) -> Any:
    """The :class:`~app.services.explore.simulation.Result` of ``config`` for ``views`` (the viser
    GUI draws its figures and notes from it), with the model already built and priced by
    the caller; a :class:`Refused` when the input is refused where it is computed. Runs in
    the GUI's render thread, or in a worker process when its priced work is large."""
    from app.services.explore.simulation import compute
    from core.exceptions import NotInvertibleError

    try:
        return compute(config, views=views, version=version, recording=recording,
                       max_operators=max_operators, max_samples=max_samples,
                       diagnosed=diagnosed, model=model)
    except (ParameterError, NotInvertibleError) as exc:
        return Refused(type(exc), str(exc))


def _recording(session: Session, what: str) -> Recording:
    rec = session.recording
    if rec is None:
        raise ParameterError(f"upload a recording first: there is nothing to {what}")
    return rec


def fit_task(session: Session, n: int | None, kind: str, apply: bool) -> Task:
    """The task of a fit of ``session``'s recording; kept: the fit is stored (the diagnosis
    dropped; with ``apply`` the fitted model becomes the session's model). The job's result
    is the typed :class:`~app.services.analysis.fitting.FitResult` (the REST API's JSON of
    it: ``routers/schemas.py::fit_json``)."""
    rec = _recording(session, "fit")

    def keep(out: FitResult) -> FitResult:
        session.set_fit(out.outcome, apply=apply)
        return out

    return Task(run_fit, (rec, n, kind), keep, samples=rec.n_samples, cost=FIT)


def diagnose_task(session: Session) -> Task:
    """The task of a diagnosis of the fitted model (else the current model) against
    ``session``'s recording; kept: the result is stored. The job's result is the typed
    :class:`~app.services.analysis.diagnosis.SessionDiagnosis` (the REST API's JSON of it:
    ``routers/schemas.py::diagnosis_json``)."""
    fitted = session.fitted
    model = fitted if fitted is not None else session.model  # the worker is sent the Model

    def keep(out: SessionDiagnosis) -> SessionDiagnosis:
        session.set_diagnosis(out.result)
        return out

    rec = _recording(session, "diagnose")
    return Task(run_diagnosis, (rec, model), keep, samples=rec.n_samples, cost=DIAGNOSE)
