"""Limits that hold (issue 18, item 7), tried the way an attacker tries them.

A forged ``X-Forwarded-For`` must not reset the per-computer limits; one computer must not
hold every live-event stream; guessing codes must not lock a student out of their own
session; tokens and codes must not reach stdout or the log. The ``hyst serve`` tests run
the real server (uvicorn) in a subprocess, where the forwarded header was trusted.
"""

from __future__ import annotations

import http.client
import json
import logging
import os
import stat
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.guard.clients import client_address, proxy_networks
from app.services.guard.redaction import MASK, RedactCodes, redact
from app.services.settings import Settings

ROOT = Path(__file__).resolve().parents[2]
UNKNOWN = "abcd-abcd-abcd-{:04d}"  # valid-looking codes that no server made


# ------------------------------------------------------------------ hyst serve, for real


@dataclass(frozen=True)
class Served:
    """A running ``hyst serve`` subprocess: its process, port and captured output file."""

    proc: subprocess.Popen[str]
    port: int
    out: Path

    def request(self, method: str, path: str, headers: dict[str, str] | None = None,
                ) -> tuple[int, dict[str, str], bytes]:
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=20)
        try:
            conn.request(method, path, headers=headers or {})
            r = conn.getresponse()
            return r.status, {k.lower(): v for k, v in r.getheaders()}, r.read()
        finally:
            conn.close()

    def output(self) -> str:
        return self.out.read_text(encoding="utf-8", errors="replace")


