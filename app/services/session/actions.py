"""What the REST routers and the viser GUI do to a session (no web imports).

Each function is one transition of a :class:`~app.services.session.sessions.Session` (load a
preset, set the config, load a parameter set, upload a recording, fit, export,
the teacher's push) or one read of its results (figures). Configs and parameter sets are
checked against the cost limits (:mod:`.cost`) before any work; a refusal is a
:class:`~core.exceptions.ParameterError` (or :class:`~core.csvio.CSVError`, a subclass)
with a message for the user. The callers only translate arguments and errors (HTTP status
codes, toasts).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Collection
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Any

import numpy as np

from app.services.analysis.diagnosis import base_name, diagnosis_html
from app.services.analysis.recordings import CsvPreview, Upload, csv_preview, read_upload
from app.services.explore import controls as C
from app.services.explore import figures as F
from app.services.explore.config import Config, SignalSpec
from app.services.explore.cost import CheckedModel, check_config, check_document, checked_config
from app.services.explore.payload import FiguresBody
from app.services.explore.shared import STEP_RESULTS, content_key, with_version
from app.services.explore.simulation import (
    PresetDoc,
    Result,
    check_operator_limit,
    diagnosed_model,
    preset_doc,
    priced_views,
)
from app.services.jobs import tasks
from app.services.jobs.worker import Task
from app.services.memory import give_back
from app.services.session.exports import export_session, fmi_version, parameter_set_model
from app.services.session.sessions import Session
from app.services.settings import Settings
from app.services.words import diagnosed_words
from core.base import Model, RunCost
from core.exceptions import ParameterError
from core.presets import list_presets
from core.recordings import Recording

__all__ = [
    "change_config",
    "check_figure_names",
    "checked_controls",
    "clamp_slider",
    "checked_model",
    "diagnosis_figure",
    "diagnosis_report",
    "diagnosis_report_name",
    "export",
    "fit_figure",
    "load_parameter_set",
    "load_preset",
    "no_report",
    "preset_doc",
    "preview_csv",
    "push_model",
    "session_figures",
    "figures_are_quick",
    "session_model",
    "session_result",
    "set_operator_count",
    "simulate",
    "upload",
]


# ----------------------------------------------------------------------------- config
def checked_model(cfg: Config, recording: Recording | None,
                  settings: Settings) -> CheckedModel:
    """The model of ``cfg`` built once from its document, checked against the cost limits
    (run on ``recording`` when ``cfg.use_recording``) and the operator limit.

    Raises
    ------
    ParameterError
        Naming the limit exceeded or the invalid field of the model.
    """
    checked = checked_config(cfg, recording, settings.limits)
    check_operator_limit(checked.model, settings.max_operators)
    return checked


def session_model(session: Session, settings: Settings) -> Model:
    """The session's current model, parsed and checked once per config (kept in its state,
    :meth:`~app.services.session.sessions.Session.checked`)."""
    return session.checked(settings.limits,
                           lambda cfg, rec: checked_model(cfg, rec, settings))[2]


def change_config(session: Session, fn: Callable[[Config], Config],
                  settings: Settings) -> int:
    """Apply ``fn`` to the session's config, check its cost and validity, store it.

    Returns the new version. Nothing is stored when the new config is refused.

    Raises
    ------
    ParameterError
        Naming the field out of range or the limit exceeded.
    """
    with session.lock:
        new = fn(session.config)
        return session.set_config(new, checked_config_change(new, session.recording,
                                                             settings))


def checked_config_change(new: Config, recording: Recording | None,
                          settings: Settings) -> CheckedModel:
    """``new`` checked as a config change is, each check once: the sliders' rules (in the
    labels they show), the model built once from its document and priced against the cost
    limits, the operator limit, then the signal (when the run is not the recording's). A
    session's change, a slider's move and a lesson's step pass the same checks.

    Raises
    ------
    ParameterError
        Naming the field out of range or the limit exceeded.
    """
    C.check_rules(new.model)  # a broken rule in the labels the sliders show
    checked = checked_model(new, recording, settings)
    if not (new.use_recording and recording is not None):
        new.signal.validate(settings.max_samples)
    return checked


def checked_controls(doc: Any, settings: Settings) -> C.ModelControls:
    """The sliders of a model document (:func:`app.services.explore.controls.model_controls`),
    after checking that it is a valid model within the limits.

    Raises
    ------
    ParameterError
        If the document is too big or deep, or not a valid model (the message names the
        broken rule or the JSON path).
    """
    if not isinstance(doc, dict) or "type" not in doc:
        raise ParameterError('model: a model document is a JSON object with a "type" '
                             '(for example {"type": "pi", "p0": 1, ...})')
    check_document(doc, settings.limits)
    C.check_rules(doc)
    model = parameter_set_model(doc)
    check_operator_limit(model, settings.max_operators)
    return C.model_controls(doc)


def clamp_slider(doc: Any, path: str, value: float, settings: Settings) -> C.Clamped:
    """A slider's move kept inside its field's rules (:func:`.controls.clamp`: whole
    numbers, hard limits, one step short of an increasing neighbour), with the note in the
    labels the sliders show: the one implementation of the rules, which the viser GUI calls
    and the web page asks for (``POST /api/controls/clamp``).

    Raises
    ------
    ParameterError
        If the document is too big or deep or not a model document, ``path`` is not one of
        its sliders or ``value`` is not a finite number.
    """
    if not isinstance(doc, dict) or "type" not in doc:
        raise ParameterError('model: a model document is a JSON object with a "type" '
                             '(for example {"type": "pi", "p0": 1, ...})')
    check_document(doc, settings.limits)
    try:
        return C.clamp(doc, path, value)
    except (TypeError, KeyError, IndexError) as exc:
        raise ParameterError(f"the model has no slider at {path!r} ({exc})") from None


def set_operator_count(session: Session, n: int, settings: Settings) -> int:
    """Give the session a classical PI of ``n`` operators: thresholds evenly spaced up to
    the current widest one (2.7 without one), the current total weight shared equally and
    ``p0`` kept. Returns the new version.

    Raises
    ------
    ParameterError
        If ``n`` is not between 1 and the operator limit.
    """
    if not 1 <= n <= settings.max_operators:
        raise ParameterError(f"n must be between 1 and {settings.max_operators}")

    def fn(cfg: Config) -> Config:
        m = cfg.model
        rmax = float(m["thresholds"][-1]) if m.get("thresholds") else 2.7
        total = float(np.sum(m.get("weights", [1.0])))
        return cfg.with_model({"type": "pi", "p0": float(m.get("p0", 0.72)),
                               "thresholds": (rmax * np.arange(1, n + 1) / n).tolist(),
                               "weights": [total / n] * n})

    return change_config(session, fn, settings)


def load_preset(session: Session, name: str, *, with_input: bool) -> PresetDoc:
    """Give the session preset ``name``'s model (and, ``with_input``, its own input
    signal instead of an uploaded recording); returns the preset document.

    Raises
    ------
    ParameterError
        If there is no such preset (the message lists the names).
    """
    doc = preset_doc(name)
    if with_input:
        sig = SignalSpec(**doc["input"])
        session.update(lambda c: replace(c.with_model(doc["model"]), signal=sig,
                                         use_recording=False))
    else:
        session.update(lambda c: c.with_model(doc["model"]))
    return doc


@lru_cache(maxsize=1)
def _preset_keys() -> tuple[tuple[str, str], ...]:
    return tuple((json.dumps(preset_doc(p.name)["model"], sort_keys=True), p.name)
                 for p in list_presets())


def matching_preset(model: dict[str, Any]) -> str | None:
    """Name of the preset whose model is ``model`` (dict form), or None when the model was
    changed since (or never came from a preset)."""
    key = json.dumps(model, sort_keys=True)
    return next((name for k, name in _preset_keys() if k == key), None)


def load_parameter_set(session: Session, doc: Any, settings: Settings) -> Model:
    """Continue from a saved parameter set (parsed JSON: a downloaded set or a bare model).

    Raises
    ------
    ParameterError
        If the document is not a usable parameter set or exceeds a cost limit.
    """
    try:
        check_document(doc, settings.limits, where="body")
        model = parameter_set_model(doc)
        d = model.to_dict()
        check_config(session.config.with_model(d), session.recording, settings.limits)
    except (TypeError, KeyError) as exc:
        raise ParameterError(str(exc)) from None
    session.update(lambda c: c.with_model(d))
    return model


# ----------------------------------------------------------------------------- data
def upload(session: Session, content: str | bytes, settings: Settings,
           **mapping: Any) -> Upload:
    """Read uploaded CSV content (never a path; see :func:`.recordings.read_upload` for the
    column ``mapping``) and make it the session's recording (its fit and diagnosis are
    dropped).

    Raises
    ------
    core.csvio.CSVError
        Naming the line and the column.
    """
    try:
        up = read_upload(content, max_samples=settings.max_samples, **mapping)
        session.set_recording(up.recording)  # stored: the session no longer holds it
    finally:
        give_back()  # the parse's freed memory goes back to the system
    return up


def _units(session: Session) -> dict[str, str]:
    rec = session.recording
    return {} if rec is None else dict(rec.units)


def diagnosis_report(session: Session) -> str | None:
    """The session's last diagnosis as a self-contained HTML report (axes in the
    recording's units), or ``None`` before one."""
    result = session.diagnosis_result
    return None if result is None else diagnosis_html(result, _units(session))


