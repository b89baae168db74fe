"""Shared FastAPI dependencies: settings, the session registry, a session by code.

They are ``async``: FastAPI runs a plain ``def`` dependency in a worker thread, and the
hand-over (a thread wake-up and the GIL going back and forth) cost more than the lookups
themselves (a third of a slider step's server time with the hot routes, issue 18 item 8).
They do not wait for anything but the session registry's lock and, for a session not in
memory, one SQLite read.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, HTTPException, Request

from app.services.guard.clients import client_address
from app.services.guard.ratelimit import RateLimiter
from app.services.session.sessions import Session, SessionRegistry, normalise_code
from app.services.settings import Settings

__all__ = ["RegistryDep", "SessionDep", "SettingsDep", "attachment", "client_key", "rate_limited",
           "read_body", "require_teacher"]


async def get_settings(request: Request) -> Settings:
    """The app's :class:`Settings`."""
    return request.app.state.settings


async def get_registry(request: Request) -> SessionRegistry:
    """The app's :class:`SessionRegistry`."""
    return request.app.state.registry


def client_key(request: Request) -> str:
    """The client's address (the limits are per client): the socket's peer, or, when the
    peer is a trusted proxy (``Settings.trusted_proxies``), the address it forwards."""
    return client_address(request.client.host if request.client else None,
                          request.headers.getlist("x-forwarded-for"),
                          request.app.state.settings.trusted_proxies)


def rate_limited(limiter: RateLimiter, key: str, message: str) -> HTTPException:
    """The 429 of ``limiter`` for client ``key`` (with ``Retry-After``)."""
    return HTTPException(429, message, headers={"Retry-After": str(limiter.retry_after(key))})


async def get_session(code: str, request: Request) -> Session:
    """The session ``code``; 404 if there is none, 429 after too many unknown codes.

    The pause after too many unknown codes is of this client and the codes it does not
    know yet: a session it created or opened before stays open to it
    (:class:`~app.services.guard.known_codes.KnownCodes`)."""
    key = client_key(request)
    limiter = request.app.state.lookup_limiter
    known = request.app.state.known_codes
    try:
        canonical = normalise_code(code)
    except KeyError:
        canonical = None
    familiar = canonical is not None and known.knows(key, canonical)
    if not familiar and not limiter.allowed(key):
        raise rate_limited(limiter, key, "too many unknown session codes from this computer; "
                                         "wait a minute and check the code")
    try:
        session = request.app.state.registry.get(code)
    except KeyError:
        if familiar:
            known.forget(key, canonical)
        limiter.take(key)
        raise HTTPException(404, "no such session: check the code (it looks like "
                                 "abcd-efgh-jkmn-pqrs) or start a new session") from None
    known.add(key, session.code)
    return session


def require_teacher(settings: Settings, token: str | None) -> None:
    """403 unless ``token`` may push to every session (:meth:`Settings.may_teach`: the
    teacher token, compared in constant time, whenever the server has one; a server
    reachable beyond loopback always has one)."""
    if not settings.may_teach(token):
        raise HTTPException(403, "this needs the teacher token (the one the server was "
                                 "started with)")


SettingsDep = Annotated[Settings, Depends(get_settings)]
RegistryDep = Annotated[SessionRegistry, Depends(get_registry)]
SessionDep = Annotated[Session, Depends(get_session)]


async def read_body(request: Request, limit: int) -> bytes:
    """The request body, or 413 if it is larger than ``limit`` bytes."""
    declared = request.headers.get("content-length")
    if declared is not None and declared.isdigit() and int(declared) > limit:
        raise HTTPException(413, f"body of {declared} bytes exceeds the {limit}-byte limit")
    chunks: list[bytes] = []
    size = 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise HTTPException(413, f"body exceeds the {limit}-byte limit")
        chunks.append(chunk)
    return b"".join(chunks)


def attachment(filename: str, disposition: str = "attachment") -> dict[str, str]:
    """A ``Content-Disposition`` header safe for any file name (RFC 6266 / 5987).

    Header values are Latin-1, so the plain ``filename=`` gets an ASCII fallback (other
    characters become ``_``) and ``filename*=`` carries the UTF-8 name percent-encoded.
    """
    from urllib.parse import quote

    ascii_name = "".join(c if c.isascii() and (c.isalnum() or c in "._-") else "_"
                         for c in filename) or "download"
    return {"Content-Disposition":
            f"{disposition}; filename=\"{ascii_name}\"; filename*=UTF-8''{quote(filename)}"}


def decode_text(body: bytes) -> str:
    """UTF-8 (with or without BOM) or Latin-1 text of an uploaded file."""
    try:
        return body.decode("utf-8-sig")
    except UnicodeDecodeError:
        return body.decode("latin-1")
