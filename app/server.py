"""The explorer's FastAPI app; its lifespan starts the viser GUI server beside it.

viser is not an ASGI app (it serves its own page and websocket on its own port), so both
run in one process and share the
:class:`~app.services.session.sessions.SessionRegistry`: a parameter change
through REST shows up in the viser GUI of the same session code, and vice versa.
"""

from __future__ import annotations

import asyncio
import logging
import mimetypes
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import numpy as np
from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, RedirectResponse
from fastapi.staticfiles import StaticFiles

from app.services.analysis.recordings import UnevenUpload
from app.services.explore.config import Config
from app.services.guard.known_codes import KnownCodes
from app.services.guard.ratelimit import RateLimiter
from app.services.jobs.manager import JobManager
from app.services.jobs.worker import LiveWorkers
from app.services.session.sessions import SessionRegistry, StoreFullError
from app.services.settings import Settings
from app.services.storage.quotas import QuotaError
from app.services.storage.store import DamagedSessionError, SessionStore
from core.csvio import CSVError
from core.exceptions import NotInvertibleError, ParameterError
from core.paramset import ensure_model_types_registered

from .security import Guard

__all__ = ["STATIC_DIR", "create_app"]

#: Directory of the plain HTML/JS page, located from this file (never from the CWD).
STATIC_DIR = Path(__file__).resolve().parent.parent / "static"
# The page is ES modules: a browser runs a module script only when it comes as JavaScript
# (with nosniff), whatever the host's MIME table says (a Windows registry may say text/plain).
mimetypes.add_type("text/javascript", ".js")

log = logging.getLogger(__name__)


def _start_viser(app: FastAPI, settings: Settings) -> Any:
    """Start the viser server behind its guard (:mod:`app.gui.viser_guard`) and bind the GUI
    to the registry; ``None`` if disabled. New GUI sessions count against the same
    per-client limiter as ``POST /api/sessions``."""
    if settings.viser_port is None:
        return None
    from .gui.explorer import attach_gui
    from .gui.viser_guard import ViserGuard, start_viser

    guard = ViserGuard(settings.host_allow_list, settings.trusted_proxies,
                       max_tabs_per_client=settings.max_tabs_per_client,
                       max_tabs=settings.max_tabs,
                       max_upload_bytes=settings.max_upload_bytes)
    server = start_viser(settings.host, settings.viser_port, guard)
    app.state.gui = attach_gui(server, app.state.registry, settings, guard=guard,
                               limiter=app.state.create_limiter, jobs=app.state.jobs)
    return server


