"""Sessions: per-student state by code, config updates, figures, presets, broadcast."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Header, HTTPException, Query

from core.exceptions import ParameterError

from ..compute import compute, preset_doc, validate_config
from ..events import HUB
from ..schemas import ConfigIn
from .deps import RegistryDep, SessionDep, SettingsDep
from .simulate import result_payload

__all__ = ["router"]

router = APIRouter(prefix="/api", tags=["sessions"])


@router.post("/sessions", status_code=201)
def create_session(registry: RegistryDep) -> dict[str, Any]:
    """Create a session with the default config (paper 001 Example 1); returns its code."""
    return registry.create().summary()


@router.get("/sessions/{code}")
def get_session(session: SessionDep) -> dict[str, Any]:
    """The session's config, version, recording and fit summary."""
    return session.summary()


@router.put("/sessions/{code}")
def join_session(code: str, registry: RegistryDep) -> dict[str, Any]:
    """Get or create the session with a chosen code (3-32 letters, digits, - or _)."""
    try:
        return registry.get_or_create(code).summary()
    except KeyError:
        raise HTTPException(422, "a session code has 3-32 letters, digits, '-' or '_'") from None


@router.patch("/sessions/{code}/config")
def update_config(body: ConfigIn, session: SessionDep, settings: SettingsDep) -> dict[str, Any]:
    """Change model, signal, mismatch or input source; validated before it is stored."""
    with session.lock:
        new = body.apply(session.config)
        validate_config(new, session.recording, settings.max_operators, settings.max_samples)
        session.set_config(new)
    return session.summary()


@router.get("/sessions/{code}/figures")
def session_figures(
    session: SessionDep,
    settings: SettingsDep,
    names: list[str] = Query(default=["loop"], alias="name"),  # noqa: B008
) -> dict[str, Any]:
    """Figures of the session's current config (``?name=loop&name=time``)."""
    cfg, v = session.snapshot()
    res = compute(cfg, version=v, recording=session.recording,
                  max_operators=settings.max_operators, max_samples=settings.max_samples,
                  with_inverse="inverse" in names, with_digitized="digitized" in names)
    return result_payload(res, names, cfg.mismatch, False)


@router.post("/sessions/{code}/preset/{name}")
def apply_preset(name: str, session: SessionDep) -> dict[str, Any]:
    """Load the model of preset ``name`` (see ``GET /api/presets``)."""
    model = _preset(name)["model"]
    session.update(lambda c: c.with_model(model))
    return session.summary()


def _preset(name: str) -> dict[str, Any]:
    try:
        return preset_doc(name)
    except ParameterError:
        raise HTTPException(404, f"no preset named {name!r}") from None


@router.post("/broadcast/{name}")
def broadcast_preset(
    name: str,
    registry: RegistryDep,
    settings: SettingsDep,
    x_teacher_token: str | None = Header(default=None),
) -> dict[str, Any]:
    """Teacher: push preset ``name`` to every session (needs ``X-Teacher-Token`` if set)."""
    if settings.teacher_token and x_teacher_token != settings.teacher_token:
        raise HTTPException(403, "pushing to all sessions needs the teacher token")
    out = {"preset": name, "sessions": registry.push_model(_preset(name)["model"])}
    HUB.broadcast({"kind": "push", "preset": name})
    return out
