"""The lesson routes: reading lesson files, the teacher's moves (token only), returning."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.settings import Settings
from app.services.teaching.lessons import MAX_LESSON_BYTES

TOKEN = "lesson-7c"
T = {"X-Teacher-Token": TOKEN}


@pytest.fixture
def client() -> Iterator[TestClient]:
    app = create_app(Settings(viser_port=None, teacher_token=TOKEN))
    with TestClient(app) as c:
        yield c


@pytest.fixture
def public_client() -> Iterator[TestClient]:
    """A server reachable beyond loopback: it always has a token (generated here)."""
    app = create_app(Settings(viser_port=None, host="0.0.0.0"))
    with TestClient(app, base_url="http://127.0.0.1") as c:
        yield c


def test_shipped_lessons_list_and_download_and_read_back(client: TestClient) -> None:
    listed = client.get("/api/lessons").json()
    assert listed[0]["name"] == "pi-basics" and listed[0]["steps"] == 6
    doc = client.get("/api/lessons/pi-basics").json()
    assert [s["view"] for s in doc["steps"]][:3] == ["loop", "time", "operators"]
    again = client.post("/api/lessons/check", json=doc)
    assert again.status_code == 200 and again.json() == doc
    r = client.get("/api/lessons/..%2F..%2Fetc%2Fpasswd")  # a name, never a path
    assert r.status_code == 404
    r = client.get("/api/lessons/__init__")
    assert r.status_code == 404 and "pi-basics" in r.json()["detail"]


def test_check_names_the_step_and_the_field(client: TestClient) -> None:
    doc = client.get("/api/lessons/pi-basics").json()
    doc["steps"][1]["view"] = "3d"
    r = client.post("/api/lessons/check", json=doc)
    assert r.status_code == 422
    assert r.json()["detail"].startswith("step 2 (The same run in time): view '3d'")
    toml = 'title = "T"\n[[steps]]\ntitle = "a"\npreset = "paper001-example4"\nprompt = "p"\n'
    r = client.post("/api/lessons/check", content=toml, headers={"Content-Type": "text/plain"})
    assert r.status_code == 200 and r.json()["steps"][0]["preset"] == "paper001-example4"
    r = client.post("/api/lessons/check", content="x" * (MAX_LESSON_BYTES + 1))
    assert r.status_code == 413
    r = client.post("/api/lessons/check", content="/etc/passwd")
    assert r.status_code == 422 and "neither JSON" in r.json()["detail"]


@pytest.mark.parametrize("headers", [{}, {"X-Teacher-Token": "guess"},
                                     {"X-Teacher-Token": TOKEN + " "}])
def test_only_the_teacher_moves_the_class(client: TestClient, headers: dict) -> None:
    code = client.post("/api/sessions").json()["code"]
    before = client.get(f"/api/sessions/{code}").json()
    for method, path, body in [("post", "/api/teacher/lesson", {"name": "deadzone-gpi"}),
                               ("post", "/api/teacher/lesson/step", {"move": 1}),
                               ("delete", "/api/teacher/lesson", None)]:
        r = client.request(method.upper(), path, json=body, headers=headers)
        assert r.status_code == 403, (path, r.status_code)
        assert "teacher token" in r.json()["detail"]
    assert client.get("/api/lesson").json() == {"running": False}
    assert client.get(f"/api/sessions/{code}").json() == before


def test_on_a_public_server_the_teacher_needs_the_token(public_client: TestClient) -> None:
    r = public_client.post("/api/teacher/lesson", json={"name": "pi-basics"})
    assert r.status_code == 403


def test_teacher_leads_and_a_student_returns(client: TestClient) -> None:
    a = client.post("/api/sessions").json()["code"]
    b = client.post("/api/sessions").json()["code"]
    r = client.post("/api/teacher/lesson", json={"name": "pi-basics"}, headers=T)
    assert r.status_code == 200, r.text
    assert (r.json()["step"], r.json()["steps"], r.json()["sessions"]) == (1, 6, 2)
    for _ in range(2):
        r = client.post("/api/teacher/lesson/step", json={"move": 1}, headers=T)
    now = r.json()
    assert (now["step"], now["view"], now["step_title"]) == (3, "operators",
                                                             "What each operator adds")
    assert client.get("/api/lesson").json()["prompt"] == now["prompt"]
    # b explores (its own model and input), then comes back to the class step
    client.patch(f"/api/sessions/{b}/config", json={
        "model": {"type": "pi", "p0": 1.0, "thresholds": [1.0], "weights": [0.5]},
        "signal": {"kind": "triangle", "amplitude": 2.0}, "mismatch": 0.3})
    back = client.post(f"/api/sessions/{b}/lesson/return")
    assert back.status_code == 200
    cfg = back.json()["config"]
    assert cfg["model"] == now["model"] and cfg["signal"] == now["input"]
    assert cfg["mismatch"] == 0.0
    assert client.get(f"/api/sessions/{a}").json()["config"]["model"] == now["model"]
    # the teacher's moves are checked
    r = client.post("/api/teacher/lesson/step", json={"step": 7}, headers=T)
    assert r.status_code == 422 and "steps 1 to 6" in r.json()["detail"]
    r = client.post("/api/teacher/lesson/step", json={}, headers=T)
    assert r.status_code == 422
    assert client.delete("/api/teacher/lesson", headers=T).json()["running"] is False
    assert client.post(f"/api/sessions/{b}/lesson/return").status_code == 409
    r = client.post("/api/teacher/lesson/step", json={"move": 1}, headers=T)
    assert r.status_code == 409 and "start one" in r.json()["detail"]


def test_a_teachers_own_lesson_is_checked_before_it_starts(client: TestClient) -> None:
    mine = {"title": "Mine", "steps": [
        {"title": "one", "preset": "paper000-two-operators", "view": "digitized",
         "prompt": "<b>count</b> the states"}]}
    r = client.post("/api/teacher/lesson", json={"lesson": mine}, headers=T)
    assert r.status_code == 200 and r.json()["prompt"] == "<b>count</b> the states"
    mine["steps"][0]["model"] = {"type": "pi"}
    r = client.post("/api/teacher/lesson", json={"lesson": mine, "step": 1}, headers=T)
    assert r.status_code == 422 and r.json()["detail"].startswith("step 1 (one)")
    r = client.post("/api/teacher/lesson", json={"name": "nope"}, headers=T)
    assert r.status_code == 404
    r = client.post("/api/teacher/lesson", json={}, headers=T)
    assert r.status_code == 422
    r = client.post("/api/teacher/lesson", json={"name": "pi-basics", "step": 99}, headers=T)
    assert r.status_code == 422
    client.delete("/api/teacher/lesson", headers=T)


def test_a_step_is_checked_by_the_sliders_ranges(client: TestClient) -> None:
    """Issue 35 item 6: ``"input": {"duration": 1e308}`` passed the check and started;
    then every student's figures answered 422. The step's input and mismatch must be
    values the sliders can show, and its model must keep the sliders' rules."""
    from app.services.explore.config import CONTROLS

    doc = client.get("/api/lessons/pi-basics").json()
    for key, value, words in (
            ("duration", 1e308, "input.duration is 1e+308 s, outside the Duration slider's "
                                "range 0.5 to 20 s"),
            ("amplitude", -3.0, "input.amplitude is -3, outside the Amplitude"),
            ("frequency", 1e5, "input.frequency is 100000 Hz, outside"),
            ("offset", 6.0, "input.offset is 6, outside the Offset slider's range -5 to 5")):
        bad = {**doc, "steps": [{**doc["steps"][0],
                                 "input": {**doc["steps"][0]["input"], key: value}}]}
        r = client.post("/api/lessons/check", json=bad)
        assert r.status_code == 422, r.text
        assert r.json()["detail"].startswith("step 1 (") and words in r.json()["detail"]
        r = client.post("/api/teacher/lesson", json={"lesson": bad}, headers=T)
        assert r.status_code == 422 and words in r.json()["detail"]
    bad = {**doc, "steps": [{**doc["steps"][0], "mismatch": 0.8}]}
    r = client.post("/api/lessons/check", json=bad)
    assert r.status_code == 422 and "mismatch is 0.8, outside the Model mismatch" in r.text
    edge = {**doc, "steps": [{**doc["steps"][0], "mismatch": CONTROLS["mismatch"].high,
                              "input": {**doc["steps"][0]["input"],
                                        "duration": CONTROLS["duration"].high}}]}
    assert client.post("/api/lessons/check", json=edge).status_code == 200