def diagnosis_report_name(session: Session) -> str:
    """The file name of the session's diagnosis report, named for its recording
    (``diagnosis-piezo-150v-1hz.html``); a session's code is a key to the session and never
    goes into a file a student shares (as :func:`export`'s names)."""
    rec = session.recording
    name = re.sub(r"\.[A-Za-z0-9]{1,5}$", "", str(getattr(rec, "name", "") or ""))
    stem = re.sub(r"[^a-z0-9]+", "-", name.lower()).strip("-")[:60].strip("-")
    return f"diagnosis-{stem or 'recording'}.html"


def diagnosis_figure(session: Session) -> F.FigureJSON | None:
    """The session's last diagnosis before and after (loops and residuals, in the
    recording's units; :func:`.figures.diagnosis_figure`), or ``None`` before one."""
    result = session.diagnosis_result
    if result is None:
        return None
    first = result.records[0]
    units = {**first.units, **_units(session)}
    if not first.has_time:  # sample numbers (a file without a time column), not seconds
        units["time"] = "sample"
    rec = replace(first, units=units)
    base = f"{base_name(result.baseline.structure.base_kind, 'base')} model"
    if len(result.records) > 1:  # the figure draws the first recording
        base += f" ({result.records[0].name}, the first of {len(result.records)} runs)"
    effects = [e.name for e in result.effects]
    final = f"with {', '.join(e.replace('-', ' ') for e in effects)}" if effects else \
        "no effect added"
    b = result.heldout_rmse(result.baseline)
    f = result.heldout_rmse(result.final)
    heldout = (float(b), float(f)) if math.isfinite(b) and math.isfinite(f) else None
    fig = F.diagnosis_figure(rec, result.baseline.pred[0], result.final.pred[0], base, final,
                             heldout)
    # the page's status line names the diagnosed model (not the session's fitted one)
    fig.layout["meta"] = {**fig.layout.get("meta", {}),
                          "model_title": diagnosed_words(result.model, effects)}
    return fig


