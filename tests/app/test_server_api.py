"""REST API of the explorer, through FastAPI's TestClient (runs the lifespan, so viser too)."""

from __future__ import annotations

import io
import json
import shutil
from collections.abc import Iterator

import numpy as np
import plotly.graph_objects as go
import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.settings import Settings
from core.pi import PIModel

EX1 = {
    "type": "pi",
    "p0": 0.72,
    "thresholds": [0.45, 0.9, 1.35, 1.8, 2.25, 2.7],
    "weights": [0.6, 0.48, 0.36, 0.24, 0.12, 0.012],
}
SETTINGS = Settings(viser_port=0, max_upload_bytes=200_000, max_samples=20_000, max_operators=40)


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(SETTINGS)) as c:
        yield c


@pytest.fixture
def code(client: TestClient) -> str:
    r = client.post("/api/sessions")
    assert r.status_code == 201
    return r.json()["code"]


def _csv(n: int = 600, header: str = "t,u,y") -> str:
    t = np.arange(n) * 1e-3
    u = 3 * np.sin(2 * np.pi * 2 * t) * np.exp(-t)
    y = PIModel.from_dict(EX1)(u) + 0.05
    rows = "\n".join(f"{a:.6g},{b:.8g},{c:.8g}" for a, b, c in zip(t, u, y, strict=True))
    return f"{header}\n{rows}\n"


def _upload(client: TestClient, code: str, text: str, **params: str):
    return client.post(f"/api/sessions/{code}/recording", content=text,
                       headers={"Content-Type": "text/csv"}, params=params)


# ----------------------------------------------------------------- meta
def test_health_and_viser_url(client: TestClient) -> None:
    assert client.get("/api/health").json() == {"status": "ok"}
    v = client.get("/api/viser-url").json()
    assert v["enabled"] and v["port"] > 0


def test_capabilities_and_presets(client: TestClient) -> None:
    caps = client.get("/api/capabilities").json()
    assert "pi" in caps["model_types"] and "sine" in caps["signals"]
    assert caps["limits"]["max_operators"] == 40
    presets = client.get("/api/presets").json()
    assert presets and all("model" in p for p in presets)


def test_static_page_and_vendored_plotly(client: TestClient) -> None:
    page = client.get("/")
    assert page.status_code == 200 and "/vendor/plotly.min.js" in client.get("/app.js").text
    assert "cdn" not in page.text.lower()
    js = client.get("/vendor/plotly.min.js")
    assert js.status_code == 200 and len(js.content) > 1_000_000
    assert client.get("/app.js").status_code == 200
    assert "/openapi.json" in client.get("/api.html").text  # offline API reference
    assert client.get("/openapi.json").json()["info"]["title"] == "Hysteresis Explorer"


# ----------------------------------------------------------------- simulate
def test_simulate_example1_matches_core(client: TestClient) -> None:
    r = client.post("/api/simulate", json={
        "model": EX1, "signal": {"samples": 1001}, "include_data": True,
        "figures": ["time", "loop", "operators", "loading", "inverse"]})
    assert r.status_code == 200
    body = r.json()
    m = PIModel.from_dict(EX1)
    np.testing.assert_allclose(body["slopes"], m.slopes)
    assert body["max_loop_width"] == pytest.approx(1.518, abs=1e-3)  # paper 001 Example 1
    np.testing.assert_allclose(body["data"]["y"], m(np.array(body["data"]["u"])), atol=1e-12)
    for fig in body["figures"].values():
        go.Figure(fig)  # valid plotly


@pytest.mark.parametrize(
    ("payload", "status", "text"),
    [
        ({"model": {**EX1, "thresholds": [0.9, 0.45, 1.35, 1.8, 2.25, 2.7]}}, 422, "increasing"),
        ({"model": {**EX1, "weights": [1.0]}}, 422, "weights"),
        ({"model": {"type": "nope"}}, 422, "unknown model type"),
        ({"model": {"type": "pi", "p0": 1, "thresholds": list(np.arange(1.0, 42)),
                    "weights": [0.1] * 41}}, 422, "at most 40"),
        # a chain may not bypass the operator limit
        ({"model": {"type": "chain", "stages": [
            {"type": "pi", "p0": 1, "thresholds": list(np.arange(1.0, 42)),
             "weights": [0.1] * 41},
            {"type": "offset", "offset": 0.5}]}}, 422, "at most 40"),
        ({"model": EX1, "signal": {"samples": 50_000}}, 422, "samples"),
        ({"model": EX1, "signal": {"duration": -1}}, 422, "duration"),
        ({"model": EX1, "signal": {"kind": "square-ish"}}, 422, "unknown"),
        ({"model": EX1, "mismatch": 3}, 422, "mismatch"),
        ({"model": EX1, "figures": ["nope"]}, 422, "unknown figure"),
        ({"model": EX1, "extra": 1}, 422, "extra"),
    ],
)
def test_simulate_rejects_out_of_range(client: TestClient, payload: dict, status: int,
                                       text: str) -> None:
    r = client.post("/api/simulate", json=payload)
    assert r.status_code == status
    assert text in json.dumps(r.json()).lower()


