"""Download the session's parameter set (JSON, .mat, C, FMU) and upload a saved one."""

from __future__ import annotations

from functools import partial
from typing import Any

import anyio
from fastapi import APIRouter, HTTPException, Request
from fastapi.responses import Response

from app.services.errors import ParameterError
from app.services.guard.jsonbody import read_document
from app.services.session import actions
from app.services.session.exports import EXPORT_FORMATS

from .deps import (
    SessionDep,
    SettingsDep,
    attachment,
    client_key,
    decode_text,
    rate_limited,
    read_body,
)
from .schemas import SessionOut, session_json

__all__ = ["router"]

router = APIRouter(prefix="/api", tags=["export"])

_MEDIA = {"json": "application/json", "mat": "application/octet-stream", "c": "text/x-csrc",
          "fmu": "application/octet-stream"}


@router.get("/sessions/{code}/export/{fmt}", response_class=Response, responses={200: {
    "description": "the parameter set as a download",
    "content": {media: {} for media in _MEDIA.values()}}})
async def export(fmt: str, session: SessionDep, request: Request, fmi: str = "3",
                 inverse: bool = False) -> Response:
    """The session's current model as a download: ``json`` (parameter set), ``mat``, ``c`` or
    ``fmu`` (a co-simulation FMU compiled on the server: ``fmi`` 3 or 2, the compensator
    with ``inverse=true``, else the model)."""
    if fmt not in EXPORT_FORMATS:
        raise HTTPException(404, f"unknown export format {fmt!r}; known: {list(EXPORT_FORMATS)}")
    build = partial(actions.export, session, fmt, fmi=fmi, inverse=inverse)
    if fmt == "fmu":  # runs the C compiler: a few per minute and client
        key, limiter = client_key(request), request.app.state.fmu_limiter
        if not limiter.take(key):
            raise rate_limited(limiter, key, "too many FMU builds from this computer; wait "
                                             "a minute")
        # at most FMU_BUILDS compilers at once, the others wait here without holding one of
        # the worker threads every other request needs (60 builds at once had delayed a new
        # session by 9 s); past FMU_QUEUE waiting builds the answer is "busy"
        builds = _fmu_builds(request)
        if builds.statistics().tasks_waiting >= FMU_QUEUE:
            raise HTTPException(503, "the server is compiling many FMUs right now; try again "
                                     "in a minute", headers={"Retry-After": "30"})
        name, payload = await anyio.to_thread.run_sync(build, limiter=builds)
    else:
        name, payload = await anyio.to_thread.run_sync(build)
    return Response(payload, media_type=_MEDIA[fmt], headers=attachment(name))


#: FMU builds compiled at once (one C compiler per core of a small server).
FMU_BUILDS = 2
#: FMU builds that may wait for a compiler before the server answers "busy".
FMU_QUEUE = 32


def _fmu_builds(request: Request) -> anyio.CapacityLimiter:
    """The app's limiter of concurrent FMU builds (made on first use, in the event loop)."""
    state = request.app.state
    if getattr(state, "fmu_builds", None) is None:
        state.fmu_builds = anyio.CapacityLimiter(FMU_BUILDS)
    return state.fmu_builds


@router.put("/sessions/{code}/parameter-set",
            response_model=SessionOut, response_model_exclude_unset=True)
async def upload_parameter_set(
    request: Request, session: SessionDep, settings: SettingsDep
) -> dict[str, Any]:
    """Continue from a saved parameter set (a JSON body as downloaded, or a bare model)."""
    body = await read_body(request, settings.max_upload_bytes)
    doc = read_document(decode_text(body), name="the parameter set")  # 422 with the path
    try:
        actions.load_parameter_set(session, doc, settings)
    except (ParameterError, ValueError) as exc:
        raise HTTPException(422, f"not a usable parameter set: {exc}") from None
    return session_json(session)