def no_report(session: Session) -> str:
    """Why :func:`diagnosis_report` has no report for ``session`` (what to do)."""
    note = session.diagnosis_note  # a diagnosis stored by an older version, dropped
    return "run the diagnosis first" if note is None else note


def preview_csv(content: str | bytes, settings: Settings) -> CsvPreview:
    """Columns, first rows, row count and notes of CSV content (the column-mapping step;
    see :func:`.recordings.csv_preview`)."""
    return csv_preview(content, settings.max_samples)


def fit_figure(recording: Recording, model: Model, label: str) -> F.FigureJSON:
    """The overlay of ``model`` run on ``recording``'s input against its output."""
    return F.fit_figure(recording, model(recording.u), label)


def export(session: Session, fmt: str, *, fmi: object = 3,
           inverse: bool = False) -> tuple[str, bytes]:
    """``(filename, content)`` of the session's model as ``json``, ``mat``, ``c`` or ``fmu``
    (FMI version ``fmi``, ``"3"`` or ``"2"``; the compensator with ``inverse``)."""
    return export_session(session, fmt, fmi=fmi_version(fmi) if fmt == "fmu" else 3,
                          inverse=inverse)


# ----------------------------------------------------------------------------- teacher
def push_model(doc: Any, settings: Settings) -> dict[str, Any]:
    """A model document the teacher pushes, parsed and checked as a saved parameter set
    is (any model type, the cost limits, the operator limit); returns its canonical form.

    Raises
    ------
    ParameterError
        Naming the invalid field or the limit exceeded.
    """
    try:
        check_document(doc, settings.limits)
        model = parameter_set_model(doc)
    except (TypeError, KeyError) as exc:
        raise ParameterError(str(exc)) from None
    check_operator_limit(model, settings.max_operators)
    d = model.to_dict()
    check_config(Config().with_model(d), None, settings.limits)
    return d


