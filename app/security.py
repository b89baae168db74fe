"""The explorer's outer ASGI guard: bounded bodies, origin check, security headers, no 500 crash.

One pure-ASGI middleware (no framework code in the way, so it also covers the static page
and errors raised anywhere below it):

* **Bounded bodies**: a POST/PUT/PATCH/DELETE body larger than ``max_upload_bytes`` is a
  413 before the app reads it; a JSON body nested deeper than ``Limits.max_json_depth`` is
  a 422 before any (recursive) parser sees it (:func:`app.services.cost.json_depth`).
* **Foreign origins**: a state-changing request whose ``Origin`` (or ``Sec-Fetch-Site:
  cross-site``) is not this server is refused with 403, so another web page open in a
  student's browser cannot create, change or wipe sessions.
* **Headers**: a strict Content-Security-Policy (``default-src 'self'``; inline blocks of
  the static HTML pages' inline scripts are allowed by their SHA-256 hash only, computed
  at start-up; styles may be inline, as plotly.js needs),
  ``frame-ancestors 'none'`` and ``X-Frame-Options: DENY``, ``X-Content-Type-Options:
  nosniff``, ``Referrer-Policy: no-referrer``.
* **No crash**: an exception that reaches this layer becomes a JSON 500 saying what to do,
  sent normally (the connection is not reset) and logged with its traceback.
"""

from __future__ import annotations

import base64
import hashlib
import json
import logging
import re
from collections.abc import Awaitable, Callable, MutableMapping
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

from .services.cost import json_depth

__all__ = ["BASE_CSP", "Guard", "inline_hashes"]

log = logging.getLogger(__name__)

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

#: The policy of every response (pages add hashes of their own inline scripts). Styles allow
#: inline: plotly.js inserts its own style elements and attributes at run time (styles
#: cannot run code; scripts stay 'self' + hashes only).
BASE_CSP = ("default-src 'self'; script-src 'self'{script}; style-src 'self' 'unsafe-inline'; "
            "img-src 'self' data: blob:; font-src 'self' data:; connect-src 'self'; "
            "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'")
_UNSAFE = frozenset({"POST", "PUT", "PATCH", "DELETE"})
_INLINE = re.compile(rb"<(script|style)\b([^>]*)>(.*?)</\1\s*>", re.S | re.I)


def inline_hashes(static_dir: Path) -> dict[str, tuple[list[str], list[str]]]:
    """``{"/page.html": (script hashes, style hashes)}`` of the inline blocks of each page."""
    out: dict[str, tuple[list[str], list[str]]] = {}
    for page in sorted(static_dir.glob("*.html")):
        scripts: list[str] = []
        styles: list[str] = []
        for m in _INLINE.finditer(page.read_bytes()):
            if m.group(1).lower() == b"script" and b"src=" in m.group(2).lower():
                continue
            digest = base64.b64encode(hashlib.sha256(m.group(3)).digest()).decode()
            (scripts if m.group(1).lower() == b"script" else styles).append(
                f"'sha256-{digest}'")
        out[f"/{page.name}"] = (scripts, styles)
        if page.name == "index.html":
            out["/"] = (scripts, styles)
    return out


def _csp(scripts: list[str], styles: list[str]) -> str:
    del styles  # inline styles are allowed as a whole (see BASE_CSP)
    return BASE_CSP.format(script="".join(" " + h for h in scripts))


def _json(status: int, detail: Any) -> tuple[int, bytes]:
    return status, json.dumps({"detail": detail}).encode()


