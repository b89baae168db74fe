"""Sessions: per-student state by code, config updates, figures, presets, broadcast."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Header, HTTPException, Query

from ..schemas import ConfigIn
from ..state import Config, SignalSpec, compute, get_preset, validate_config
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
    """Load preset ``name`` (model and, if the preset has one, signal)."""
    doc = _preset(name)
    session.update(lambda c: _with_preset(c, doc))
    return session.summary()


def _preset(name: str) -> dict[str, Any]:
    try:
        return get_preset(name)
    except KeyError:
        raise HTTPException(404, f"no preset named {name!r}") from None


def _with_preset(cfg: Config, doc: dict[str, Any]) -> Config:
    from dataclasses import replace

    cfg = cfg.with_model(doc["model"])
    sig = doc.get("signal")
    if isinstance(sig, dict):
        fields = {k: v for k, v in sig.items() if k in SignalSpec.__dataclass_fields__}
        cfg = replace(cfg, signal=replace(cfg.signal, **fields))
    return cfg


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
    doc = _preset(name)
    sessions = registry.all()
    for s in sessions:
        s.update(lambda c: _with_preset(c, doc))
    return {"preset": name, "sessions": len(sessions)}
