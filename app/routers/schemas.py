"""Pydantic request/response models of the REST API (the only module using pydantic).

The routers declare the response models (``response_model=...``) so that ``/openapi.json``
describes every JSON response. They are served with ``response_model_exclude_unset=True``:
a response holds exactly the keys the services returned, in the order declared here (the
services' order), and numbers keep their type (:data:`Number` where a value may be an int
or a float), so the bytes are what they were before the models were declared.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from app.services.analysis.diagnosis import SessionDiagnosis
from app.services.analysis.fit_words import fit_words
from app.services.analysis.fitting import FitResult
from app.services.analysis.recordings import TIMING_CHOICES, CsvPreview, Timing
from app.services.explore.config import Config, SignalSpec
from app.services.explore.controls import ModelControls

if TYPE_CHECKING:
    from app.services.jobs.manager import JobView
    from app.services.session.sessions import Session

__all__ = [
    "BroadcastOut",
    "CapabilitiesOut",
    "ClampIn",
    "ClampOut",
    "ConfigIn",
    "ConnectedOut",
    "ControlsIn",
    "ControlsOut",
    "CsvPreviewOut",
    "DiagnosisOut",
    "FigureOut",
    "FiguresOut",
    "FitIn",
    "FitOut",
    "HealthOut",
    "JobCreatedOut",
    "JobListOut",
    "JobOut",
    "PresetOut",
    "PushOut",
    "RecordingOut",
    "SessionOut",
    "controls_json",
    "csv_preview_json",
    "diagnosis_json",
    "fit_json",
    "fit_report_json",
    "job_json",
    "job_result_json",
    "session_json",
    "timing_json",
    "SignalIn",
    "SimulateIn",
    "SimulateOut",
    "ViserUrlOut",
]

#: A JSON number that keeps its type (an int stays an int, a float a float).
Number = int | float


class SignalIn(BaseModel):
    """Input signal ``offset + amplitude * shape(frequency t)`` on ``[0, duration]``."""

    model_config = ConfigDict(extra="forbid")
    kind: str = Field("sine", description="signal name, see GET /api/capabilities")
    amplitude: float = Field(4.0, ge=-1e6, le=1e6, description="input units")
    frequency: float = Field(1.0, ge=0, le=1e5, description="Hz")
    offset: float = Field(0.0, ge=-1e6, le=1e6, description="input units")
    duration: float = Field(2.0, gt=0, le=3600, description="s")
    samples: int = Field(2000, ge=2, description="number of samples (limit: max_samples)")

    def to_spec(self) -> SignalSpec:
        """The core-side value object."""
        return SignalSpec(**self.model_dump())


class ConfigIn(BaseModel):
    """Partial update of a session's config (omitted fields keep their value)."""

    model_config = ConfigDict(extra="forbid")
    model: dict[str, Any] | None = Field(
        None, description="a model document with a 'type' field, e.g. {'type': 'pi', ...}"
    )
    signal: SignalIn | None = None
    mismatch: float | None = Field(None, ge=-0.9, le=0.9, description="plant perturbation")
    use_recording: bool | None = None

    def apply(self, cfg: Config) -> Config:
        """``cfg`` with the given fields replaced."""
        from dataclasses import replace

        kw: dict[str, Any] = {}
        if self.model is not None:
            kw["model"] = dict(self.model)
        if self.signal is not None:
            kw["signal"] = self.signal.to_spec()
        if self.mismatch is not None:
            kw["mismatch"] = float(self.mismatch)
        if self.use_recording is not None:
            kw["use_recording"] = self.use_recording
        return replace(cfg, **kw)


class ControlsIn(BaseModel):
    """A model whose sliders are wanted."""

    model_config = ConfigDict(extra="forbid")
    model: dict[str, Any] = Field(..., description="model document with a 'type' field")


class ClampIn(BaseModel):
    """A slider's move: the model document before it, the slider's path and where it was
    moved."""

    model_config = ConfigDict(extra="forbid")
    model: dict[str, Any] = Field(..., description="model document with a 'type' field")
    path: str = Field(..., max_length=200, description="the slider's path, e.g. thresholds[2]")
    value: float = Field(..., description="where the slider was moved (its field's value)")


class ClampOut(BaseModel):
    """The move kept inside its field's rules, and what a rule changed in words."""

    value: float = Field(description="the value the slider stops at")
    note: str = Field(description="what a rule changed, in the sliders' labels, or ''")


