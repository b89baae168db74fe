"""Issue 35 item 3: unfinished requests are timed out and one client holds few connections.

Measured on 9b4b66d: 1,500 half-sent requests (one header byte every 5 s) from one process
stayed open for 40 s, and 19,980 of them took every file slot (the REST API and the viser
page stopped answering; 89 MB of ``Too many open files`` in the log in 70 s). Here a
slowloris of 40 connections on loopback against a server with short deadlines.
"""

from __future__ import annotations

import logging
import socket
import time

from app.connections import RepeatFilter, fd_headroom, http_protocol
from app.server import create_app
from app.services.settings import Settings

from .live_server import serving


def _connect(port: int, source: str = "127.0.0.1") -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.settimeout(10)
    s.bind((source, 0))
    s.connect(("127.0.0.1", port))
    return s


def _answer(s: socket.socket) -> bytes:
    """Everything the server sends until it closes the connection."""
    out = b""
    while True:
        chunk = s.recv(65536)
        if not chunk:
            return out
        out += chunk


def test_a_slowloris_is_timed_out_and_capped_per_client() -> None:
    settings = Settings(viser_port=None, header_timeout_s=1.0, body_timeout_s=1.0,
                        max_connections_per_client=20)
    protocol, guard, _ = http_protocol(settings)
    with serving(create_app(settings), http=protocol) as port:
        slow = []
        for _ in range(40):  # half-sent requests, as the probe's
            s = _connect(port)
            s.sendall(b"GET /api/capabilities HTTP/1.1\r\nHo")
            slow.append(s)
        t0 = time.monotonic()
        # another computer (127.0.0.2 is loopback too) is still served meanwhile
        victim = _connect(port, "127.0.0.2")
        victim.sendall(b"GET /api/capabilities HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                       b"Connection: close\r\n\r\n")
        assert _answer(victim).startswith(b"HTTP/1.1 200")
        answers = [_answer(s) for s in slow]
        took = time.monotonic() - t0
        refused = [a for a in answers if a.startswith(b"HTTP/1.1 503")]
        timed_out = [a for a in answers if a.startswith(b"HTTP/1.1 408")]
        assert len(refused) == 20 and len(timed_out) == 20, answers[:3]
        assert b"limit per computer" in refused[0]
        assert b"headers did not arrive within 1 s" in timed_out[0]
        assert took < 5.0  # every connection closed within the deadline (and slack)
        for s in slow:
            s.close()
        # a body that stops coming
        s = _connect(port)
        s.sendall(b"POST /api/lessons/check HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                  b"Content-Type: application/json\r\nContent-Length: 100\r\n\r\n{\"a\"")
        t0 = time.monotonic()
        out = _answer(s)
        assert out.startswith(b"HTTP/1.1 408") and b"body did not arrive" in out
        assert 0.5 < time.monotonic() - t0 < 4.0
        s.close()
        # the counts came back: a normal keep-alive client makes two requests
        s = _connect(port)
        for _ in range(2):
            s.sendall(b"GET /api/capabilities HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
            head = s.recv(65536)
            assert head.startswith(b"HTTP/1.1 200")
        s.close()
        deadline = time.monotonic() + 5
        while guard.total and time.monotonic() < deadline:
            time.sleep(0.05)
        assert guard.total == 0 and guard.timed_out >= 21


def test_file_descriptor_headroom_says_what_to_raise() -> None:
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    assert fd_headroom(16) == (soft, None)
    if hard != resource.RLIM_INFINITY:
        limit, message = fd_headroom(hard + 1)
        assert limit == hard and "ulimit -n" in message and str(hard + 1) in message
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))  # as it was


def test_a_repeated_error_is_logged_a_few_times() -> None:
    flt = RepeatFilter(burst=3, window_s=0.2)
    rec = lambda: logging.LogRecord("asyncio", logging.ERROR, __file__, 1,  # noqa: E731
                                    "socket.accept() out of system resource", (), None)
    passed = [flt.filter(rec()) for _ in range(1000)]
    assert sum(passed) == 3
    info = logging.LogRecord("uvicorn.access", logging.INFO, __file__, 1, "%s", ("x",), None)
    assert all(flt.filter(info) for _ in range(10))  # access lines are not a flood
    time.sleep(0.25)
    later = rec()
    assert flt.filter(later) and "and 997 more like it" in later.getMessage()