# ----------------------------------------------------------------------------- figures
def check_figure_names(names: Collection[str]) -> list[str]:
    """The distinct figure names of a request, in their first order (a figure asked for
    twice is built once); names that are not figures are refused before any work."""
    unique = list(dict.fromkeys(names))
    unknown = [n for n in unique if n not in F.FIGURES]
    if unknown:
        raise ParameterError(f"unknown figure(s) {unknown[:10]}; known: {list(F.FIGURES)}")
    return unique


def session_result_run(session: Session, views: Collection[str],
                       settings: Settings) -> FiguresRun:
    """The session's current config for ``views``, priced before any work (the model's run
    and the views' extra runs: :func:`_priced_work`; the model is the one the session keeps
    for its config, parsed once). Its task returns a
    :class:`~app.services.explore.simulation.Result` (or a :class:`.tasks.Refused`); ``killable``
    says it is heavy enough for a worker process (the viser GUI's heavy views).

    Raises
    ------
    ParameterError
        The model or the views are over a limit.
    """
    views = tuple(views)
    cfg, v, model = session.checked(settings.limits,
                                    lambda c, rec: checked_model(c, rec, settings))
    checked = session.state.checked
    diagnosed = diagnosed_model(session)
    cost = _priced_work(checked, views, diagnosed) if checked is not None else math.inf
    args = (cfg, views, v, session.recording, diagnosed, model, settings.max_operators,
            settings.max_samples)
    shared = (content_key("result", cfg, tuple(sorted(views)), settings.max_operators,
                          settings.max_samples)
              if _shareable(cfg, session.recording, diagnosed) else None)
    return FiguresRun(Task(tasks.run_result, args), cost > KILLABLE_WORK, shared, v)


def session_result(session: Session, views: Collection[str], settings: Settings) -> Result:
    """The session's current config computed for ``views`` only, in this thread (priced
    first: :func:`session_result_run`)."""
    return figures_here(session_result_run(session, views, settings))


#: Figures computed on the event loop when the model's priced work is at most this many
#: element operations (about a millisecond: the default session is 4e4, 25 operators on
#: 4,000 samples 1e5).
QUICK_WORK = 1_000_000
#: The figures that may be computed on the event loop (the closed loop runs three 100,000
#: sample simulations and the digitized view a state graph: never quick).
QUICK_FIGURES = frozenset({"time", "loop", "operators", "loading", "inverse"})


