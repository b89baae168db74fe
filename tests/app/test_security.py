"""The server as an attacker and a crowd of students see it (issue 10), via TestClient.

Every test here failed on the code before issue 10: it names the numbered failure of the
issue it covers.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.settings import Settings
from core.pi import PIModel

ROOT = Path(__file__).resolve().parents[2]

PI = {"type": "pi", "p0": 1.0, "thresholds": [0.5], "weights": [1.0]}


def settings(tmp: Path, **kw: object) -> Settings:
    return Settings(viser_port=None, max_upload_bytes=6_000_000, **kw)


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    app = create_app(settings(tmp_path_factory.mktemp("state")))
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


@pytest.fixture
def code(client: TestClient) -> str:
    r = client.post("/api/sessions")
    assert r.status_code == 201
    return r.json()["code"]


def csv_text(n: int = 300, header: str = "t,u,y", run: str | None = None) -> str:
    t = np.arange(n) * 1e-3
    u = 3 * np.sin(2 * np.pi * 5 * t)
    y = PIModel.from_dict(PI)(u)
    rows = [f"{a:.6g},{b:.8g},{c:.8g}" for a, b, c in zip(t, u, y, strict=True)]
    if run is not None:
        rows = [f"{run},{r}" for r in rows]
    return f"{header}\n" + "\n".join(rows) + "\n"


def upload(client: TestClient, code: str, body: str | bytes, **params: str):
    return client.post(f"/api/sessions/{code}/recording", content=body,
                       headers={"Content-Type": "text/csv"}, params=params)


# ------------------------------------------------- 1. it reads its own files / 8. uploads
def test_a_body_naming_a_server_file_is_data(client: TestClient, code: str,
                                             tmp_path: Path) -> None:
    """Failure 1: a newline-free body was opened as a path (and its lines quoted back)."""
    secret = tmp_path / "numbers.csv"
    secret.write_text(csv_text(50))
    for body in (str(secret), str(tmp_path / "nope.csv"), "/etc/passwd"):
        for r in (client.post("/api/csv/preview", content=body,
                              headers={"Content-Type": "text/csv"}),
                  upload(client, code, body)):
            assert r.status_code == 422, r.text
            msg = r.json()["detail"]["message"]
            assert "no such file" not in msg and "root:" not in msg and "0.001" not in msg
    assert client.get(f"/api/sessions/{code}").json()["recording"] is None


def test_upload_accepts_utf16_like_the_cli(client: TestClient, code: str) -> None:
    """Failure 8: a UTF-16 CSV that ``hyst fit`` reads was refused by the upload."""
    r = upload(client, code, csv_text().encode("utf-16"))
    assert r.status_code == 201, r.text
    assert r.json()["samples"] == 300
    p = client.post("/api/csv/preview", content=csv_text().encode("utf-16"),
                    headers={"Content-Type": "text/csv"})
    assert p.status_code == 200 and p.json()["columns"] == ["t", "u", "y"]


def test_upload_reports_the_cleaning_notes(client: TestClient, code: str) -> None:
    """Failure 8: removed rows were not reported by the upload response."""
    lines = csv_text().splitlines()
    lines[10] = lines[10].rsplit(",", 1)[0] + ",nan"
    r = upload(client, code, "\n".join(lines) + "\n")
    assert r.status_code == 201
    notes = r.json()["notes"]
    assert any("removed 1 row" in n and "11" in n for n in notes), notes


def test_run_column_is_chosen_and_said(client: TestClient, code: str) -> None:
    """Failure 8: a file with a run column silently kept run 1 of 2."""
    a = csv_text(200, header="run,t,u,y", run="1")
    b = csv_text(200, header="run,t,u,y", run="2").split("\n", 1)[1]
    body = a + b
    r = upload(client, code, body)
    assert r.status_code == 201
    j = r.json()
    # by default every run is kept, each its own loop, as hyst fit and hyst diagnose read it
    assert j["runs"] == ["1", "2"] and j["run"] == "each" and j["samples"] == 400
    assert any("all 2 runs" in n and "each its own loop" in n for n in j["notes"])
    r2 = upload(client, code, body, run="2")
    assert r2.status_code == 201 and r2.json()["run"] == "2" and r2.json()["samples"] == 200
    assert any("holds 2 runs" in n and "run=" in n for n in r2.json()["notes"])
    # the two runs each start at t = 0: their rows are no one recording, and the error says so
    r3 = upload(client, code, body, run="all")
    assert r3.status_code == 422
    assert "each start their own time" in r3.json()["detail"]["message"]
    assert "each its own loop" in r3.json()["detail"]["message"]
    bad = upload(client, code, body, run="7")
    assert bad.status_code == 422 and "1, 2" in bad.json()["detail"]["message"]


# ------------------------------------------------------------------ 6. no input yields a 500
def nested(depth: int) -> dict:
    d: dict = PI
    for _ in range(depth):
        d = {"type": "chain", "stages": [d]}
    return d


def raw_nested(depth: int) -> bytes:
    return (b'{"model":' + b'{"type":"chain","stages":[' * depth + b'{"type":"pi","p0":1,'
            b'"thresholds":[0.5],"weights":[1]}' + b"]}" * depth + b"}")


@pytest.mark.parametrize("depth", [15, 300, 100_000])
def test_deep_nesting_is_refused_before_recursion(client: TestClient, code: str,
                                                  depth: int) -> None:
    """Failure 6: chains 300 deep were stored and broke the session; deeper ones raised
    RecursionError."""
    for url, method in ((f"/api/sessions/{code}/config", "PATCH"), ("/api/simulate", "POST")):
        r = client.request(method, url, content=raw_nested(depth),
                           headers={"Content-Type": "application/json"})
        assert r.status_code == 422, (depth, r.text[:200])
        assert "nested" in r.text
    r = client.put(f"/api/sessions/{code}/parameter-set", content=raw_nested(depth))
    assert r.status_code == 422 and "nested" in r.text
    assert client.get(f"/api/sessions/{code}/figures").status_code == 200
    assert client.get(f"/api/sessions/{code}/export/json").status_code == 200


@pytest.mark.parametrize(
    ("stage", "words"),
    [
        ({"type": "delay", "delay_s": 1e300}, "delay_s"),
        ({"type": "delay", "delay_s": 1e5}, "delay_s"),
        ({"type": "lag", "tau_s": 5e-324}, "tau_s"),
        ({"type": "resonance", "freq_hz": 1e-9, "damping": 0.1}, "freq_hz"),
        ({"type": "lti", "num": [1.0], "den": [1.0] * 1501}, "lti order 1500"),
        ({"type": "creep", "taus_s": list(range(1, 101)), "weights": [0.01] * 100}, "creep"),
        ({"type": "creep", "taus_s": list(range(1, 100_001)),
          "weights": [0.0] * 100_000}, "numbers"),
        ({"type": "rate", "p0": 1, "thresholds": list(np.arange(1, 151) / 100),
          "weights": [0.01] * 150, "beta_s": 0.1}, "151 operators"),
        ({"type": "initial-memory", "history": [1, -1],
          "model": {"type": "pi", "p0": 1, "thresholds": list(np.arange(1, 151) / 100),
                    "weights": [0.01] * 150}}, "151 operators"),
    ],
)
def test_every_model_type_has_a_bounded_cost(client: TestClient, code: str, stage: dict,
                                             words: str) -> None:
    """Failures 3 and 6: the operator limit skipped rate/initial-memory/creep; extreme
    delays, lags and resonances were 500s or took gigabytes."""
    model = {"type": "chain", "stages": [PI, stage]}
    r = client.post("/api/simulate", json={"model": model, "figures": ["time"]})
    assert r.status_code == 422, r.text[:300]
    assert words in r.json()["detail"]
    r = client.patch(f"/api/sessions/{code}/config", json={"model": model})
    assert r.status_code == 422
    assert client.get(f"/api/sessions/{code}").json()["config"]["model"]["type"] == "pi"


def test_limits_are_published(client: TestClient) -> None:
    lim = client.get("/api/capabilities").json()["limits"]
    for key in ("max_operators", "max_samples", "max_model_depth", "max_creep_terms",
                "max_lti_order", "max_work", "max_json_depth"):
        assert lim[key] > 0


def test_download_names_are_header_safe() -> None:
    """Failure 6: a non-Latin-1 session code broke every export (header encoding)."""
    from app.routers.deps import attachment

    h = attachment("hysteresis-pi-ßcode-日本.json")["Content-Disposition"]
    h.encode("latin-1")  # what the ASGI server needs
    assert 'filename="hysteresis-pi-_code-__.json"' in h
    assert "filename*=UTF-8''hysteresis-pi-%C3%9Fcode-%E6%97%A5%E6%9C%AC.json" in h


def test_unhandled_errors_are_json_and_keep_the_connection() -> None:
    """Failure 6: after a 500 the connection was reset."""
    from app.security import Guard

    async def boom(scope, receive, send):  # noqa: ANN001, ANN202
        raise RuntimeError("bug")

    c = TestClient(Guard(boom, max_body=100, max_json_depth=5))
    for _ in range(2):  # the same connection answers again
        r = c.get("/x")
        assert r.status_code == 500 and "internal error" in r.json()["detail"]
        assert r.headers["x-content-type-options"] == "nosniff"


# ------------------------------------------------------------------ 2./4. headers and origin
def test_security_headers(client: TestClient) -> None:
    """Failure 2: no CSP, X-Frame-Options or nosniff."""
    for url in ("/", "/api/health", "/api.html", "/app.js"):
        h = client.get(url).headers
        csp = h["content-security-policy"]
        assert "default-src 'self'" in csp and "frame-ancestors 'none'" in csp
        script_src = csp.split("script-src")[1].split(";")[0]
        assert "'self'" in script_src and "unsafe" not in script_src
        assert h["x-content-type-options"] == "nosniff" and h["x-frame-options"] == "DENY"


def test_static_pages_have_no_inline_script() -> None:
    """The CSP allows scripts from the server's files only: an inline script or event-handler
    attribute in a static page would be blocked in the browser (and is an injection sink)."""
    pages = sorted((ROOT / "static").glob("*.html"))
    assert pages
    for page in pages:
        html = page.read_text(encoding="utf-8")
        for m in re.finditer(r"<script\b([^>]*)>(.*?)</script\s*>", html, re.S | re.I):
            assert "src=" in m.group(1) and not m.group(2).strip(), (page.name, m.group(0)[:80])
        assert not re.search(r"\son[a-z]+\s*=", html, re.I), page.name


def test_foreign_origins_cannot_change_state(client: TestClient, code: str) -> None:
    """Failure 4: POST /api/sessions was accepted from a foreign Origin."""
    evil = {"Origin": "http://evil.example"}
    assert client.post("/api/sessions", headers=evil).status_code == 403
    assert client.patch(f"/api/sessions/{code}/config", json={"mismatch": 0.1},
                        headers=evil).status_code == 403
    assert client.post("/api/sessions", headers={"Sec-Fetch-Site": "cross-site"}
                       ).status_code == 403
    assert client.post("/api/sessions", headers={"Origin": "http://testserver"}
                       ).status_code == 201
    assert client.get(f"/api/sessions/{code}", headers=evil).status_code == 200


# ------------------------------------------------------------------ 5. credentials
def test_codes_are_long_random_and_made_by_the_server(client: TestClient) -> None:
    """Failure 5: 6-character codes (30 bits); PUT /api/sessions/abc created a session."""
    import math

    from app.services.session.sessions import CODE_ALPHABET, CODE_LENGTH

    assert CODE_LENGTH * math.log2(len(set(CODE_ALPHABET))) >= 64
    codes = {client.post("/api/sessions").json()["code"] for _ in range(20)}
    assert len(codes) == 20 and all(len(c.replace("-", "")) == CODE_LENGTH for c in codes)
    r = client.put("/api/sessions/abc")
    assert r.status_code == 404 and "no such session" in r.json()["detail"]
    assert client.get("/api/sessions/abc").status_code == 404


def test_failed_lookups_are_rate_limited(tmp_path: Path) -> None:
    """Failure 5: 2,860 guesses a minute, never a 429."""
    app = create_app(settings(tmp_path))
    with TestClient(app) as c:
        good = app.state.registry.create().code  # a session this client never opened
        codes = [c.get(f"/api/sessions/{'abcd' * 3}{k:04d}") for k in range(40)]
        statuses = [r.status_code for r in codes]
        assert statuses[:20] == [404] * 20 and set(statuses[20:]) == {429}
        assert int(codes[-1].headers["retry-after"]) >= 1
        assert c.get(f"/api/sessions/{good}").status_code == 429  # guessing is paused


def test_session_flood_cannot_evict_a_class(tmp_path: Path) -> None:
    """Failure 4: 600 POST /api/sessions in 1.5 s evicted idle sessions (a teacher's too)."""
    with TestClient(create_app(settings(tmp_path, max_sessions=50))) as c:
        teacher = c.post("/api/sessions").json()["code"]
        assert upload(c, teacher, csv_text()).status_code == 201
        assert c.post(f"/api/sessions/{teacher}/fit", json={"n": 4}).status_code == 200
        statuses = [c.post("/api/sessions").status_code for _ in range(600)]
        assert statuses.count(201) <= 210 and statuses.count(429) >= 390  # 200 + 1 a second
        s = c.get(f"/api/sessions/{teacher}").json()
        assert s["recording"]["samples"] == 300 and s["fitted"] is not None


def test_broadcast_beyond_loopback_needs_the_token(tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    """Failure 5: with --host 0.0.0.0 and no token anyone could broadcast; `!=` compare."""
    import hmac

    calls: list[int] = []
    real = hmac.compare_digest
    monkeypatch.setattr(hmac, "compare_digest",
                        lambda a, b: calls.append(1) or real(a, b))
    app = create_app(settings(tmp_path, host="0.0.0.0"))
    token = app.state.settings.teacher_token
    assert token and len(token) >= 20
    with TestClient(app) as c:
        assert c.post("/api/broadcast/paper001-example1").status_code == 403
        assert c.post("/api/broadcast/paper001-example1",
                      headers={"X-Teacher-Token": "guess"}).status_code == 403
        ok = c.post("/api/broadcast/paper001-example1", headers={"X-Teacher-Token": token})
        assert ok.status_code == 200
    assert calls, "the token must be compared with hmac.compare_digest"


def test_public_host_says_what_it_exposes(capsys) -> None:  # noqa: ANN001
    from types import SimpleNamespace

    from app.commands.serve import _announce

    sock = SimpleNamespace(getsockname=lambda: ("0.0.0.0", 8123))
    server = SimpleNamespace(started=True, should_exit=False,
                             servers=[SimpleNamespace(sockets=[sock])])
    app = SimpleNamespace(state=SimpleNamespace(viser_port=8124))
    s, generated = Settings(host="0.0.0.0", state_dir="/tmp/x").with_teacher_token()
    assert generated
    _announce(server, app, s, Path("/tmp/x/teacher-token"), False)
    out = capsys.readouterr().out
    assert "WARNING: listening on 0.0.0.0" in out and "8123" in out and "8124" in out
    assert "Teacher token (needed to push presets to every session): generated into " \
           "/tmp/x/teacher-token" in out and s.teacher_token not in out


def test_teacher_token_from_file_or_env(tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    from app.cli import build_parser
    from app.commands.serve import _token

    f = tmp_path / "token"
    f.write_text("from-a-file\n")
    args = build_parser().parse_args(["serve", "--teacher-token-file", str(f)])
    assert _token(args) == "from-a-file"
    monkeypatch.setenv("HYST_TEACHER_TOKEN", "from-env")
    assert Settings.from_env(teacher_token=None).teacher_token == "from-env"
