"""The explorer's outer ASGI guard: host and origin checks, bounded and clean bodies, security
headers, no 500 crash.

One pure-ASGI middleware (no framework code in the way, so it also covers the static page
and errors raised anywhere below it):

* **Own names only** (DNS rebinding): a request whose ``Host`` is not a name of this
  server (:class:`app.services.guard.hosts.HostAllowList`: loopback, the bound host, each
  ``--allowed-host``, or the address the connection arrived at) is a 421 before anything
  else, whatever its method.
* **Bounded bodies**: a POST/PUT/PATCH/DELETE body larger than ``max_upload_bytes`` is a
  413 before the app reads it; a JSON body nested deeper than ``Limits.max_json_depth`` is
  a 422 before any (recursive) parser sees it (:func:`app.services.explore.cost.json_depth`).
* **Clean JSON**: a JSON body holding ``NaN``/``Infinity`` (or a number beyond the float
  range) or an unpaired surrogate is a 422 naming its JSON path
  (:func:`app.services.guard.jsonbody.json_body_problem`).
* **Foreign origins**: a state-changing request whose ``Origin`` (or ``Sec-Fetch-Site:
  cross-site``) is not this server is refused with 403, so another web page open in a
  student's browser cannot create, change or wipe sessions.
* **Headers**: a strict Content-Security-Policy (``default-src 'self'``; scripts only from
  the server's own files — ``static/`` has no inline script, a test keeps it so; styles may
  be inline, as plotly.js needs),
  ``frame-ancestors 'none'`` and ``X-Frame-Options: DENY``, ``X-Content-Type-Options:
  nosniff``, ``Referrer-Policy: no-referrer``.
* **No crash**: an exception that reaches this layer becomes a JSON 500 saying what to do,
  sent normally (the connection is not reset) and logged with its traceback (the path's
  session code masked).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Awaitable, Callable, MutableMapping
from typing import Any

from app.services.explore.cost import json_depth
from app.services.guard.hosts import HostAllowList, foreign_origin, host_name
from app.services.guard.jsonbody import json_body_problem
from app.services.guard.redaction import redact

__all__ = ["CSP", "Guard"]

log = logging.getLogger(__name__)

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

#: The policy of every response. Styles allow inline: plotly.js inserts its own style
#: elements and attributes at run time (styles cannot run code; scripts stay 'self').
CSP = ("default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
       "img-src 'self' data: blob:; font-src 'self' data:; connect-src 'self'; "
       "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'")
_UNSAFE = frozenset({"POST", "PUT", "PATCH", "DELETE"})


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
    hosts : HostAllowList, optional
        The names a request's ``Host`` may carry; the loopback names by default.
    """

    def __init__(self, app: ASGIApp, *, max_body: int, max_json_depth: int,
                 hosts: HostAllowList | None = None) -> None:
        self.app = app
        self.max_body = max_body
        self.max_json_depth = max_json_depth
        self.hosts = hosts or HostAllowList.for_server("127.0.0.1")

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1")
                   for k, v in scope.get("headers", [])}
        started = False

        async def send_guarded(message: Message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
                hs = list(message.get("headers", []))
                have = {k.lower() for k, _ in hs}
                extra = {
                    b"content-security-policy": CSP.encode(),
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

        host = headers.get("host")
        local = (scope.get("server") or (None,))[0]
        if not self.hosts.allows(host, None if local is None else str(local)):
            await reply(*_json(421, f"this server does not answer to the name "
                                    f"{host_name(host or '')[:100]!r} (the request's Host); "
                                    "open it by its own address (as `hyst serve` printed "
                                    "it), or start it with --allowed-host NAME to add "
                                    "that name"))
            return
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
            log.exception("unhandled error in %s %s", scope.get("method"),
                          redact(str(scope.get("path"))))
            if not started:
                await reply(*_json(500, "internal error: the server could not handle this "
                                        "request; it was logged. Check the input and try "
                                        "again, or report it with the request that caused it"))

    @staticmethod
    def _foreign(headers: dict[str, str]) -> str | None:
        """Why a state-changing request comes from another site, or ``None``."""
        return foreign_origin(headers)

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
        if body and (not ctype or "json" in ctype or body.lstrip()[:1] in (b"{", b"[")):
            # whatever the declared type: a JSON body sent as text/plain, TOML or multipart
            # reaches the same parsers (issue 35 item 5)
            problem = json_body_problem(body)
            if problem:
                return body, _json(422, problem)
        return body, None
