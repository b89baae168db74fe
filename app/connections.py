"""Bounded connections on the HTTP port: every request arrives in time, no client holds many.

uvicorn closes a connection idle *between* requests (``timeout_keep_alive``), but not one
whose request never finishes arriving: on 9b4b66d 19,980 half-sent requests (one header byte
every 5 s) held every file slot of the process, the REST API and the viser page stopped
answering, and the log grew 89 MB in 70 s of ``Too many open files`` (issue 35 item 3).

:func:`guarded_protocol` wraps uvicorn's HTTP protocol class (httptools or h11) with a
:class:`ConnectionGuard`:

* **Request deadlines**: a request's headers must arrive within ``header_timeout_s`` of
  its first byte (of the connection's opening for the first request), and its body within
  ``body_timeout_s`` of the headers; otherwise the server answers ``408`` (when no answer
  has started) and closes the connection. The application sees a client that hung up.
* **Connections per client address** (``max_per_client``, the socket's peer) and in all
  (``max_total``, below the process's file-descriptor limit): one more is answered ``503``
  with the limit named and closed at once, so its file slot is free again.

:func:`fd_headroom` checks the process's file-descriptor limit at start-up (raising the soft
limit up to the hard one when needed) and says what to raise when it stays too low.
:class:`RepeatFilter` rate-limits identical log records.
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from dataclasses import dataclass
from typing import Any

__all__ = ["ConnectionGuard", "RepeatFilter", "fd_headroom", "guarded_protocol"]

#: Seconds a refused connection may stay open to take the rest of what its client sent.
LINGER_S = 1.0
#: File descriptors kept for everything but HTTP connections: the session store, worker
#: processes and their pipes, imported libraries, the log; viser's tabs come on top.
RESERVED_FDS = 256


@dataclass
class ConnectionGuard:
    """Deadlines and connection counts shared by every connection of one server.

    Parameters
    ----------
    header_timeout_s : float
        Seconds a request's headers may take to arrive.
    body_timeout_s : float
        Seconds a request's body may take to arrive once its headers have.
    max_per_client : int
        Open connections of one client address.
    max_total : int
        Open connections in all.
    """

    header_timeout_s: float = 10.0
    body_timeout_s: float = 60.0
    max_per_client: int = 100
    max_total: int = 1000

    def __post_init__(self) -> None:
        self._lock = threading.Lock()
        self._open: dict[str, int] = {}
        self.total = 0
        self.refused = 0
        self.timed_out = 0

    def admit(self, address: str) -> str | None:
        """Count one more connection of ``address``; the reason it is refused (nothing
        counted) or ``None``."""
        with self._lock:
            if self.total >= self.max_total:
                self.refused += 1
                return (f"the server holds its {self.max_total} connections; try again in a "
                        "few seconds")
            if self._open.get(address, 0) >= self.max_per_client:
                self.refused += 1
                return (f"this computer already has {self.max_per_client} connections open to "
                        "the server, the limit per computer; close pages or programs that "
                        "hold connections and try again")
            self._open[address] = self._open.get(address, 0) + 1
            self.total += 1
            return None

    def release(self, address: str) -> None:
        """One connection of ``address`` closed."""
        with self._lock:
            n = self._open.get(address, 0) - 1
            if n > 0:
                self._open[address] = n
            else:
                self._open.pop(address, None)
            self.total = max(0, self.total - 1)

    def open_of(self, address: str) -> int:
        """Open connections of ``address``."""
        with self._lock:
            return self._open.get(address, 0)


def _raw_response(status: str, text: str) -> bytes:
    body = (text + "\n").encode("utf-8")
    return (f"HTTP/1.1 {status}\r\ncontent-type: text/plain; charset=utf-8\r\n"
            f"content-length: {len(body)}\r\nconnection: close\r\n\r\n").encode() + body


def guarded_protocol(base: type[asyncio.Protocol], guard: ConnectionGuard) -> type:  # noqa: C901 - the guard's protocol class: its callbacks are closures counted into it
    """uvicorn's HTTP protocol class ``base`` with ``guard``'s deadlines and counts.

    Parameters
    ----------
    base : type
        ``uvicorn.protocols.http.httptools_impl.HttpToolsProtocol`` or ``...h11_impl.
        H11Protocol`` (both keep the current request in ``cycle``, with ``more_body``,
        ``response_started`` and ``response_complete``).
    guard : ConnectionGuard
        Shared by every connection of the server.

    Returns
    -------
    type
        A subclass to give uvicorn as ``Config(http=...)``.
    """

    class Guarded(base):  # type: ignore[misc, valid-type]
        _hx_address: str | None = None
        _hx_timer: asyncio.TimerHandle | None = None
        _hx_phase = ""
        _hx_refused = False

        def eof_received(self) -> bool | None:
            if self._hx_refused:
                self.transport.close()  # the client is done: the socket goes now
                return None
            return super().eof_received()

        def connection_made(self, transport: Any) -> None:
            peer = transport.get_extra_info("peername")
            address = str(peer[0]) if isinstance(peer, tuple) and peer else "unknown"
            refused = guard.admit(address)
            if refused is not None:
                # answered and half-closed; what the client already sent is read and dropped
                # (closing over unread data would reset the connection and lose the answer),
                # and the socket is closed within LINGER_S whatever the client does
                self._hx_refused = True
                self.transport = transport
                transport.write(_raw_response("503 Service Unavailable", refused))
                if transport.can_write_eof():
                    transport.write_eof()
                asyncio.get_running_loop().call_later(LINGER_S, transport.close)
                return
            self._hx_address = address
            super().connection_made(transport)
            self._hx_arm("headers", guard.header_timeout_s)

        def connection_lost(self, exc: Exception | None) -> None:
            if self._hx_address is None:  # refused: uvicorn never knew it
                return
            self._hx_cancel()
            guard.release(self._hx_address)
            self._hx_address = None
            super().connection_lost(exc)

        def data_received(self, data: bytes) -> None:
            if self._hx_refused:
                return
            cycle = getattr(self, "cycle", None)
            if self._hx_timer is None and (cycle is None or cycle.response_complete):
                self._hx_arm("headers", guard.header_timeout_s)  # a new request begins
            super().data_received(data)
            self._hx_progress()

        def on_response_complete(self) -> None:
            super().on_response_complete()
            if self._hx_phase == "body":  # answered before its body was read in full
                self._hx_cancel()

        def _hx_progress(self) -> None:
            """Move the deadline on when the headers or the body are complete."""
            cycle = getattr(self, "cycle", None)
            if cycle is None or cycle.response_complete or self._hx_timer is None:
                return
            if self._hx_phase == "headers":
                if cycle.more_body:
                    self._hx_arm("body", guard.body_timeout_s)
                else:
                    self._hx_cancel()
            elif self._hx_phase == "body" and not cycle.more_body:
                self._hx_cancel()

        def _hx_arm(self, phase: str, seconds: float) -> None:
            self._hx_cancel()
            self._hx_phase = phase
            self._hx_timer = self.loop.call_later(seconds, self._hx_expire)

        def _hx_cancel(self) -> None:
            if self._hx_timer is not None:
                self._hx_timer.cancel()
            self._hx_timer = None
            self._hx_phase = ""

        def _hx_expire(self) -> None:
            self._hx_timer = None
            transport = self.transport
            if transport is None or transport.is_closing():
                return
            if transport.get_protocol() is not self:  # upgraded to another protocol
                return
            guard.timed_out += 1
            cycle = getattr(self, "cycle", None)
            seconds = (guard.body_timeout_s if self._hx_phase == "body"
                       else guard.header_timeout_s)
            what = "body" if self._hx_phase == "body" else "headers"
            if cycle is None or cycle.response_complete or not cycle.response_started:
                if cycle is not None and not cycle.response_complete:
                    cycle.disconnected = True  # the application's answer is dropped
                transport.write(_raw_response(
                    "408 Request Timeout",
                    f"the request {what} did not arrive within {seconds:g} s"))
            self._hx_phase = ""
            transport.close()

    Guarded.__name__ = Guarded.__qualname__ = f"Guarded{base.__name__}"
    return Guarded


def fd_headroom(wanted: int) -> tuple[int, str | None]:
    """The process's file-descriptor limit, raised toward ``wanted`` if it is lower.

    Parameters
    ----------
    wanted : int
        Descriptors the server would like (its connections plus :data:`RESERVED_FDS`).

    Returns
    -------
    (int, str or None)
        The soft limit now, and a message for the person starting the server when it is
        below ``wanted`` (what to raise, and how), else ``None``.
    """
    try:
        import resource
    except ImportError:  # Windows: no such limit
        return wanted, None
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != resource.RLIM_INFINITY and soft < wanted:
        target = wanted if hard == resource.RLIM_INFINITY else min(wanted, hard)
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
            soft = target
        except (ValueError, OSError):
            pass
    if soft == resource.RLIM_INFINITY or soft >= wanted:
        return wanted if soft == resource.RLIM_INFINITY else soft, None
    return soft, (f"this process may open only {soft} files (the hard limit is {hard}); the "
                  f"server would like {wanted} (its connections and {RESERVED_FDS} for the "
                  "rest). It caps the connections to fit; to serve more at once, raise the "
                  "limit before starting it (`ulimit -n 8192` in the shell, or LimitNOFILE= "
                  "in a systemd unit)")


class RepeatFilter(logging.Filter):
    """Let the same warning or error through at most ``burst`` times per ``window_s`` s.

    "The same" is the logger, level and message template (``record.msg``), so a flood of
    ``Too many open files`` is a few lines, and the first record after a quiet window says
    how many were left out.

    Parameters
    ----------
    burst : int
        Records of one kind let through per window.
    window_s : float
        Length of a window, s.
    """

    def __init__(self, burst: int = 5, window_s: float = 10.0) -> None:
        super().__init__()
        self.burst = int(burst)
        self.window_s = float(window_s)
        self._lock = threading.Lock()
        self._seen: dict[tuple[str, int, str], tuple[float, int, int]] = {}

    def filter(self, record: logging.LogRecord) -> bool:  # noqa: A003 - logging's name
        if record.levelno < logging.WARNING:  # one access line per request is no flood
            return True
        key = (record.name, record.levelno, str(record.msg)[:200])
        now = time.monotonic()
        with self._lock:
            start, shown, dropped = self._seen.get(key, (now, 0, 0))
            if now - start >= self.window_s:
                if dropped:
                    record.msg = f"{record.msg} (and {dropped} more like it in the last " \
                                 f"{now - start:.0f} s, not shown)"
                start, shown, dropped = now, 0, 0
            if shown < self.burst:
                self._seen[key] = (start, shown + 1, dropped)
                if len(self._seen) > 1000:
                    self._seen.pop(next(iter(self._seen)))
                return True
            self._seen[key] = (start, shown, dropped + 1)
            return False


def http_protocol(settings: Any) -> tuple[type, ConnectionGuard, str | None]:
    """The guarded HTTP protocol class of a server with ``settings``.

    Parameters
    ----------
    settings : app.services.settings.Settings
        Its ``header_timeout_s``, ``body_timeout_s``, ``max_connections_per_client`` and
        ``max_connections`` (``0``: as many as the file-descriptor limit leaves beside
        :data:`RESERVED_FDS` and one per viser tab).

    Returns
    -------
    (type, ConnectionGuard, str or None)
        The protocol class for ``uvicorn.Config(http=...)``, its guard, and
        :func:`fd_headroom`'s message (``None`` when the limit is enough).
    """
    from uvicorn.protocols.http.auto import AutoHTTPProtocol

    spare = RESERVED_FDS + int(settings.max_tabs)
    wanted = (settings.max_connections or 4096) + spare
    limit, message = fd_headroom(wanted)
    fits = max(16, limit - spare)
    total = min(settings.max_connections or fits, fits)
    guard = ConnectionGuard(header_timeout_s=settings.header_timeout_s,
                            body_timeout_s=settings.body_timeout_s,
                            max_per_client=settings.max_connections_per_client,
                            max_total=total)
    return guarded_protocol(AutoHTTPProtocol, guard), guard, message