def figures_are_quick(session: Session, names: Collection[str], settings: Settings) -> bool:
    """Whether the figures ``names`` of the session's current config are cheap enough to be
    computed where the request arrived (the routes run the others in a worker thread):
    only :data:`QUICK_FIGURES`, a priced work of at most :data:`QUICK_WORK`, and no
    diagnosed model (its closed loop and report views are never quick).

    Raises
    ------
    ParameterError
        The session's model is invalid or over a limit (as computing it would).
    """
    if not set(names) <= QUICK_FIGURES or session.diagnosed is not None \
            or session.diagnosis_result is not None:
        return False
    session_model(session, settings)  # parsed and priced once per config
    checked = session.state.checked
    return checked is not None and _priced_work(checked, names, None) <= QUICK_WORK


def _priced_work(checked: CheckedModel, names: Collection[str],
                 diagnosed: Model | None) -> float:
    """Priced work of figures ``names`` of a checked config: the model's run and what the
    views run beyond it (:func:`.simulation.priced_views`: the inverse of the compensated
    model, the diagnosed chain's closed loop), checked against the limits before any work.

    Raises
    ------
    ParameterError
        The views together with the model's run are priced over the limits of one request
        (``Limits.max_figures_work``, ``Limits.max_memory_bytes``); the message names the
        views and what to change.
    """
    key = frozenset(names) & {"inverse", "closed-loop"}
    extra: RunCost | None
    if diagnosed is not None:
        extra = priced_views(checked.model, key, checked.samples, checked.dt, diagnosed)
    else:
        extra = checked.views_work.get(key)
        if extra is None:  # once per config (a slider step builds the inverse once)
            extra = checked.views_work[key] = priced_views(
                checked.model, key, checked.samples, checked.dt)
    limits = checked.limits
    work = checked.cost.total_work + extra.work
    memory = checked.cost.memory_bytes + extra.memory
    if key and not (work <= limits.max_figures_work and memory <= limits.max_memory_bytes):
        views = " and ".join(VIEW_TITLES.get(v, v) for v in sorted(key))
        over = (f"{work:,.0f} units of work, more than the limit of "
                f"{limits.max_figures_work:,.0f}" if not work <= limits.max_figures_work else
                f"{memory / 1e6:,.0f} MB of memory, more than the limit of "
                f"{limits.max_memory_bytes / 1e6:,.0f} MB")
        whose = "the diagnosed model" if diagnosed is not None else "this model"
        raise ParameterError(
            f"the {views} view of {whose} on {checked.samples:,} samples is priced at "
            f"{over} (the model's own run: {checked.cost.total_work:,.0f}); show another "
            "view, or use fewer samples or a smaller model (fewer operators, segments or "
            "terms)")
    return work


#: The names of the views whose extra runs are priced, as the pages title them.
VIEW_TITLES = {"inverse": "Inverse", "closed-loop": "Closed-loop"}


#: Priced work (element operations) above which figures are computed in a worker process
#: that is killed when the client hangs up (:func:`figures_here` runs the others in the
#: server): about 65 ms of asymmetry work (1.3 ns per unit), up to 0.4 s at the slowest
#: unit measured (7.7 ns, ``bench_cost.py``), against the about 30 ms a worker process adds
#: (start, pickling the answer back; serve.md). The play-operator types, whose units are the
#: cheapest (0.07 to 0.24 ns), stay below it within the operator limit (100 operators x
#: 200,000 samples is 4e7 units).
KILLABLE_WORK = 50_000_000


@dataclass(frozen=True)
class FiguresRun:
    """Figures of one request, priced and ready to run (:func:`simulate_run`,
    :func:`session_figures_run`).

    ``task`` computes the JSON body (:func:`.tasks.run_figures`) or the result
    (:func:`.tasks.run_result`); ``killable`` says its priced work is above
    :data:`KILLABLE_WORK`, so the routes run it in a worker process that they kill when the
    client disconnects. ``shared`` is its content key when its outcome is the same for every
    session with the same config (no recording used, no diagnosed model): computed here, it
    is then computed once for all of them (:data:`.shared.STEP_RESULTS`, issue 33: a class on
    one lesson step), each session's ``version`` put into its copy.
    """

    task: Task
    killable: bool
    shared: str | None = None
    version: int = 0