def test_chain_reports_its_operator_count(client: TestClient) -> None:
    chain = {"type": "chain", "stages": [EX1, {"type": "offset", "offset": 0.5}]}
    r = client.post("/api/simulate", json={"model": chain})
    assert r.status_code == 200
    assert r.json()["model_type"] == "chain" and r.json()["n_operators"] == 6


def test_simulate_bad_json(client: TestClient) -> None:
    r = client.post("/api/simulate", content=b"{not json",
                    headers={"Content-Type": "application/json"})
    assert r.status_code == 422


def test_closed_loop_and_digitized_figures(client: TestClient) -> None:
    r = client.post("/api/simulate", json={"model": EX1, "figures": ["closed-loop", "digitized"],
                                          "signal": {"duration": 1.0, "samples": 1000}})
    assert r.status_code == 200
    figs = r.json()["figures"]
    title = figs["closed-loop"]["layout"]["title"]["text"]
    assert "no compensation" in title and "inverse feedforward" in title
    assert "Digitized PI: n = 7 digits" in figs["digitized"]["layout"]["title"]["text"]
    for f in figs.values():
        go.Figure(f)
    # a model whose half span is below the largest threshold: a message, not an error
    r = client.post("/api/simulate", json={"model": EX1, "figures": ["digitized"],
                                          "signal": {"amplitude": 1.0}})
    assert "raise the amplitude" in json.dumps(r.json()["figures"]["digitized"])


def test_non_invertible_model_is_a_message_not_an_error(client: TestClient) -> None:
    r = client.post("/api/simulate", json={"model": {**EX1, "p0": -0.2}, "figures": ["inverse"]})
    assert r.status_code == 200
    body = r.json()
    assert body["invertible"] is False and "p0" in body["inverse_error"]
    assert "not invertible" in json.dumps(body["figures"]["inverse"])


def test_inverse_compensation_is_exact_without_mismatch(client: TestClient) -> None:
    r = client.post("/api/simulate", json={"model": EX1, "figures": ["inverse"]})
    title = r.json()["figures"]["inverse"]["layout"]["title"]["text"]
    rms = float(title.rsplit("RMS error ", 1)[1].rstrip(")"))
    assert rms < 1e-9
    r = client.post("/api/simulate", json={"model": EX1, "figures": ["inverse"], "mismatch": 0.3})
    title = r.json()["figures"]["inverse"]["layout"]["title"]["text"]
    assert float(title.rsplit("RMS error ", 1)[1].rstrip(")")) > 0.01


# ----------------------------------------------------------------- sessions
def test_session_lifecycle(client: TestClient, code: str) -> None:
    s = client.get(f"/api/sessions/{code}").json()
    assert s["config"]["model"] == EX1 and s["version"] == 0
    r = client.patch(f"/api/sessions/{code}/config",
                     json={"mismatch": 0.1, "signal": {"amplitude": 2.0, "samples": 500}})
    assert r.status_code == 200 and r.json()["version"] == 1
    figs = client.get(f"/api/sessions/{code}/figures", params=[("name", "loop"), ("name", "time")])
    assert set(figs.json()["figures"]) == {"loop", "time"}
    assert figs.json()["version"] == 1


def test_session_rejects_invalid_config_and_keeps_old(client: TestClient, code: str) -> None:
    bad = {**EX1, "thresholds": [-1, 0.9, 1.35, 1.8, 2.25, 2.7]}
    r = client.patch(f"/api/sessions/{code}/config", json={"model": bad})
    assert r.status_code == 422 and "thresholds" in r.json()["detail"]
    assert client.get(f"/api/sessions/{code}").json()["config"]["model"] == EX1


