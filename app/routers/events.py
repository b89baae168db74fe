"""Live events (server-sent events) and the teacher's push to every session.

``GET /api/sessions/{code}/events`` is a ``text/event-stream`` that an open page keeps:
every teacher push arrives as an ``event: push`` with an ``id`` and a JSON ``data`` line,
and the page reloads its session from ``GET /api/sessions/{code}``. A stream ends after
:data:`STREAM_S` seconds (so a server shutdown never waits long for open pages); the
browser's ``EventSource`` reconnects with ``Last-Event-ID`` and gets what it missed.

``POST /api/teacher/push`` gives every session a preset's model and, optionally, an input
signal (the preset's own default input when ``use_preset_input``); ``GET
/api/teacher/connected`` says how many pages listen, and to which sessions. Both follow
``/api/broadcast``'s rule (:func:`~app.routers.deps.require_teacher`): ``X-Teacher-Token``,
compared in constant time, whenever the server has a token, which it always has when
reachable beyond loopback. A push is committed to every session used in the last hour
(the store, not only the sessions in memory), so a reload or a restart keeps it.
"""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from typing import Any

from fastapi import APIRouter, Header, HTTPException, Query, Request
from fastapi.responses import StreamingResponse
from pydantic import BaseModel, Field

from app.services.errors import ParameterError
from app.services.explore.config import SignalSpec
from app.services.session import actions
from app.services.teaching import lessons
from app.services.teaching.events import HUB, StreamsPerClientError

from .deps import RegistryDep, SessionDep, SettingsDep, client_key, require_teacher
from .schemas import ConnectedOut, PushOut, SignalIn

__all__ = ["router"]

router = APIRouter(prefix="/api", tags=["events"])

#: Longest life of one stream, s (the browser reconnects at once).
STREAM_S = 10.0


@router.get("/sessions/{code}/events", response_class=StreamingResponse, responses={200: {
    "description": "server-sent events: `event: push` with an `id` and a JSON `data` line",
    "content": {"text/event-stream": {}}}})
async def session_events(
    session: SessionDep,
    request: Request,
    settings: SettingsDep,
    last_event_id: str | None = Header(default=None),
    name: str = Query("", max_length=200,
                      description="the student's name, shown in the teacher's list"),
) -> StreamingResponse:
    """Server-sent events of session ``code`` (teacher pushes) for about 10 s, then the
    browser reconnects (``Last-Event-ID`` replays what it missed). One client may hold
    ``max_streams_per_client`` streams at once (429 beyond)."""
    last = int(last_event_id) if last_event_id and last_event_id.isdigit() else None
    # the stream starts with an id, so a page that got no event yet reconnects with a
    # Last-Event-ID too, and a push sent while it reconnects is replayed, not lost
    start = HUB.newest_id() if last is None else last
    limit = settings.max_streams_per_client
    try:
        sub = HUB.subscribe(session.code, last, client=client_key(request), per_client=limit,
                            name=name)
    except StreamsPerClientError:
        raise HTTPException(
            429, f"this computer already has {limit} live explorer pages open, the most one "
                 "computer may keep; close the pages you do not need (they reconnect by "
                 f"themselves) or ask the teacher to raise HYST_MAX_STREAMS_PER_CLIENT",
            headers={"Retry-After": str(int(STREAM_S))}) from None
    except OverflowError:
        raise HTTPException(503, "too many open live pages; try again later") from None

    async def stream() -> AsyncIterator[str]:
        loop = asyncio.get_running_loop()
        end = loop.time() + STREAM_S
        timed_out = False  # the page reconnects at once: still counted in the class
        try:
            yield f"id: {start}\nretry: 500\n: connected\n\n"
            while (left := end - loop.time()) > 0:
                try:
                    event = await sub.get(left)
                except TimeoutError:
                    break
                if event is None:  # the hub closed
                    return
                yield (f"id: {event['id']}\nevent: {event.get('kind', 'message')}\n"
                       f"data: {json.dumps(event)}\n\n")
            timed_out = True
        finally:
            HUB.unsubscribe(sub, returning=timed_out)

    return StreamingResponse(stream(), media_type="text/event-stream",
                             headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})


class PushIn(BaseModel):
    """What the teacher pushes to every session."""

    preset: str | None = Field(None, description="preset name (see GET /api/presets)")
    model: dict[str, Any] | None = Field(
        None, description="a model document to push instead of a preset's (e.g. the one "
                          "the teacher edited)")
    signal: SignalIn | None = Field(None, description="input signal for every session")
    use_preset_input: bool = Field(
        False, description="give every session the preset's own default input")


@router.post("/teacher/push", response_model=PushOut, response_model_exclude_unset=True)
def teacher_push(
    body: PushIn,
    registry: RegistryDep,
    settings: SettingsDep,
    x_teacher_token: str | None = Header(default=None),
) -> dict[str, Any]:
    """Teacher: give every session a preset's model and/or an input signal, live."""
    require_teacher(settings, x_teacher_token)
    if body.preset is None and body.signal is None and body.model is None:
        raise HTTPException(422, "choose a preset, a model or an input signal to push")
    if body.preset is not None and body.model is not None:
        raise HTTPException(422, "push a preset or a model, not both")
    model = signal = None
    title = None
    if body.model is not None:  # checked like a saved parameter set, before any session
        model, title = actions.push_model(body.model, settings), "a model"
    if body.preset is not None:
        try:
            doc = actions.preset_doc(body.preset)
        except ParameterError:
            raise HTTPException(404, f"no preset named {body.preset!r}") from None
        model, title = doc["model"], doc["title"]
        if body.use_preset_input and body.signal is None:
            signal = SignalSpec(**doc["input"])
    if body.signal is not None:
        signal = body.signal.to_spec()
        try:
            signal.validate(settings.max_samples)
        except ParameterError as exc:
            raise HTTPException(422, str(exc)) from None
    # stored: a reload or a restart keeps the push; during a lesson it becomes the class
    # step, so the students stay on it
    n, pages = lessons.push_to_class(registry, model=model, signal=signal, note={
        "preset": body.preset, "title": title, "signal": signal is not None,
        "model": model is not None})
    what = f"{title or 'a new input'}{' with its input' if model and signal else ''}"
    return {"preset": body.preset, "sessions": n, "pages": pages,
            "text": HUB.roster().sent_text(f"Pushed {what}")}


@router.get("/teacher/connected", response_model=ConnectedOut, response_model_exclude_unset=True)
def teacher_connected(
    registry: RegistryDep,
    settings: SettingsDep,
    x_teacher_token: str | None = Header(default=None),
) -> dict[str, Any]:
    """Teacher: how many web pages and viser tabs are open, in how many sessions, and the
    names students gave (``text`` says it in a sentence without codes, for a projected
    panel; ``codes`` are for scripts)."""
    require_teacher(settings, x_teacher_token)
    conn = HUB.connected()
    roster = HUB.roster()
    return {"pages": roster.web_pages, "viser_tabs": roster.viser_tabs,
            "sessions_live": roster.sessions_live, "sessions": len(registry.all()),
            "names": list(roster.names), "unnamed": roster.unnamed, "text": roster.text,
            "codes": sorted(conn)}