def _serve(tmp: Path, *extra: str) -> Iterator[Served]:
    out = tmp / "output.txt"
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1",
           "PYTHONPATH": str(ROOT)}  # this checkout, not the one the venv was installed from
    env.pop("HYST_TRUSTED_PROXIES", None)
    with out.open("w") as sink:
        proc = subprocess.Popen(
            [sys.executable, "-m", "app", "serve", "--no-browser", "--no-viser", "--port", "0",
             "--state-dir", str(tmp / "state"), "--access-log", *extra],
            cwd=ROOT, env=env, stdout=sink, stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.monotonic() + 90
        port = None
        while port is None and time.monotonic() < deadline and proc.poll() is None:
            for line in out.read_text().splitlines():
                if "web page:" in line:
                    port = int(line.split("web page:")[1].split()[0].rstrip("/")
                               .rsplit(":", 1)[1])
            time.sleep(0.1)
        assert port, f"hyst serve did not start:\n{out.read_text()}"
        yield Served(proc, port, out)
    finally:
        proc.terminate()
        proc.wait(timeout=20)


@pytest.fixture(scope="module")
def plain(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    """``hyst serve`` on loopback with no trusted proxy (the default)."""
    yield from _serve(tmp_path_factory.mktemp("plain"))


@pytest.fixture(scope="module")
def proxied(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    """``hyst serve --host 0.0.0.0 --trusted-proxy 127.0.0.1`` (a token is generated)."""
    yield from _serve(tmp_path_factory.mktemp("proxied"), "--host", "0.0.0.0",
                      "--trusted-proxy", "127.0.0.1")


def _guesses(served: Served, n: int, forged: bool) -> list[int]:
    return [served.request("GET", "/api/sessions/" + UNKNOWN.format(k),
                           {"X-Forwarded-For": f"10.9.{k // 250}.{k % 250}"} if forged
                           else None)[0] for k in range(n)]


def test_forged_forwarded_for_does_not_reset_the_limits(plain: Served) -> None:
    """Measured: rotating X-Forwarded-For from 127.0.0.1, 40/40 guesses and 20/20 new
    sessions went past the limits (uvicorn trusted the header from loopback)."""
    statuses = _guesses(plain, 30, forged=True)
    assert statuses[:20] == [404] * 20 and set(statuses[20:]) == {429}
    created = [plain.request("POST", "/api/sessions",
                             {"X-Forwarded-For": f"10.8.{k // 250}.{k % 250}"})[0]
               for k in range(215)]
    assert created.count(201) <= 205 and created.count(429) >= 10  # 200 at once, then 1/s
    status, headers, body = plain.request("POST", "/api/sessions")
    assert status == 429 and "too many new sessions" in json.loads(body)["detail"]


def test_a_trusted_proxy_forwards_each_client(proxied: Served) -> None:
    statuses = _guesses(proxied, 30, forged=True)  # 30 clients behind the proxy
    assert statuses == [404] * 30
    one = [proxied.request("GET", "/api/sessions/" + UNKNOWN.format(k),
                           {"X-Forwarded-For": "10.7.0.1"})[0] for k in range(22)]
    assert one[:20] == [404] * 20 and one[20:] == [429, 429]  # each is still limited
    # a client cannot pose as another by prepending: the right-most untrusted entry counts
    spoof = proxied.request("GET", "/api/sessions/" + UNKNOWN.format(0),
                            {"X-Forwarded-For": "10.6.0.1, 10.7.0.1"})[0]
    assert spoof == 429


def test_one_computer_cannot_hold_every_live_stream(proxied: Served) -> None:
    """Measured: one client held all 2,000 streams; other pages got 503 6 s of every 10."""
    code = json.loads(proxied.request("POST", "/api/sessions")[2])["code"]
    path = f"/api/sessions/{code}/events"
    held = []
    try:
        for _ in range(8):
            conn = http.client.HTTPConnection("127.0.0.1", proxied.port, timeout=20)
            conn.request("GET", path, headers={"X-Forwarded-For": "10.5.0.1"})
            r = conn.getresponse()
            assert r.status == 200
            held.append(conn)
        status, headers, body = proxied.request("GET", path, {"X-Forwarded-For": "10.5.0.1"})
        detail = json.loads(body)["detail"]
        assert status == 429 and "8 live explorer pages" in detail and "close" in detail
        assert int(headers["retry-after"]) >= 1
        other = http.client.HTTPConnection("127.0.0.1", proxied.port, timeout=20)
        other.request("GET", path, headers={"X-Forwarded-For": "10.5.0.2"})
        assert other.getresponse().status == 200  # another computer still connects
        held.append(other)
    finally:
        for conn in held:
            conn.close()


def test_a_generated_token_goes_to_a_private_file(proxied: Served) -> None:
    out = proxied.output()
    line = next(x for x in out.splitlines() if x.startswith("Teacher token"))
    path = Path(line.split("generated into ")[1].split(" (")[0])
    token = path.read_text().strip()
    assert len(token) >= 20 and token not in out
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert proxied.request("GET", "/api/teacher/connected",
                           {"X-Teacher-Token": token})[0] == 200


def test_codes_never_reach_the_log(plain: Served) -> None:
    code = None
    for _ in range(100):  # the creation limit of the first test may still be refilling
        status, _, body = plain.request("POST", "/api/sessions")
        if status == 201:
            code = json.loads(body)["code"]
            break
        time.sleep(0.5)
    assert code
    typed = code.replace("-", "").upper()
    for path in (f"/api/sessions/{code}", f"/api/sessions/{typed}/figures/nope",
                 f"/api/sessions/{code}/config?x={code}"):
        plain.request("GET", path)
    plain.request("PATCH", f"/api/sessions/{code}/config", {"Content-Type": "application/json"})
    time.sleep(0.5)
    out = plain.output()
    assert f"/api/sessions/{MASK}" in out  # the access log is there, masked
    assert code not in out and typed not in out and code.replace("-", "") not in out


# ------------------------------------------------------------------ in process


def test_client_address_reads_forwarded_for_only_from_trusted_peers() -> None:
    trusted = proxy_networks(["127.0.0.1", "10.0.0.0/8"])
    assert client_address("127.0.0.1", ["6.6.6.6"], ()) == "127.0.0.1"
    assert client_address("192.0.2.9", ["6.6.6.6"], trusted) == "192.0.2.9"
    assert client_address("127.0.0.1", ["6.6.6.6, 203.0.113.4"], trusted) == "203.0.113.4"
    assert client_address("127.0.0.1", ["6.6.6.6", "203.0.113.4, 10.1.1.1"],
                          trusted) == "203.0.113.4"  # proxies of the chain skipped
    assert client_address("127.0.0.1", ["not-an-address"], trusted) == "127.0.0.1"
    assert client_address("127.0.0.1", [], trusted) == "127.0.0.1"
    with pytest.raises(ValueError, match="'proxy.example' is not an IP address"):
        Settings(trusted_proxies=("proxy.example",))


def test_trusted_proxies_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HYST_TRUSTED_PROXIES", "127.0.0.1, 10.0.0.0/8")
    monkeypatch.setenv("HYST_MAX_STREAMS_PER_CLIENT", "3")
    s = Settings.from_env()
    assert s.trusted_proxies == ("127.0.0.1/32", "10.0.0.0/8")
    assert s.max_streams_per_client == 3


def test_bad_guesses_do_not_lock_out_a_known_session(tmp_path: Path) -> None:
    """Measured: 20 bad code look-ups locked the client out of its own valid session."""
    app = create_app(Settings(viser_port=None))
    with TestClient(app) as c:
        mine = c.post("/api/sessions").json()["code"]
        statuses = [c.get("/api/sessions/" + UNKNOWN.format(k)).status_code for k in range(25)]
        assert statuses[:20] == [404] * 20 and set(statuses[20:]) == {429}
        for form in (mine, mine.replace("-", "").upper()):
            assert c.get(f"/api/sessions/{form}").status_code == 200
        assert c.patch(f"/api/sessions/{mine}/config", json={}).status_code == 200
        # guessing goes on paused: a code made for someone else gets the same 429 as a
        # code that does not exist, so the answer tells nothing
        theirs = app.state.registry.create().code
        assert c.get(f"/api/sessions/{theirs}").status_code == 429
        assert c.get("/api/sessions/" + UNKNOWN.format(99)).status_code == 429
    with TestClient(app, client=("192.0.2.50", 4000)) as other:  # another computer
        assert other.get(f"/api/sessions/{theirs}").status_code == 200


def test_an_error_is_logged_with_its_code_masked(caplog: pytest.LogCaptureFixture) -> None:
    from app.security import Guard

    code = "abcd-efgh-jkmn-pqrs"

    async def boom(scope, receive, send):  # noqa: ANN001, ANN202
        raise RuntimeError(f"failed for {code}")

    c = TestClient(Guard(boom, max_body=100, max_json_depth=5))
    with caplog.at_level(logging.ERROR):
        assert c.get(f"/api/sessions/{code}/figures/loop").status_code == 500
    handler = logging.StreamHandler()
    handler.addFilter(RedactCodes())
    text = "\n".join(handler.format(r) for r in caplog.records if handler.filter(r))
    assert f"/api/sessions/{MASK}/figures/loop" in text and "failed for <code>" in text
    assert code not in text


def test_access_log_lines_are_masked() -> None:
    from uvicorn.logging import AccessFormatter

    record = logging.LogRecord("uvicorn.access", logging.INFO, __file__, 1,
                               '%s - "%s %s HTTP/%s" %d',
                               ("127.0.0.1:5000", "GET", "/api/sessions/ABCDEFGHJKMNPQRS/events",
                                "1.1", 404), None)
    assert RedactCodes().filter(record)
    line = AccessFormatter(fmt='%(client_addr)s - "%(request_line)s" %(status_code)s',
                           use_colors=False).format(record)
    assert line == f'127.0.0.1:5000 - "GET /api/sessions/{MASK}/events HTTP/1.1" 404 Not Found'
    assert redact("join abcd efgh jkmn pqrs now") == f"join {MASK} now"
    assert redact("GET /api/presets 200") == "GET /api/presets 200"