def test_sessions_are_isolated(client: TestClient) -> None:
    a = client.post("/api/sessions").json()["code"]
    b = client.post("/api/sessions").json()["code"]
    client.patch(f"/api/sessions/{a}/config", json={"model": {**EX1, "p0": 1.5}})
    assert client.get(f"/api/sessions/{b}").json()["config"]["model"]["p0"] == 0.72


def test_join_by_code_and_unknown_session(client: TestClient, code: str) -> None:
    typed = code.upper().replace("-", " ")  # case, spaces and dashes do not matter
    assert client.put(f"/api/sessions/{typed}").json()["code"] == code
    r = client.put("/api/sessions/class-7")  # codes are made by the server only
    assert r.status_code == 404 and "no such session" in r.json()["detail"]
    assert client.get("/api/sessions/doesnotexist").status_code == 404
    assert client.patch("/api/sessions/doesnotexist/config", json={}).status_code == 404


def test_presets_and_broadcast(client: TestClient, code: str) -> None:
    names = client.get("/api/capabilities").json()["presets"]
    r = client.post(f"/api/sessions/{code}/preset/{names[-1]}")
    assert r.status_code == 200
    assert client.post(f"/api/sessions/{code}/preset/nope").status_code == 404
    out = client.post(f"/api/broadcast/{names[0]}").json()
    assert out["sessions"] >= 1
    first = client.get("/api/presets").json()[0]["model"]
    assert client.get(f"/api/sessions/{code}").json()["config"]["model"] == first


def test_broadcast_needs_teacher_token_when_set() -> None:
    with TestClient(create_app(Settings(viser_port=None, teacher_token="s3cret"))) as c:
        assert c.post("/api/broadcast/paper001-example1").status_code == 403
        r = c.post("/api/broadcast/paper001-example1", headers={"X-Teacher-Token": "s3cret"})
        assert r.status_code == 200


# ----------------------------------------------------------------- data
def test_csv_preview(client: TestClient) -> None:
    r = client.post("/api/csv/preview", content=_csv(20), headers={"Content-Type": "text/csv"})
    assert r.status_code == 200
    assert r.json()["columns"] == ["t", "u", "y"] and r.json()["n_rows"] == 20


def test_upload_fit_diagnose(client: TestClient, code: str) -> None:
    r = _upload(client, code, _csv(header="time;input;output").replace(",", ";"))
    assert r.status_code == 201 and r.json()["samples"] == 600
    fit = client.post(f"/api/sessions/{code}/fit", json={"n": 8})
    assert fit.status_code == 200
    assert fit.json()["report"]["nrmse_percent"] < 2.0
    go.Figure(fit.json()["figure"])
    s = client.get(f"/api/sessions/{code}").json()
    assert s["fitted"] == s["config"]["model"]
    assert client.get(f"/api/sessions/{code}/diagnosis/report.html").status_code == 409
    d = client.post(f"/api/sessions/{code}/diagnose")
    assert d.status_code == 200 and d.json()["findings"]
    html = client.get(f"/api/sessions/{code}/diagnosis/report.html")
    assert html.status_code == 200 and "diagnosis" in html.text.lower()
    assert "<script src=\"http" not in html.text  # plotly.js inlined, nothing remote


@pytest.mark.parametrize("kind", ["gpi-deadzone", "mpi", "gpi-tanh", "digitized"])
def test_fit_other_model_kinds(client: TestClient, code: str, kind: str) -> None:
    assert kind in client.get("/api/capabilities").json()["fit_kinds"]
    _upload(client, code, _csv(800))
    r = client.post(f"/api/sessions/{code}/fit", json={"n": 6, "kind": kind})
    assert r.status_code == 200, r.text
    assert r.json()["report"]["kind"] == kind
    assert client.get(f"/api/sessions/{code}/figures", params={"name": "loop"}).status_code == 200
    assert client.post(f"/api/sessions/{code}/fit", json={"kind": "nope"}).status_code == 422


def test_upload_with_column_mapping(client: TestClient, code: str) -> None:
    text = _csv(50, header="a,b,c")
    r = _upload(client, code, text, t_col="0", u_col="b", y_col="c")
    assert r.status_code == 201
    r = _upload(client, code, text, u_col="zz")
    assert r.status_code == 422 and "zz" in r.json()["detail"]["message"]