def _shareable(config: Config, recording: Recording | None, diagnosed: Model | None) -> bool:
    """Whether the outcome of ``config`` depends on nothing but its content (not on a
    session's recording or diagnosed model): then sessions with equal configs share it."""
    return diagnosed is None and not (config.use_recording and recording is not None)


def _figures_run(config: Config, names: tuple[str, ...], settings: Settings, cost: float,
                 model: Model, *, version: int = 0, recording: Recording | None = None,
                 diagnosed: Model | None = None, include_data: bool = False,
                 state: int | None = None) -> FiguresRun:
    args = (config, names, version, recording, diagnosed, model, settings.max_operators,
            settings.max_samples, include_data, state)
    shared = (content_key("figures", config, names, settings.max_operators,
                          settings.max_samples, include_data, state)
              if _shareable(config, recording, diagnosed) else None)
    return FiguresRun(Task(tasks.run_figures, args), cost > KILLABLE_WORK, shared, version)


def figures_here(run: FiguresRun) -> Any:
    """Compute ``run`` in this process (thread); the JSON body (or the result). A run with a
    content key is computed once for every session that asks for the same key while it is
    kept (:data:`.shared.STEP_RESULTS`), each given its own version."""
    if run.shared is None:
        return figures_body(run.task.fn(*run.task.args, progress=_no_progress))
    out = STEP_RESULTS.get(run.shared,
                           lambda: run.task.fn(*run.task.args, progress=_no_progress),
                           keep=lambda o: not isinstance(o, tasks.Refused))
    return figures_body(with_version(out, run.version))


def figures_body(out: Any) -> Any:
    """The outcome of a :func:`.tasks.run_figures` or :func:`.tasks.run_result` task (the
    JSON body, the result), its refusal raised again.

    Raises
    ------
    ParameterError, NotInvertibleError
        The input was refused where the figures were computed.
    """
    if isinstance(out, tasks.Refused):
        raise out.error(out.message)
    return out


def _no_progress(fraction: float, message: str = "") -> None:
    pass


def session_figures_run(session: Session, names: Collection[str], settings: Settings,
                        state: int | None = None) -> FiguresRun:
    """Figures ``names`` of the session's current config, priced (nothing computed yet);
    ``state``: the digitized view at that row of its trace."""
    names = tuple(check_figure_names(names))
    cfg, v, model = session.checked(settings.limits,
                                    lambda c, rec: checked_model(c, rec, settings))
    checked = session.state.checked
    diagnosed = diagnosed_model(session)
    cost = _priced_work(checked, names, diagnosed) if checked is not None else math.inf
    return _figures_run(cfg, names, settings, cost, model, version=v,
                        recording=session.recording, diagnosed=diagnosed, state=state)


def session_figures(session: Session, names: Collection[str],
                    settings: Settings, state: int | None = None) -> FiguresBody:
    """Figures ``names`` of the session's current config (only their views computed);
    ``state``: the digitized view at that row of its trace (clipped to the trace)."""
    return figures_here(session_figures_run(session, names, settings, state))


def simulate_run(config: Config, names: Collection[str], settings: Settings,
                 include_data: bool = False) -> FiguresRun:
    """Figures ``names`` of a config that belongs to no session, priced (nothing computed
    yet: the cost is checked and the model built once, here)."""
    names = tuple(check_figure_names(names))
    checked = checked_config(config, None, settings.limits)
    model = check_operator_limit(checked.model, settings.max_operators)
    return _figures_run(config, names, settings, _priced_work(checked, names, None), model,
                        include_data=include_data)


def simulate(config: Config, names: Collection[str], settings: Settings,
             include_data: bool = False) -> FiguresBody:
    """Figures ``names`` of a config that belongs to no session (stateless)."""
    return figures_here(simulate_run(config, names, settings, include_data))