class SliderOut(BaseModel):
    """One number of the model as a slider (see app/services/explore/controls.py)."""

    path: str = Field(description="JSON path in the model document, e.g. pi.thresholds[2]")
    label: str = Field(description="what the user sees, e.g. r3")
    unit: str = Field(description="input, output, output/input, 1/input, s, Hz, s^k or 1")
    value: Number
    min: Number
    max: Number
    step: Number
    lower: Number | None = Field(None, description="hard lower limit of a valid value")
    upper: Number | None = Field(None, description="hard upper limit of a valid value")
    strict: bool = Field(description="the hard limits are exclusive")
    integer: bool
    fixed: bool = Field(description="a constant of the model: shown, not moved")
    below: str | None = Field(None, description="path of the neighbour to stay above")
    above: str | None = Field(None, description="path of the neighbour to stay below")
    rule: str = Field(description="the ordering rule in words")
    log: bool = Field(False, description="logarithmic slider: the thumb moves in log10 of "
                      "the value; value, min and max are real values (min > 0)")


class SliderGroupOut(BaseModel):
    """The sliders of one field of one model part."""

    key: str
    title: str
    unit: str
    sliders: list[SliderOut]
    note: str


class ControlsOut(BaseModel):
    """Every slider of a model, grouped by field, from the model types' declarations."""

    type: str
    layout: str = Field(description="changes only when the model's structure changes")
    groups: list[SliderGroupOut]


def controls_json(controls: ModelControls) -> dict[str, Any]:
    """The :class:`ControlsOut` body of a model's sliders (``POST /api/controls``)."""
    return {"type": controls.type, "layout": controls.layout,
            "groups": [{**dataclasses.asdict(g), "sliders": [dataclasses.asdict(s)
                                                             for s in g.sliders]}
                       for g in controls.groups]}


class SimulateIn(BaseModel):
    """Stateless simulation request."""

    model_config = ConfigDict(extra="forbid")
    model: dict[str, Any] = Field(..., description="model document with a 'type' field")
    signal: SignalIn = Field(default_factory=SignalIn)
    mismatch: float = Field(0.0, ge=-0.9, le=0.9)
    figures: list[str] = Field(
        default_factory=lambda: ["loop"],
        description="figures to build: time, loop, operators, loading, inverse",
    )
    include_data: bool = Field(False, description="also return t, u, y arrays")


class FigureOut(BaseModel):
    """A plotly figure (hand it to Plotly.react)."""

    data: list[dict[str, Any]]
    layout: dict[str, Any]


class SimulateOut(BaseModel):
    """Simulation result: model properties, figures and optionally the raw signals."""

    model_type: str
    model_title: str | None = Field(None, description="the model type in words")
    model_note: str | None = Field(None, description="what the model's values do, in words "
                                                     "(a negative weight and invertibility)")
    n_operators: int | None = None
    slopes: list[float] | None = None
    max_loop_width: float | None = None
    invertible: bool | None = None
    inverse_error: str | None = None
    figures: dict[str, FigureOut] = Field(default_factory=dict)
    data: dict[str, list[float]] | None = None
    elapsed_ms: float


class FitIn(BaseModel):
    """Fit request on the session's uploaded recording."""

    model_config = ConfigDict(extra="forbid")
    kind: str = Field("pi", description="model kind to fit, see GET /api/capabilities, or "
                                         "'auto': the model hyst fit chooses")
    n: int | None = Field(10, ge=1, description="number of play operators (limit: "
                                                "max_operators); null: chosen by "
                                                "cross-validation, as hyst fit does")
    apply: bool = Field(True, description="make the fitted model the session's model")


# ----------------------------------------------------------------------------- responses
class HealthOut(BaseModel):
    """Liveness."""

    status: str = Field(description="'ok'")


class ViserUrlOut(BaseModel):
    """Where the viser GUI listens."""

    enabled: bool
    url: str | None = Field(None, description="http://host:port/ or null when disabled")
    port: int | None = None


class LimitsOut(BaseModel):
    """The limits of one request (see docs/serve.md, *Server safety*)."""

    max_upload_bytes: int
    max_operators: int
    max_samples: int
    max_json_depth: int
    max_model_depth: int
    max_numbers: int
    max_creep_terms: int
    max_lti_order: int
    min_tau_per_dt: Number
    max_tau_per_dt: Number
    max_work: int
    max_total_work: Number
    max_memory_bytes: Number


class CapabilitiesOut(BaseModel):
    """What the server offers and its limits."""

    model_types: list[str]
    signals: list[str]
    presets: list[str]
    figures: list[str]
    export_formats: list[str]
    fit_kinds: list[str]
    fit_kind_titles: dict[str, str] = Field(
        default_factory=dict, description="each fit kind in words (the menus show these)")
    limits: LimitsOut


class SignalOut(BaseModel):
    """An input signal (the fields of :class:`SignalIn`)."""

    kind: str
    amplitude: Number
    frequency: Number
    offset: Number
    duration: Number
    samples: int


class PresetOut(BaseModel):
    """A preset of the papers: its model and the input that suits it."""

    name: str
    title: str
    description: str
    model: dict[str, Any] = Field(description="model document with a 'type' field")
    input: SignalOut