def create_app(settings: Settings | None = None) -> FastAPI:  # noqa: C901 - the composition root: one branch per optional part it wires
    """Build the explorer app.

    Parameters
    ----------
    settings : Settings, optional
        Addresses and limits; ``Settings()`` by default. ``viser_port=None`` runs the
        REST API and static page without the viser GUI; ``viser_port=0`` picks a free port.

    Returns
    -------
    FastAPI
        The app; use it as a context manager (``TestClient``) or serve it with uvicorn.
    """
    settings, generated = (settings or Settings()).with_teacher_token()
    if generated:
        log.warning("the server is reachable beyond loopback: broadcasting needs a teacher "
                    "token; one was generated (`hyst serve` writes it to a file in the "
                    "state directory and prints the file's path)")
    ensure_model_types_registered()
    store = SessionStore(
        ":memory:" if not settings.state_dir else Path(settings.state_dir) / "sessions.sqlite3",
        max_bytes=settings.max_store_mb * 1_000_000, quotas=settings.quotas)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        from app.services.explore.simulation import compute

        compute(Config())  # every view once: the compiled kernels load before any user
        server = _start_viser(app, settings)
        app.state.viser = server
        app.state.viser_port = None if server is None else server.get_port()
        try:
            yield
        finally:
            gui = getattr(app.state, "gui", None)
            if gui is not None:
                gui.close()
            if server is not None:
                server.stop()
            app.state.jobs.cancel_all()
            store.close()

    app = FastAPI(
        title="Hysteresis Explorer",
        version="0.1.0",
        summary="Prandtl-Ishlinskii hysteresis models: simulate, invert, fit, diagnose, export.",
        lifespan=lifespan,
        # FastAPI's Swagger/ReDoc pages load their scripts from a CDN; nothing here may use
        # the network, so /docs points at the offline reference rendered from /openapi.json.
        docs_url=None,
        redoc_url=None,
    )
    app.state.settings = settings

    @app.get("/docs", include_in_schema=False)
    def _docs() -> RedirectResponse:
        return RedirectResponse("/api.html")

    app.state.registry = SessionRegistry(settings.max_sessions, store)
    memory = settings.worker_memory_bytes  # each worker process's allowance
    app.state.jobs = JobManager(max_workers=settings.max_jobs, memory_limit=memory)
    # the worker processes of heavy figures (killed when their client hangs up)
    app.state.figure_workers = LiveWorkers(memory_limit=memory)
    app.state.figure_slots = asyncio.Semaphore(app.state.figure_workers.max_running)
    # per client: 200 new sessions at once, then 1 a second; 20 unknown codes, then 1 in 3 s
    app.state.create_limiter = RateLimiter(burst=200, per_minute=60)
    app.state.lookup_limiter = RateLimiter(burst=20, per_minute=20)
    # an FMU download compiles C on the server: 10 at once, then 1 in 10 s
    app.state.fmu_limiter = RateLimiter(burst=10, per_minute=6)
    # ...but a client paused for guessing still opens the sessions it created or opened
    app.state.known_codes = KnownCodes()
    app.state.viser_port = None

    @app.exception_handler(ParameterError)
    @app.exception_handler(NotInvertibleError)
    async def _domain_error(request: Request, exc: Exception) -> JSONResponse:
        return JSONResponse(status_code=422, content={"detail": str(exc)})

    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        # FastAPI's own answer, but a body that is not text (bytes sent as text/csv to a
        # JSON route) is shown with its undecodable bytes replaced instead of failing
        shown = jsonable_encoder(exc.errors(), custom_encoder={
            bytes: lambda b: b[:200].decode("utf-8", "replace")})
        return JSONResponse(status_code=422, content={"detail": shown})

    @app.exception_handler(StoreFullError)
    async def _full(request: Request, exc: Exception) -> JSONResponse:
        return JSONResponse(status_code=503, content={"detail": str(exc)})

    @app.exception_handler(QuotaError)
    async def _quota(request: Request, exc: Exception) -> JSONResponse:
        # a computer past its share: 429 (it may retry once its own old sessions go);
        # one session too large: 413
        status = 413 if getattr(exc, "limit", "") == "session_bytes" else 429
        return JSONResponse(status_code=status, content={"detail": str(exc)})

    @app.exception_handler(DamagedSessionError)
    async def _damaged(request: Request, exc: Exception) -> JSONResponse:
        # the store has reset the session (and logged it without the code): 410 once
        return JSONResponse(status_code=410, content={"detail": str(exc)})

    @app.exception_handler(RecursionError)
    async def _too_deep(request: Request, exc: Exception) -> JSONResponse:
        return JSONResponse(status_code=422, content={
            "detail": "the input is nested too deeply to process; flatten it"})

    @app.exception_handler(ArithmeticError)
    @app.exception_handler(np.linalg.LinAlgError)
    async def _numeric(request: Request, exc: Exception) -> JSONResponse:
        return JSONResponse(status_code=422, content={
            "detail": f"these parameter values cannot be computed ({exc}); use values of "
                      "ordinary size (see the limits in GET /api/capabilities)"})

    @app.exception_handler(CSVError)
    async def _csv_error(request: Request, exc: CSVError) -> JSONResponse:
        # line 1-based, column 0-based (the index, not the name: CSVError.column_index)
        detail: dict[str, Any] = {"message": str(exc), "line": exc.line,
                                  "column": exc.column_index}
        if isinstance(exc, UnevenUpload):  # the choices of the upload, with the step
            from .routers.schemas import timing_json

            detail["uneven"] = timing_json(exc.timing)
        return JSONResponse(status_code=422, content={"detail": detail})

    from .routers import controls, data, export, jobs, meta, sessions, simulate

    for mod in (meta, simulate, controls, sessions, data, jobs, export):
        app.include_router(mod.router)
    app.include_router(meta.vendor_router)
    from .routers.events import router as events_router  # live pushes (SSE), teacher

    app.include_router(events_router)
    from .routers.lessons import router as lessons_router  # the lesson a teacher leads

    app.include_router(lessons_router)
    app.mount("/", StaticFiles(directory=STATIC_DIR, html=True), name="static")
    app.add_middleware(Guard, max_body=settings.max_upload_bytes,
                       max_json_depth=settings.limits.max_json_depth,
                       hosts=settings.host_allow_list)
    return app
