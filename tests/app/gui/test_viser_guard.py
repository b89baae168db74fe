"""The viser port's guard (app/gui/viser_guard.py), attacked with a raw websocket client and
raw HTTP requests: foreign Origin / Host refused before the connection is accepted, security
headers on the page, new sessions per client bounded, a loud failure when viser changes."""

from __future__ import annotations

import http.client
import time
from collections.abc import Iterator
from types import SimpleNamespace
from typing import Any

import msgspec
import pytest
import viser
import websockets
import websockets.asyncio.server as ws_server
from fastapi.testclient import TestClient
from websockets.exceptions import ConnectionClosed, InvalidStatus
from websockets.sync.client import connect

from app.gui.viser_guard import (
    MAX_MESSAGE_BYTES,
    VISER_CSP,
    ViserGuard,
    ViserGuardError,
    check_viser,
    start_viser,
)
from app.server import create_app
from app.services.guard.clients import proxy_networks
from app.services.guard.hosts import HostAllowList
from app.services.guard.ratelimit import RateLimiter
from app.services.settings import Settings

PROTOCOL = f"viser-v{viser.__version__}"


@pytest.fixture(scope="module")
def served() -> Iterator[Any]:
    app = create_app(Settings(viser_port=0, port=0))
    with TestClient(app):
        yield app


#: What a browser tab sends first: viser counts a client as connected (and runs the
#: explorer's connect callback) on its first camera message.
CAMERA = msgspec.msgpack.encode({
    "type": "ViewerCameraMessage", "wxyz": [1.0, 0.0, 0.0, 0.0], "position": [0.0, 0.0, 5.0],
    "fov": 1.0, "near": 0.01, "far": 100.0, "image_height": 900, "image_width": 1500,
    "look_at": [0.0, 0.0, 0.0], "up_direction": [0.0, 0.0, 1.0]})


def _ws(port: int, **kw: Any) -> Any:
    ws = connect(f"ws://127.0.0.1:{port}/", subprotocols=[PROTOCOL], open_timeout=20,
                 max_size=None, **kw)
    ws.send(CAMERA)
    return ws


def _views(app: Any, n: int, timeout: float = 20.0) -> int:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and len(app.state.gui.views) < n:
        time.sleep(0.05)
    return len(app.state.gui.views)


def _get(port: int, path: str = "/", host: str | None = None) -> http.client.HTTPResponse:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=20)
    headers = {} if host is None else {"Host": host}
    conn.request("GET", path, headers=headers)
    return conn.getresponse()


def test_a_foreign_origin_is_refused_before_the_websocket_opens(served: Any) -> None:
    port = served.state.viser_port
    before = len(served.state.registry)
    with pytest.raises(InvalidStatus) as err:
        _ws(port, origin="http://evil.example")
    assert err.value.response.status_code == 403
    assert b"another web site" in err.value.response.body
    time.sleep(0.3)
    assert len(served.state.registry) == before  # no session was created for it


def test_a_cross_site_handshake_is_refused(served: Any) -> None:
    with pytest.raises(InvalidStatus) as err:
        _ws(served.state.viser_port, additional_headers={"Sec-Fetch-Site": "cross-site"})
    assert err.value.response.status_code == 403


def test_a_foreign_host_is_refused_on_the_websocket(served: Any) -> None:
    port = served.state.viser_port
    with pytest.raises(InvalidStatus) as err:  # DNS rebinding: Host and Origin agree
        _ws(port, origin=f"http://rebind.example:{port}",
            additional_headers={"Host": f"rebind.example:{port}"})
    assert err.value.response.status_code == 421
    assert b"--allowed-host" in err.value.response.body


def test_the_same_origin_is_accepted_and_gets_a_view(served: Any) -> None:
    port = served.state.viser_port
    n = len(served.state.gui.views)
    with _ws(port, origin=f"http://127.0.0.1:{port}") as ws:
        assert ws.subprotocol == PROTOCOL
        assert _views(served, n + 1) == n + 1