class ConfigOut(BaseModel):
    """A session's config."""

    model: dict[str, Any] = Field(description="model document with a 'type' field")
    signal: SignalOut
    mismatch: Number
    use_recording: bool


class RecordingSummaryOut(BaseModel):
    """The session's recording."""

    name: str
    samples: int


class SessionOut(BaseModel):
    """A session: its code, version, config, recording and fitted model."""

    code: str = Field(description="the session code, abcd-efgh-jkmn-pqrs")
    version: int = Field(description="bumped on every change")
    config: ConfigOut
    recording: RecordingSummaryOut | None = None
    fitted: dict[str, Any] | None = Field(None, description="the fitted model document")
    has_diagnosis: bool


def session_json(session: Session) -> dict[str, Any]:
    """The :class:`SessionOut` body of ``session``: its typed state (core's ``FitOutcome``
    for the fit) turned into JSON, here and nowhere in the services."""
    st = session.use()
    rec = session.recording
    return {
        "code": st.code,
        "version": st.version,
        "config": st.config.to_dict(),
        "recording": None if rec is None else {"name": rec.name, "samples": rec.n_samples},
        "fitted": None if st.fit is None else st.fit.model.to_dict(),
        "has_diagnosis": session.has_diagnosis,
    }


class FiguresOut(BaseModel):
    """Figures of a session's config and the properties of its model."""

    model_type: str
    model_title: str | None = Field(None, description="the model type in words")
    model_note: str | None = Field(None, description="what the model's values do, in words "
                                                     "(a negative weight and invertibility)")
    n_operators: int | None = None
    inverse_error: str | None = None
    figures: dict[str, FigureOut] = Field(default_factory=dict)
    elapsed_ms: Number
    version: int
    slopes: list[Number] | None = Field(None, description="classical PI models only")
    max_loop_width: Number | None = None
    invertible: bool | None = None
    digitized_states: int | None = Field(None, description="rows of the digitized trace "
                                                           "(when that view was computed)")
    data: dict[str, list[Number]] | None = None


class BroadcastOut(BaseModel):
    """A preset pushed to every session."""

    preset: str
    sessions: int = Field(description="sessions changed")


class PushOut(BaseModel):
    """The teacher's push."""

    preset: str | None = None
    sessions: int = Field(description="sessions changed (used in the last hour)")
    pages: int = Field(description="open pages told at once")
    text: str | None = Field(None, description="what the teacher reads: the push and the "
                                               "class connected now (counts, never codes)")


class ConnectedOut(BaseModel):
    """Pages that listen live."""

    pages: int = Field(description="open web pages (live event streams)")
    viser_tabs: int = Field(0, description="open viser (3D / GUI) tabs")
    sessions_live: int = Field(description="sessions with an open page or tab")
    sessions: int = Field(description="sessions in memory")
    names: list[str] = Field([], description="names the students gave, sorted")
    unnamed: int = Field(0, description="pages and tabs without a name")
    text: str = Field("", description="the above in a sentence, without session codes")
    codes: list[str] = Field(description="session codes with an open web page (for "
                                         "scripts; the teacher panel does not show them)")


class UnevenTimingOut(BaseModel):
    """Uneven time stamps of a CSV and the choices of the upload (``timing=``)."""

    column: str = Field(description="the time column")
    spacing_min_s: float
    spacing_max_s: float
    spacing_mean_s: float
    step_s: float = Field(description="the even step timing=resample uses (the median "
                                      "spacing); pass it back as step= to be sure")
    choices: list[str] = Field(description="resample: interpolate onto an even grid; "
                                           "keep: keep the time stamps as measured")


class CsvPreviewOut(BaseModel):
    """The layout of a CSV body (the column-mapping step)."""

    columns: list[str]
    rows: list[list[str]] = Field(description="the first data rows, as text")
    n_rows: int
    encoding: str
    notes: list[str]
    uneven: UnevenTimingOut | None = Field(
        None, description="present when the time stamps (automatic column mapping) are "
                          "uneven: upload with timing=resample or timing=keep")


def timing_json(timing: Timing) -> dict[str, Any]:
    """The :class:`UnevenTimingOut` body of an upload's uneven time stamps (in the CSV
    preview, and in the 422 of an upload that has to choose)."""
    return {"column": timing.column, "spacing_min_s": timing.spacing_min,
            "spacing_max_s": timing.spacing_max, "spacing_mean_s": timing.spacing_mean,
            "step_s": timing.step, "choices": list(TIMING_CHOICES)}


