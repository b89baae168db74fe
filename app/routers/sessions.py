"""Sessions: per-student state by code, config updates, figures, presets, broadcast.

The routes of a slider step (read, rejoin, ``PATCH .../config``, figures of a small model)
are ``async``: they and their dependencies run on the event loop, with no hand-over to a
worker thread, which cost more than their own work (issue 18 item 8). What may wait long
still goes to a worker thread, so it never holds up the other requests: the commit of a
config change (a disk write) and figures whose priced work is not small
(:func:`app.services.session.actions.figures_are_quick`); heavy figures go to a worker process that
is killed when the client hangs up (:mod:`.killable`).
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Header, HTTPException, Query, Request
from fastapi.concurrency import run_in_threadpool

from app.services.errors import ParameterError
from app.services.session import actions
from app.services.teaching.push import push

from .deps import RegistryDep, SessionDep, SettingsDep, client_key, rate_limited, require_teacher
from .killable import run_figures
from .schemas import BroadcastOut, ConfigIn, FiguresOut, SessionOut, session_json

__all__ = ["router"]

router = APIRouter(prefix="/api", tags=["sessions"])


@router.post("/sessions", status_code=201,
             response_model=SessionOut, response_model_exclude_unset=True)
def create_session(
    request: Request,
    registry: RegistryDep,
    settings: SettingsDep,
    x_teacher_token: str | None = Header(default=None),
) -> dict[str, Any]:
    """Create a session with the default config (paper 001 Example 1); returns its code.

    Codes are made by the server only (79 random bits). Each client may create 200
    sessions at once, then one a second (429 beyond), and keep 500 stored sessions and a
    tenth of the store (429 beyond, saying which limit). With a valid ``X-Teacher-Token``
    the session is the teacher's: never evicted, and opened even when the store is full
    (the sessions of the computers holding the most go first).
    """
    key = client_key(request)
    teacher = settings.teacher_ok(x_teacher_token)
    limiter = request.app.state.create_limiter
    if not teacher and not limiter.take(key):
        raise rate_limited(limiter, key, "too many new sessions from this computer; wait a "
                                         "little or rejoin your session with its code")
    session = registry.create(teacher=teacher, owner=key)
    request.app.state.known_codes.add(key, session.code)
    return session_json(session)


@router.get("/sessions/{code}", response_model=SessionOut, response_model_exclude_unset=True)
async def get_session(session: SessionDep) -> dict[str, Any]:
    """The session's config, version, recording and fit summary."""
    return session_json(session)


@router.put("/sessions/{code}", response_model=SessionOut, response_model_exclude_unset=True)
async def join_session(session: SessionDep) -> dict[str, Any]:
    """Rejoin an existing session by its code (404 "no such session" otherwise; codes are
    created only by ``POST /api/sessions``)."""
    return session_json(session)


@router.patch("/sessions/{code}/config",
              response_model=SessionOut, response_model_exclude_unset=True)
async def update_config(body: ConfigIn, session: SessionDep,
                        settings: SettingsDep) -> dict[str, Any]:
    """Change model, signal, mismatch or input source; validated and priced before it is
    stored, and stored (committed) before the answer."""
    # the commit writes to the disk: in a worker thread, so a write the system holds up
    # (other programs flushing) never stops the event loop and every other request
    await run_in_threadpool(actions.change_config, session, body.apply, settings)
    return session_json(session)


@router.get("/sessions/{code}/figures",
            response_model=FiguresOut, response_model_exclude_unset=True)
async def session_figures(
    request: Request,
    session: SessionDep,
    settings: SettingsDep,
    names: list[str] = Query(default=["loop"], alias="name"),  # noqa: B008
    state: int | None = Query(None, ge=0, le=10_000_000,
                              description="the digitized view at this state (row of its "
                                          "trace; step and play)"),
) -> dict[str, Any]:
    """Figures of the session's current config (``?name=loop&name=time``); only what the
    named figures show is computed."""
    if actions.figures_are_quick(session, names, settings):
        return actions.session_figures(session, names, settings, state)
    # priced here; heavy ones in a worker process that stops when the client hangs up
    return await run_figures(request,
                             actions.session_figures_run(session, names, settings, state))


@router.post("/sessions/{code}/preset/{name}",
             response_model=SessionOut, response_model_exclude_unset=True)
def apply_preset(name: str, session: SessionDep) -> dict[str, Any]:
    """Load the model of preset ``name`` (see ``GET /api/presets``)."""
    try:
        actions.load_preset(session, name, with_input=False)
    except ParameterError:
        raise HTTPException(404, f"no preset named {name!r}") from None
    return session_json(session)


@router.post("/broadcast/{name}", response_model=BroadcastOut, response_model_exclude_unset=True)
def broadcast_preset(
    name: str,
    registry: RegistryDep,
    settings: SettingsDep,
    x_teacher_token: str | None = Header(default=None),
) -> dict[str, Any]:
    """Teacher: push preset ``name`` to every session used in the last hour.

    Needs ``X-Teacher-Token`` whenever the server has a token, which it always has when
    reachable beyond loopback (compared in constant time).
    """
    require_teacher(settings, x_teacher_token)
    try:
        model = actions.preset_doc(name)["model"]
    except ParameterError:
        raise HTTPException(404, f"no preset named {name!r}") from None
    n, _ = push(registry, model=model, note={"preset": name})
    return {"preset": name, "sessions": n}