class Guard:
    """Pure ASGI middleware; see the module docstring.

    Parameters
    ----------
    app : ASGI app
        The wrapped application.
    max_body : int
        Largest accepted request body, bytes.
    max_json_depth : int
        Deepest accepted JSON nesting.
    static_dir : Path
        Directory of the static HTML pages (for the inline-block hashes).
    """

    def __init__(self, app: ASGIApp, *, max_body: int, max_json_depth: int,
                 static_dir: Path) -> None:
        self.app = app
        self.max_body = max_body
        self.max_json_depth = max_json_depth
        self.pages = {k: _csp(*v) for k, v in inline_hashes(static_dir).items()}
        self.default_csp = _csp([], [])

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1")
                   for k, v in scope.get("headers", [])}
        csp = self.pages.get(scope.get("path", ""), self.default_csp)
        started = False

        async def send_guarded(message: Message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
                hs = list(message.get("headers", []))
                have = {k.lower() for k, _ in hs}
                extra = {
                    b"content-security-policy": csp.encode(),
                    b"x-content-type-options": b"nosniff",
                    b"x-frame-options": b"DENY",
                    b"referrer-policy": b"no-referrer",
                    b"cross-origin-opener-policy": b"same-origin",
                }
                hs.extend((k, v) for k, v in extra.items() if k not in have)
                message = {**message, "headers": hs}
            await send(message)

        async def reply(status: int, body: bytes) -> None:
            await send_guarded({"type": "http.response.start", "status": status,
                                "headers": [(b"content-type", b"application/json"),
                                            (b"content-length", str(len(body)).encode())]})
            await send_guarded({"type": "http.response.body", "body": body})

        downstream = receive
        if scope.get("method") in _UNSAFE:
            refused = self._foreign(headers)
            if refused:
                await reply(*_json(403, refused))
                return
            body, error = await self._read(headers, receive)
            if error is not None:
                await reply(*error)
                return
            sent = False

            async def replay() -> Message:
                nonlocal sent
                if not sent:
                    sent = True
                    return {"type": "http.request", "body": body, "more_body": False}
                return await receive()

            downstream = replay
        try:
            await self.app(scope, downstream, send_guarded)
        except Exception:  # the last line of defence: log, answer, keep the connection
            log.exception("unhandled error in %s %s", scope.get("method"), scope.get("path"))
            if not started:
                await reply(*_json(500, "internal error: the server could not handle this "
                                        "request; it was logged. Check the input and try "
                                        "again, or report it with the request that caused it"))

    @staticmethod
    def _foreign(headers: dict[str, str]) -> str | None:
        """Why a state-changing request comes from another site, or ``None``."""
        if headers.get("sec-fetch-site") == "cross-site":
            return "requests from another web site may not change sessions"
        origin = headers.get("origin")
        if origin is None:
            return None  # not a browser's cross-origin request (curl, scripts, same-origin GET)
        host = headers.get("host", "")
        try:
            parts = urlsplit(origin)
        except ValueError:
            return "the request's Origin header is malformed"
        if origin == "null" or parts.netloc.lower() != host.lower():
            return (f"requests from another web site ({origin[:100]}) may not change "
                    "sessions; open the explorer's own page")
        return None

    async def _read(self, headers: dict[str, str],
                    receive: Receive) -> tuple[bytes, tuple[int, bytes] | None]:
        declared = headers.get("content-length", "")
        if declared.isdigit() and int(declared) > self.max_body:
            return b"", _json(413, f"body of {int(declared):,} bytes exceeds the "
                                   f"{self.max_body:,}-byte limit")
        chunks: list[bytes] = []
        size = 0
        while True:
            msg = await receive()
            if msg["type"] == "http.disconnect":
                break
            chunk = msg.get("body", b"")
            size += len(chunk)
            if size > self.max_body:
                return b"", _json(413, f"body exceeds the {self.max_body:,}-byte limit")
            chunks.append(chunk)
            if not msg.get("more_body", False):
                break
        body = b"".join(chunks)
        ctype = headers.get("content-type", "")
        if ("json" in ctype or body[:1] in (b"{", b"[")) and \
                json_depth(body) > self.max_json_depth:
            return body, _json(422, f"the JSON body is nested more than "
                                    f"{self.max_json_depth} levels deep; flatten it")
        return body, None
