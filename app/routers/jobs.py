"""Fits and diagnoses as queued, cancellable jobs (``/api/sessions/{code}/jobs``).

Contract: ``POST`` ``{"kind": "fit" | "diagnose", "params": {...}}`` → 202
``{"id", "kind", "state"}``; ``GET .../jobs/{id}`` → ``{"id", "kind", "state", "progress",
"message", "result", "error"}``; ``DELETE .../jobs/{id}`` cancels (a running job's worker
process is killed: the job is ``cancelled`` and its slot free when the DELETE returns);
``GET .../jobs?limit=``
→ ``{"jobs": [...]}``, the session's newest jobs first (the queued or running one
included, without results), so a page reloaded during a job can follow it. ``params`` are the bodies
of the synchronous ``POST .../fit`` (``FitIn``) and ``POST .../diagnose`` (none). A job
nobody polls for 30 s is cancelled. The synchronous endpoints (:mod:`app.routers.data`) run
through the same queue and cancel their job when the client hangs up (checked every 50 ms).
"""

from __future__ import annotations

import asyncio
from typing import Any, Literal

from fastapi import APIRouter, HTTPException, Query, Request
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from app.services.jobs import tasks
from app.services.jobs.manager import Job, JobBusy, JobManager, JobTooLarge
from app.services.session.sessions import Session
from app.services.settings import Settings

from .deps import SessionDep, SettingsDep
from .schemas import FitIn, JobCreatedOut, JobListOut, JobOut, job_json

__all__ = ["JobIn", "router", "start_job", "wait_for"]

router = APIRouter(prefix="/api", tags=["jobs"])


class JobIn(BaseModel):
    """A fit or diagnosis request."""

    model_config = ConfigDict(extra="forbid")
    kind: Literal["fit", "diagnose"]
    params: dict[str, Any] = Field(default_factory=dict,
                                   description="the body of POST .../fit, or {} to diagnose")


def _need_recording(session: Session) -> None:
    if session.recording is None:
        raise HTTPException(409, "upload a recording first (POST /api/sessions/{code}/recording)")


def start_job(request: Request, session: Session, settings: Settings, kind: str,
              params: dict[str, Any]) -> Job:
    """Validate ``params`` (cost limits included) and queue the job; HTTP errors otherwise."""
    _need_recording(session)
    if kind == "fit":
        try:
            body = FitIn(**params)
        except ValidationError as exc:
            raise HTTPException(422, exc.errors(include_url=False, include_context=False)
                                ) from None
        if body.n is not None and body.n > settings.max_operators:
            raise HTTPException(
                422, f"n = {body.n} exceeds max_operators = {settings.max_operators}")
        task = tasks.fit_task(session, body.n, body.kind, body.apply)
    else:
        if params:
            raise HTTPException(422, "a diagnosis takes no parameters (params: {})")
        task = tasks.diagnose_task(session)
    jobs: JobManager = request.app.state.jobs
    try:
        return jobs.submit(session.code, kind, task)
    except JobTooLarge as exc:  # the recording is too long for a worker: the input's fault
        raise HTTPException(422, str(exc)) from None
    except JobBusy as exc:
        raise HTTPException(409, str(exc)) from None


async def wait_for(request: Request, job: Job, timeout_s: float = 300.0) -> Any:
    """Wait for ``job`` while the client is connected; its typed result (the routers make
    its JSON, :mod:`.schemas`), or the HTTP error."""
    jobs: JobManager = request.app.state.jobs
    waited = 0.0
    while not jobs.wait(job, 0):
        if await request.is_disconnected():
            jobs.cancel(job.code, job.id)
            raise HTTPException(499, "the client went away; the job was cancelled")
        if waited > timeout_s:
            jobs.cancel(job.code, job.id)
            raise HTTPException(504, f"the {job.kind} took longer than {timeout_s:g} s and "
                                     "was cancelled; use a shorter recording")
        await asyncio.sleep(0.05)
        waited += 0.05
    v = job.view()
    if v.state == "done":
        return v.result
    if v.state == "failed":
        raise HTTPException(422, f"the {job.kind} failed: {v.error}")
    raise HTTPException(409, f"the {job.kind} was cancelled: {v.message}")


@router.post("/sessions/{code}/jobs", status_code=202,
             response_model=JobCreatedOut, response_model_exclude_unset=True)
def create_job(body: JobIn, request: Request, session: SessionDep,
               settings: SettingsDep) -> dict[str, Any]:
    """Queue a fit or a diagnosis of the session's recording; poll it with GET."""
    job = start_job(request, session, settings, body.kind, body.params)
    return {"id": job.id, "kind": job.kind, "state": job.view().state}


#: The most jobs a list returns.
MAX_LISTED = 20


@router.get("/sessions/{code}/jobs", response_model=JobListOut, response_model_exclude_unset=True)
def list_jobs(request: Request, session: SessionDep,
              limit: int = Query(10, ge=1, le=MAX_LISTED,
                                 description="how many of the newest jobs")
              ) -> dict[str, Any]:
    """The session's newest jobs, newest first, without their results (GET one for it)."""
    jobs: JobManager = request.app.state.jobs
    return {"jobs": [job_json(j.view(), with_result=False)
                     for j in jobs.recent(session.code, limit)]}


def _job(request: Request, session: Session, job_id: str) -> Job:
    try:
        return request.app.state.jobs.get(session.code, job_id)
    except KeyError:
        raise HTTPException(404, f"no job {job_id[:40]!r} in this session") from None


@router.get("/sessions/{code}/jobs/{job_id}",
            response_model=JobOut, response_model_exclude_unset=True)
def get_job(job_id: str, request: Request, session: SessionDep) -> dict[str, Any]:
    """State, progress (0..1), message, and the result once done (the error if failed)."""
    return job_json(_job(request, session, job_id).view())


@router.delete("/sessions/{code}/jobs/{job_id}",
               response_model=JobOut, response_model_exclude_unset=True)
def cancel_job(job_id: str, request: Request, session: SessionDep) -> dict[str, Any]:
    """Cancel a queued or running job (a finished one is left as it is)."""
    _job(request, session, job_id)
    return job_json(request.app.state.jobs.cancel(session.code, job_id).view())