@pytest.mark.parametrize(
    ("text", "line", "column"),
    [
        ("t,u,y\n0,1,2\n0.001,1,abc\n0.002,1,2\n", 3, 2),
        ("t,u,y\n0,1,2\n0.001,1\n", 3, None),
        ("", None, None),
        ("t,u,y\n", 1, None),
        ("t,u,y\n0,1,2\n0,1,2\n0.1,2,3\n", 3, 0),
    ],
)
def test_bad_csv_is_422_with_location(client: TestClient, code: str, text: str,
                                      line: int | None, column: int | None) -> None:
    r = _upload(client, code, text)
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert detail["message"]
    assert detail["line"] == line and detail["column"] == column


def test_upload_too_large_and_wrong_type(client: TestClient, code: str) -> None:
    big = "t,u,y\n" + "0.0,1.0,2.0\n" * 30_000
    assert _upload(client, code, big).status_code == 413
    r = client.post(f"/api/sessions/{code}/recording", content=b"{}",
                    headers={"Content-Type": "application/json"})
    assert r.status_code == 415


def test_fit_and_diagnose_need_recording(client: TestClient, code: str) -> None:
    assert client.post(f"/api/sessions/{code}/fit", json={"n": 5}).status_code == 409
    assert client.post(f"/api/sessions/{code}/diagnose").status_code == 409
    _upload(client, code, _csv(200))
    assert client.post(f"/api/sessions/{code}/fit", json={"n": 500}).status_code == 422
    assert client.post(f"/api/sessions/{code}/fit", json={"n": 0}).status_code == 422


# ----------------------------------------------------------------- export
def test_export_formats_and_round_trip(client: TestClient, code: str) -> None:
    client.patch(f"/api/sessions/{code}/config", json={"model": {**EX1, "p0": 0.9}})
    r = client.get(f"/api/sessions/{code}/export/json")
    assert r.status_code == 200 and "attachment" in r.headers["content-disposition"]
    doc = r.json()
    mat = client.get(f"/api/sessions/{code}/export/mat")
    from scipy.io import loadmat

    assert "model" in loadmat(io.BytesIO(mat.content))
    c = client.get(f"/api/sessions/{code}/export/c")
    assert c.status_code == 200 and b"double" in c.content
    assert client.get(f"/api/sessions/{code}/export/xls").status_code == 404
    other = client.post("/api/sessions").json()["code"]
    r = client.put(f"/api/sessions/{other}/parameter-set", content=json.dumps(doc))
    assert r.status_code == 200 and r.json()["config"]["model"]["p0"] == 0.9


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")
def test_export_fmu_of_the_session_model(client: TestClient, code: str, tmp_path) -> None:
    """The FMU menu: compensator or model, FMI 3 or 2; refusals are 422s that say why."""
    fmpy = pytest.importorskip("fmpy")
    client.patch(f"/api/sessions/{code}/config", json={"model": {**EX1, "p0": 0.9}})
    r = client.get(f"/api/sessions/{code}/export/fmu?fmi=2&inverse=true")
    assert r.status_code == 200, r.text
    assert "compensator-fmi2.fmu" in r.headers["content-disposition"]
    (tmp_path / "c.fmu").write_bytes(r.content)
    md = fmpy.read_model_description(str(tmp_path / "c.fmu"))
    assert md.fmiVersion == "2.0" and {v.name for v in md.modelVariables} >= {"y_ref", "u"}
    r = client.get(f"/api/sessions/{code}/export/fmu")
    assert r.status_code == 200 and "model-fmi3.fmu" in r.headers["content-disposition"]
    r = client.get(f"/api/sessions/{code}/export/fmu?fmi=9")
    assert r.status_code == 422 and "unknown FMI version '9'" in r.json()["detail"]
    client.patch(f"/api/sessions/{code}/config", json={"model": {**EX1, "weights": [
        -1.0, 0.1, 0.1, 0.1, 0.1, 0.1]}})
    r = client.get(f"/api/sessions/{code}/export/fmu?inverse=true")
    assert r.status_code == 422 and "invert" in r.json()["detail"]


@pytest.mark.parametrize(
    ("body", "text"),
    [(b"{oops", "json"), (b"[1, 2]", "object"), (b'{"model": {"type": "pi"}}', "missing")],
)
def test_bad_parameter_set(client: TestClient, code: str, body: bytes, text: str) -> None:
    r = client.put(f"/api/sessions/{code}/parameter-set", content=body)
    assert r.status_code == 422 and text in r.json()["detail"].lower()


def test_parameter_set_too_large(client: TestClient, code: str) -> None:
    r = client.put(f"/api/sessions/{code}/parameter-set", content=b" " * 300_000)
    assert r.status_code == 413
