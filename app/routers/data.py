"""Recordings (raw CSV bodies, no multipart), fitting and diagnosis."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from fastapi import APIRouter, HTTPException, Query, Request
from fastapi.responses import HTMLResponse
from starlette.concurrency import run_in_threadpool

from app.services.session import actions

from .deps import SessionDep, SettingsDep, attachment, read_body
from .jobs import start_job, wait_for
from .schemas import (
    CsvPreviewOut,
    DiagnosisOut,
    FigureOut,
    FitIn,
    FitOut,
    RecordingOut,
    csv_preview_json,
    diagnosis_json,
    fit_json,
)

__all__ = ["router"]

router = APIRouter(prefix="/api", tags=["data"])

#: Policy of the self-contained diagnosis report (inline plotly.js, sandboxed, no network).
REPORT_CSP = ("default-src 'none'; script-src 'unsafe-inline' 'unsafe-eval'; "
              "style-src 'unsafe-inline'; img-src data: blob:; font-src data:; "
              "sandbox allow-scripts allow-downloads; frame-ancestors 'none'")

_CSV_TYPES = ("text/csv", "text/plain", "application/csv", "application/octet-stream")


def _check_type(request: Request) -> None:
    ctype = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if ctype not in _CSV_TYPES:
        raise HTTPException(415, f"send the CSV as a raw text/csv body, not {ctype or 'nothing'}")


@router.post("/csv/preview", response_model=CsvPreviewOut, response_model_exclude_unset=True)
async def preview_csv(request: Request, settings: SettingsDep) -> dict[str, Any]:
    """Columns, first rows and row count of a CSV body (the column-mapping step).

    Errors: 413 (too large), 415 (not text/csv), 422 with ``line``/``column``.
    """
    _check_type(request)
    body = await read_body(request, settings.max_upload_bytes)
    return csv_preview_json(await run_in_threadpool(actions.preview_csv, body, settings))


@router.post("/sessions/{code}/recording", status_code=201,
             response_model=RecordingOut, response_model_exclude_unset=True)
async def upload_recording(
    request: Request,
    session: SessionDep,
    settings: SettingsDep,
    t_col: str | None = Query(None, description="time column (name or 0-based index)"),
    u_col: str | None = Query(None, description="input column"),
    y_col: str | None = Query(None, description="output column"),
    run: str | None = Query(None, max_length=200,
                            description="run id to keep when the file has a run column, "
                                        "or 'all' to read every row as one recording"),
    dt: float = Query(1e-3, gt=0, le=3600,
                      description="sample spacing when there is no time column"),
    name: str = Query("upload.csv", max_length=200),
    timing: Literal["resample", "keep"] | None = Query(
        None, description="uneven time stamps: 'resample' onto an even grid (of step "
                          "seconds, else the median spacing) or 'keep' them as measured"),
    step: float | None = Query(None, gt=0, le=3600,
                               description="the even step of timing=resample, s"),
) -> dict[str, Any]:
    """Store a recording from a raw ``text/csv`` body with an optional column mapping.

    The body is CSV content, never a file name. The response lists the cleaning notes
    (removed rows, skipped lines, the run kept) and the file's runs.
    Errors: 413 (too large), 415 (not text/csv), 422 with ``line``/``column`` (and
    ``uneven``, the spacing and the step offered, when the time stamps are uneven and no
    ``timing`` was chosen).
    """
    _check_type(request)
    body = await read_body(request, settings.max_upload_bytes)
    up = await run_in_threadpool(
        lambda: actions.upload(session, body, settings, t_col=t_col, u_col=u_col,
                               y_col=y_col, run=run, dt=dt, name=name,
                               timing=timing, step=step)
    )
    rec = up.recording
    return {
        "name": rec.name,
        "samples": rec.n_samples,
        "notes": list(rec.cleaning),
        "runs": list(up.runs),
        "run": up.kept,
        "time_steps": up.time_steps,
        "t_range": [float(rec.t[0]), float(rec.t[-1])],
        "u_range": [float(np.min(rec.u)), float(np.max(rec.u))],
        "y_range": [float(np.min(rec.y)), float(np.max(rec.y))],
    }


@router.post("/sessions/{code}/fit", response_model=FitOut, response_model_exclude_unset=True)
async def fit(body: FitIn, request: Request, session: SessionDep,
              settings: SettingsDep) -> dict[str, Any]:
    """Fit a model to the session's recording; returns the model, report and overlay figure.

    Runs as a job of the bounded queue (see :mod:`app.routers.jobs`) and waits for it;
    the job is cancelled if the client hangs up.
    """
    job = start_job(request, session, settings, "fit", body.model_dump())
    return fit_json(await wait_for(request, job))


@router.post("/sessions/{code}/diagnose",
             response_model=DiagnosisOut, response_model_exclude_unset=True)
async def diagnose(request: Request, session: SessionDep,
                   settings: SettingsDep) -> dict[str, Any]:
    """Diagnose the fitted model (else the current model) against the recording (a job of
    the bounded queue, waited for; cancelled if the client hangs up)."""
    job = start_job(request, session, settings, "diagnose", {})
    return diagnosis_json(await wait_for(request, job))


@router.get("/sessions/{code}/diagnosis/figure", response_model=FigureOut)
def diagnosis_figure(session: SessionDep) -> dict[str, Any]:
    """The last diagnosis before and after: loops and residuals in the recording's units
    (the page's *Diagnosis* view)."""
    fig = actions.diagnosis_figure(session)
    if fig is None:
        raise HTTPException(409, actions.no_report(session))
    return fig.to_dict()


@router.get("/sessions/{code}/diagnosis/report.html", response_class=HTMLResponse)
def diagnosis_report(session: SessionDep) -> HTMLResponse:
    """The last diagnosis as a self-contained HTML report (plotly.js inlined, no CDN)."""
    text = actions.diagnosis_report(session)
    if text is None:
        raise HTTPException(409, f"{actions.no_report(session)} (POST "
                                 "/api/sessions/{code}/diagnose)")
    # a self-contained page: its inlined plotly.js needs inline scripts, so it runs
    # sandboxed (no access to the API's origin, no network)
    return HTMLResponse(text, headers={
        **attachment(actions.diagnosis_report_name(session), "inline"),
        "Content-Security-Policy": REPORT_CSP})