def test_the_page_sends_csp_and_no_framing(served: Any) -> None:
    r = _get(served.state.viser_port)
    assert r.status == 200 and b"<html" in r.read()
    assert r.getheader("Content-Security-Policy") == VISER_CSP
    assert "frame-ancestors 'none'" in VISER_CSP
    assert r.getheader("X-Frame-Options") == "DENY"
    assert r.getheader("X-Content-Type-Options") == "nosniff"
    missing = _get(served.state.viser_port, "/no-such-file")
    assert missing.status == 404 and missing.getheader("X-Frame-Options") == "DENY"


def test_the_page_refuses_a_foreign_host(served: Any) -> None:
    r = _get(served.state.viser_port, host="rebind.example")
    assert r.status == 421
    assert b"rebind.example" in r.read()
    assert r.getheader("X-Frame-Options") == "DENY"


def test_new_gui_sessions_per_client_are_bounded() -> None:
    app = create_app(Settings(viser_port=0, port=0))
    app.state.create_limiter = RateLimiter(burst=1, per_minute=0.01)
    with TestClient(app):
        port = app.state.viser_port
        before = len(app.state.registry)
        with _ws(port), _ws(port):
            deadline = time.monotonic() + 20
            # both tabs must have been answered: one view, one refusal (in either order)
            while time.monotonic() < deadline and not (app.state.gui.refused
                                                       and app.state.gui.views):
                time.sleep(0.05)
            assert len(app.state.gui.views) == 1
            assert len(app.state.gui.refused) == 1
            assert len(app.state.registry) == before + 1
        # the REST API shares the budget: this computer's one session is used up
        assert not app.state.create_limiter.allowed("127.0.0.1")


def test_an_unchecked_viser_version_is_refused() -> None:
    check_viser(viser.__version__)
    with pytest.raises(ViserGuardError, match="viser 2.0.0 is installed"):
        check_viser("2.0.0")


