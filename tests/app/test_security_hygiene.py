"""Hostile bodies and names (issue 18, items 5 and the REST half of 2), via TestClient.

Each test failed before issue 18: the JSON and CSV ones with a 500, the advance with a 500
deep in the numerics, the rebinding one with a 200.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.cli import build_parser
from app.commands.serve import settings_of
from app.server import create_app
from app.services.explore.cost import Limits, check_model
from app.services.guard.hosts import HostAllowList, host_name
from app.services.settings import Settings
from core.base import model_from_dict
from core.exceptions import ParameterError

JSON = {"Content-Type": "application/json"}


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    app = create_app(Settings(viser_port=None, max_samples=5000))
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


@pytest.fixture
def code(client: TestClient) -> str:
    return client.app.state.registry.create().code  # (POST /api/sessions is rate-limited)


def send(client: TestClient, method: str, url: str, raw: bytes,
         headers: dict[str, str] | None = None):
    return client.request(method, url, content=raw, headers=headers or JSON)


# ----------------------------------------------------------------------- JSON bodies
@pytest.mark.parametrize(("raw", "path", "literal"), [
    (b'{"model": {"type": "pi", "p0": 1}, "mismatch": NaN}', "body.mismatch", "NaN"),
    (b'{"model": {"type": "pi"}, "signal": {"amplitude": Infinity}}',
     "body.signal.amplitude", "Infinity"),
    (b'{"model": {"type": "pi", "weights": [1, -Infinity]}}', "body.model.weights[1]",
     "-Infinity"),
    (b'{"model": {"type": "delay", "delay_s": 1e400}}', "body.model.delay_s", "1e400"),
])
def test_non_finite_numbers_are_a_422_naming_the_path(client: TestClient, raw: bytes,
                                                      path: str, literal: str) -> None:
    r = send(client, "POST", "/api/simulate", raw)
    assert r.status_code == 422, r.text
    msg = r.json()["detail"]
    assert msg.startswith(f"{path} is {literal}"), msg
    assert "must be finite" in msg


def test_non_finite_numbers_in_every_json_route(client: TestClient, code: str) -> None:
    for method, url, raw in [
        ("PATCH", f"/api/sessions/{code}/config", b'{"mismatch": NaN}'),
        ("PUT", f"/api/sessions/{code}/parameter-set", b'{"type": "delay", "delay_s": NaN}'),
        ("POST", f"/api/sessions/{code}/fit", b'{"n": Infinity}'),
        ("POST", f"/api/sessions/{code}/jobs", b'{"kind": "fit", "params": {"n": NaN}}'),
    ]:
        r = send(client, method, url, raw)
        assert r.status_code == 422, (url, r.text)
        assert "is not a finite number" in r.json()["detail"], (url, r.text)


def test_a_body_without_content_type_is_checked_too(client: TestClient, code: str) -> None:
    r = send(client, "PATCH", f"/api/sessions/{code}/config", b'{"mismatch": NaN}', headers={})
    assert r.status_code == 422, r.text
    assert r.json()["detail"].startswith("body.mismatch is NaN")


@pytest.mark.parametrize(("raw", "says"), [
    (b'{"\\ud800": 1}', 'the key "\\ud800" in body is not valid Unicode'),
    (b'{"model": {"type": "pi", "name\\udfff": 1}}', 'in body.model is not valid Unicode'),
    (b'{"signal": {"kind": "sine\\ud83d"}}', "body.signal.kind holds the unpaired surrogate"),
    (b'{"figures": ["loop", "\\udc00"]}', "body.figures[1] holds the unpaired surrogate"),
])
def test_lone_surrogates_are_a_422_naming_the_path(client: TestClient, code: str,
                                                   raw: bytes, says: str) -> None:
    for method, url in (("POST", "/api/simulate"),
                        ("PATCH", f"/api/sessions/{code}/config")):
        r = send(client, method, url, raw)
        assert r.status_code == 422, (url, r.text)
        assert says in r.json()["detail"], r.json()


def test_a_surrogate_pair_is_a_character(client: TestClient) -> None:
    r = send(client, "POST", "/api/simulate",
             b'{"model": {"type": "pi", "p0": 1, "thresholds": [0.5], "weights": [1]},'
             b' "signal": {"samples": 50}, "figures": [], "x\\ud83d\\ude00": 1}')
    assert r.json()["detail"][0]["loc"] == ["body", "x\U0001f600"], r.text  # one character


def test_invalid_utf8_json_is_a_422_naming_the_byte(client: TestClient) -> None:
    r = send(client, "POST", "/api/simulate", b'{"model": {"type": "pi\xed\xa0\x80"}}')
    assert r.status_code == 422, r.text
    assert "not valid UTF-8 at byte 22 (line 1)" in r.json()["detail"]


# ----------------------------------------------------------------------- CSV uploads
def test_a_lone_surrogate_in_a_utf16_csv_names_its_line(client: TestClient,
                                                        code: str) -> None:
    body = "t,u,y\n0,1,2\n1,\ud800,3\n".encode("utf-16", "surrogatepass")
    for url in ("/api/csv/preview", f"/api/sessions/{code}/recording"):
        r = client.post(url, content=body, headers={"Content-Type": "text/csv"})
        assert r.status_code == 422, (url, r.text)
        d = r.json()["detail"]
        assert d["line"] == 3, d
        assert "not valid UTF-16: an unpaired surrogate" in d["message"]
        assert "save the recording again" in d["message"]


def test_a_cut_off_utf16_csv_is_a_422(client: TestClient) -> None:
    body = "t,u,y\n0,1,2\n".encode("utf-16") + b"\x31"
    r = client.post("/api/csv/preview", content=body, headers={"Content-Type": "text/csv"})
    assert r.status_code == 422, r.text
    assert "cut off at the end" in r.json()["detail"]["message"]


# ----------------------------------------------------------------------- absurd models
@pytest.mark.parametrize("doc", [
    {"type": "advance", "delay_s": 1e300},
    {"type": "chain", "stages": [{"type": "pi", "p0": 1.0, "thresholds": [0.5],
                                  "weights": [1.0]}, {"type": "advance", "delay_s": 1e300}]},
])
def test_an_absurd_advance_is_refused_before_any_work(client: TestClient, code: str,
                                                      doc: dict) -> None:
    for method, url, body in [
        ("POST", "/api/simulate", {"model": doc, "signal": {"samples": 100}}),
        ("PATCH", f"/api/sessions/{code}/config", {"model": doc}),
        ("PUT", f"/api/sessions/{code}/parameter-set", doc),
    ]:
        r = client.request(method, url, json=body)
        assert r.status_code == 422, (url, r.text)
        assert "the advance's delay_s = 1e+300 s" in r.json()["detail"], r.text
        assert "shorten delay_s" in r.json()["detail"]


def test_a_delay_is_priced_in_samples_without_overflow() -> None:
    model = model_from_dict({"type": "delay", "delay_s": 1e300})
    with pytest.raises(ParameterError, match="more than 1e308 samples"):
        check_model(model, 100, 1e-300, Limits())
    ok = check_model(model_from_dict({"type": "advance", "delay_s": 0.05}), 100, 1e-3,
                     Limits())
    assert ok.delay_samples == 50


# ----------------------------------------------------------------------- DNS rebinding
def test_dns_rebinding_is_refused(client: TestClient) -> None:
    evil = "evil.example:8000"
    r = client.post("/api/broadcast/paper001-example1",
                    headers={"Host": evil, "Origin": f"http://{evil}"})
    assert r.status_code == 421, r.text
    msg = r.json()["detail"]
    assert "does not answer to the name 'evil.example'" in msg and "--allowed-host" in msg
    assert client.get("/api/health", headers={"Host": evil}).status_code == 421
    assert client.get("/", headers={"Host": evil}).status_code == 421


@pytest.mark.parametrize("host", ["127.0.0.1:8000", "localhost:8000", "LOCALHOST.",
                                  "[::1]:8000", "testserver"])
def test_own_names_are_served(client: TestClient, host: str) -> None:
    # testserver is the address TestClient's connections arrive at (the scope's server)
    assert client.get("/api/health", headers={"Host": host}).status_code == 200
    r = client.post("/api/broadcast/paper001-example1",
                    headers={"Host": host, "Origin": f"http://{host}"})
    assert r.status_code == 200, r.text


def test_the_origin_check_still_refuses_a_foreign_page(client: TestClient) -> None:
    r = client.post("/api/sessions", headers={"Host": "127.0.0.1:8000",
                                              "Origin": "http://evil.example"})
    assert r.status_code == 403


def test_allowed_hosts_bound_host_and_the_arrival_address() -> None:
    wild = HostAllowList.for_server("0.0.0.0", ("Teacher-Laptop.local",))
    assert wild.allows("teacher-laptop.local:8000")
    assert not wild.allows("0.0.0.0:8000") and not wild.allows("evil.example")
    assert wild.allows("192.168.1.10:8000", local_address="192.168.1.10")
    assert not wild.allows("evil.example:8000", local_address="127.0.0.1")
    bound = HostAllowList.for_server("192.168.1.10")
    assert bound.allows("192.168.1.10:8000") and bound.allows("[::1]")
    assert host_name("[::1]:80") == "::1" and host_name("Example.ORG.:80") == "example.org"


def test_allowed_host_option_and_env(monkeypatch: pytest.MonkeyPatch,
                                     tmp_path: Path) -> None:
    monkeypatch.setenv("HYST_ALLOWED_HOSTS", "a.example, b.example")
    args = build_parser().parse_args(["serve", "--state-dir", str(tmp_path)])
    assert settings_of(args).allowed_hosts == ("a.example", "b.example")
    args = build_parser().parse_args(["serve", "--state-dir", str(tmp_path), "--allowed-host",
                                      "class.example", "--allowed-host", "x.example"])
    s = settings_of(args)
    assert s.allowed_hosts == ("class.example", "x.example")
    app = create_app(Settings(viser_port=None, allowed_hosts=s.allowed_hosts))
    with TestClient(app, base_url="http://127.0.0.1:8000") as c:
        assert c.get("/api/health", headers={"Host": "class.example"}).status_code == 200
        assert c.get("/api/health", headers={"Host": "a.example"}).status_code == 421


def test_undecodable_bytes_to_a_json_route_are_a_422(client: TestClient, code: str) -> None:
    r = client.post(f"/api/sessions/{code}/jobs", content=b"\xed\xa0\x80",
                    headers={"Content-Type": "text/csv"})
    assert r.status_code == 422, r.text