def csv_preview_json(preview: CsvPreview) -> dict[str, Any]:
    """The :class:`CsvPreviewOut` body of a CSV preview (``uneven`` only when they are)."""
    out: dict[str, Any] = {
        "columns": list(preview.columns), "rows": [list(r) for r in preview.rows],
        "n_rows": preview.n_rows, "encoding": preview.encoding, "notes": list(preview.notes)}
    if preview.uneven is not None:
        out["uneven"] = timing_json(preview.uneven)
    return out


class RecordingOut(BaseModel):
    """The recording stored from an upload."""

    name: str
    samples: int
    notes: list[str] = Field(description="cleaning notes: removed rows, the run kept, ...")
    runs: list[str] = Field(description="run ids of the file's run column (empty without)")
    run: str | None = None
    time_steps: str | None = Field(None, description="what was done with uneven time "
                                                     "stamps, in words")
    t_range: list[Number]
    u_range: list[Number]
    y_range: list[Number]


class FitOut(BaseModel):
    """A fit: the model, its report and the overlay figure."""

    model: dict[str, Any] = Field(description="the fitted model document")
    report: dict[str, Any] = Field(description="errors, held-out RMSE, kind, n_operators")
    figure: FigureOut


class DiagnosisOut(BaseModel):
    """A diagnosis: findings, held-out RMSE before and after, and the core's document."""

    engine: str
    findings: list[str]
    baseline_rmse_pct: Number | None = None
    final_rmse_pct: Number | None = None
    effects: list[Any]
    document: dict[str, Any] = Field(description="core.diagnosis DiagnosisResult.to_dict()")


def _finite(x: Any) -> Any:
    """``x`` with non-finite floats replaced by ``None`` (JSON has no NaN/inf)."""
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_finite(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def fit_report_json(fit: FitResult) -> dict[str, Any]:
    """The ``report`` of :class:`FitOut`: the outcome's ``FitReport.to_dict()`` (NaN as
    ``null``) plus the errors on the whole recording, the number of operators asked for,
    the kind, the output unit in words and what the page says about the fit
    (:func:`~app.services.analysis.fit_words.fit_words`)."""
    return {
        **_finite(fit.outcome.report.to_dict()),
        "rms_error": fit.rms_error,
        "max_error": fit.max_error,
        "nrmse_percent": fit.nrmse_percent,
        "n_operators": fit.n_operators,
        "kind": fit.outcome.kind,
        "output_unit": fit.output_unit,
        "words": dataclasses.asdict(fit_words(fit.outcome, fit.output_unit)),
    }


def fit_json(fit: FitResult) -> dict[str, Any]:
    """The :class:`FitOut` body of a fit job's typed result."""
    return {"model": fit.outcome.model.to_dict(), "report": fit_report_json(fit),
            "figure": None if fit.figure is None else fit.figure.to_dict()}


def diagnosis_json(diag: SessionDiagnosis) -> dict[str, Any]:
    """The :class:`DiagnosisOut` body of a diagnosis job's typed result: its findings and
    the core's report document (``DiagnosisResult.to_dict()``)."""
    s = diag.summary
    return {"engine": "core.diagnosis", "findings": list(s.findings),
            "baseline_rmse_pct": s.baseline_rmse_pct, "final_rmse_pct": s.final_rmse_pct,
            "effects": list(s.effects), "document": diag.result.to_dict()}


def job_result_json(result: Any) -> Any:
    """The JSON of a job's result (:func:`fit_json`, :func:`diagnosis_json`; ``None``
    before it is done)."""
    if isinstance(result, FitResult):
        return fit_json(result)
    if isinstance(result, SessionDiagnosis):
        return diagnosis_json(result)
    return result


def job_json(view: JobView, with_result: bool = True) -> dict[str, Any]:
    """The :class:`JobOut` body of a job (``with_result=False``: without its result, as the
    list shows it)."""
    d: dict[str, Any] = {"id": view.id, "kind": view.kind, "state": view.state,
                         "progress": view.progress, "message": view.message,
                         "time_left": view.time_left, "error": view.error}
    if with_result:
        d["result"] = job_result_json(view.result)
    return d


class JobCreatedOut(BaseModel):
    """A queued job."""

    id: str
    kind: Literal["fit", "diagnose"]
    state: str


class JobOut(BaseModel):
    """A job's state, progress (0..1), message, error and (once done) result."""

    id: str
    kind: Literal["fit", "diagnose"]
    state: str = Field(description="queued, running, done, failed or cancelled")
    progress: Number
    message: str
    time_left: str = Field("", description="while it runs, the time left in words from the "
                           "measured cost of its recording's size ('about 40 s left'); empty "
                           "for a run expected to take under 20 s")
    error: str | None = None
    result: Any = Field(None, description="FitOut or DiagnosisOut once done")


class JobListOut(BaseModel):
    """The session's newest jobs, newest first (without their results)."""

    jobs: list[JobOut]