def test_start_fails_loudly_when_viser_starts_its_server_another_way(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """viser reaching ``serve`` by another path means the guard is not installed: refuse."""
    from viser.infra import _infra

    real = ws_server.serve
    elsewhere = SimpleNamespace(asyncio=SimpleNamespace(server=SimpleNamespace(serve=real)),
                                datastructures=websockets.datastructures,
                                exceptions=websockets.exceptions)
    monkeypatch.setattr(_infra, "websockets", elsewhere)
    guard = ViserGuard(HostAllowList.for_server("127.0.0.1"))
    with pytest.raises(ViserGuardError, match="Host and Origin checks are not in place"):
        start_viser("127.0.0.1", 0, guard)
    assert ws_server.serve is real


def test_the_page_names_the_browser_and_a_reload_keeps_the_session(served: Any) -> None:
    """The page sets a random browser id (not a session code, HttpOnly, SameSite=Strict);
    a websocket that brings it back gets the session its browser's last tab showed, and
    a forged cookie gets a new session."""
    port = served.state.viser_port
    r = _get(port)
    cookie = r.getheader("Set-Cookie") or ""
    assert cookie.startswith("hyst_viser=") and "HttpOnly" in cookie and \
        "SameSite=Strict" in cookie
    browser = cookie.split(";")[0]
    known = set(served.state.gui.views)
    with _ws(port, additional_headers={"Cookie": browser}):
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and set(served.state.gui.views) == known:
            time.sleep(0.05)
        (first,) = [v for k, v in served.state.gui.views.items() if k not in known]
        code = first.session.code
    assert code not in cookie
    time.sleep(0.3)
    known = set(served.state.gui.views)
    for header, same in ((browser, True), ("hyst_viser=forged-but-well-formed-id", False)):
        with _ws(port, additional_headers={"Cookie": header}):
            deadline = time.monotonic() + 20
            while time.monotonic() < deadline and set(served.state.gui.views) == known:
                time.sleep(0.05)
            (again,) = [v for k, v in served.state.gui.views.items() if k not in known]
            assert (again.session.code == code) is same
        time.sleep(0.3)
        known = set(served.state.gui.views)


def test_open_tabs_per_client_and_in_all_are_capped() -> None:
    app = create_app(Settings(viser_port=0, port=0, max_tabs_per_client=2, max_tabs=3))
    with TestClient(app):
        port = app.state.viser_port
        first, second = _ws(port), _ws(port)
        with pytest.raises(InvalidStatus) as err:  # refused before it is accepted
            _ws(port)
        assert err.value.response.status_code == 429
        assert b"HYST_MAX_TABS_PER_CLIENT" in err.value.response.body
        assert err.value.response.headers["Retry-After"]
        first.close()  # a closed tab frees its place at once
        third = _ws(port)
        # another client (a proxy names it) is refused by the server's own cap
        app.state.gui.guard.trusted_proxies = proxy_networks(("127.0.0.1",))
        other = _ws(port, additional_headers={"X-Forwarded-For": "10.0.0.7"})
        with pytest.raises(InvalidStatus) as err:
            _ws(port, additional_headers={"X-Forwarded-For": "10.0.0.8"})
        assert err.value.response.status_code == 503
        assert b"HYST_MAX_TABS" in err.value.response.body
        for ws in (second, third, other):
            ws.close()


def test_a_huge_websocket_message_closes_the_connection(served: Any) -> None:
    """viser accepts 50 MB messages; the guard lowers that, so one tab's buffers stay small."""
    with _ws(served.state.viser_port) as ws:
        ws.send(b"\x00" * (MAX_MESSAGE_BYTES + 1))
        with pytest.raises(ConnectionClosed) as err:
            for _ in range(100):
                ws.recv(timeout=10)
        assert err.value.rcvd is not None and err.value.rcvd.code == 1009  # message too big


def _upload_start(uuid: str, transfer: str, size: int, parts: int) -> bytes:
    return msgspec.msgpack.encode({
        "type": "FileTransferStartUpload", "source_component_uuid": uuid,
        "transfer_uuid": transfer, "filename": "big.csv", "mime_type": "text/csv",
        "part_count": parts, "size_bytes": size})


def _upload_part(uuid: str, transfer: str, index: int, content: bytes) -> bytes:
    return msgspec.msgpack.encode({
        "type": "FileTransferPart", "source_component_uuid": uuid, "transfer_uuid": transfer,
        "part_index": index, "content": content})


def test_uploads_are_bounded_before_a_part_is_kept() -> None:
    """viser keeps an upload's parts up to the size the client declares, with no limit;
    the guard drops one declaring more than the upload limit (and says so in the tab)."""
    app = create_app(Settings(viser_port=0, port=0, max_upload_bytes=1000))
    with TestClient(app):
        port = app.state.viser_port
        with _ws(port) as ws:
            assert _views(app, 1) == 1
            view = next(iter(app.state.gui.views.values()))
            uuid = view.ui.upload._impl.uuid
            states = app.state.viser.get_clients()[next(iter(app.state.gui.views))
                                                   ].gui._current_file_upload_states
            ws.send(_upload_start(uuid, "t-big", 10**9, 2000))  # 1 GB declared
            ws.send(_upload_start(uuid, "t-parts", 900, 10**6))  # parts that cannot be
            ws.send(_upload_start(uuid, "t-ok", 900, 2))
            ws.send(_upload_part(uuid, "t-ok", 0, b"x" * 600))
            ws.send(_upload_part(uuid, "t-ok", 1, b"x" * 600))  # beyond the declared 900
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline and states:
                time.sleep(0.05)
            time.sleep(0.3)
            assert states == {}  # nothing kept, the overflowing one dropped
            ws.send(_upload_start(uuid, "t-good", 25, 1))  # an honest small file goes on
            ws.send(_upload_part(uuid, "t-good", 0, b"t,u,y\n0,0,0\n0.001,1,1\n"[:25]))
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline and "CSV" not in view.ui.data_md.content:
                time.sleep(0.05)
            assert "CSV" in view.ui.data_md.content  # viser finished it: the view read it
