"""The in-process event hub (thread-safe publish into asyncio queues) and the teacher API."""

from __future__ import annotations

import asyncio
import threading
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.settings import Settings
from app.services.teaching.events import QUEUE_SIZE, EventHub


def _run(make: Any) -> Any:
    """``asyncio.run(make())`` in a thread of its own (a browser test's playwright may hold
    a running loop in this one when the test folders run in another order)."""
    out: list[Any] = []

    def go() -> None:
        try:
            out.append(asyncio.run(make()))
        except BaseException as exc:  # re-raised in the test's thread
            out.append(exc)

    th = threading.Thread(target=go)
    th.start()
    th.join(60)
    assert out, "the coroutine did not finish"
    if isinstance(out[0], BaseException):
        raise out[0]
    return out[0]


def test_publish_from_many_threads_reaches_the_right_pages() -> None:
    hub = EventHub()

    async def run() -> tuple[list[int], list[int], dict[str, int]]:
        a, b = hub.subscribe("a"), hub.subscribe("b")
        threads = [threading.Thread(target=lambda k=k: hub.publish("a", {"k": k}))
                   for k in range(20)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        hub.broadcast({"k": 99})
        got_a = [(await a.get(2))["k"] for _ in range(21)]
        got_b = [(await b.get(2))["k"] for _ in range(1)]
        conn = hub.connected()
        hub.unsubscribe(a)
        hub.unsubscribe(b)
        return got_a, got_b, conn

    got_a, got_b, conn = _run(run)
    assert sorted(got_a) == [*range(20), 99] and got_b == [99]
    assert conn == {"a": 1, "b": 1} and hub.connected() == {}


def test_reconnect_replays_missed_events_and_slow_pages_are_bounded() -> None:
    hub = EventHub(max_subscribers=1)

    async def run() -> tuple[list[int], int]:
        first = hub.subscribe("a")
        ev = [hub.broadcast({"k": k}) for k in range(3)]
        assert ev == [1, 1, 1]
        seen = (await first.get(1))["id"]
        hub.unsubscribe(first)
        hub.publish("b", {"k": "other"})  # not for "a"
        again = hub.subscribe("a", last_id=seen)
        replay = [(await again.get(1))["k"] for _ in range(2)]
        with pytest.raises(OverflowError):
            hub.subscribe("c")
        for k in range(QUEUE_SIZE + 10):
            again.deliver({"k": k})
        size = again.queue.qsize()
        hub.unsubscribe(again)
        return replay, size

    replay, size = _run(run)
    assert replay == [1, 2]
    assert size == QUEUE_SIZE


def test_teacher_push_needs_the_token_and_changes_every_session() -> None:
    with TestClient(create_app(Settings(viser_port=None, teacher_token="t0k"))) as client:
        codes = [client.post("/api/sessions").json()["code"] for _ in range(2)]
        body = {"preset": "paper000-three-operators", "use_preset_input": True}
        assert client.post("/api/teacher/push", json=body).status_code == 403
        assert client.post("/api/teacher/push", json=body,
                           headers={"X-Teacher-Token": "nope"}).status_code == 403
        r = client.post("/api/teacher/push", json=body, headers={"X-Teacher-Token": "t0k"})
        assert r.status_code == 200 and r.json()["sessions"] == 2
        for code in codes:
            cfg = client.get(f"/api/sessions/{code}").json()["config"]
            assert cfg["model"]["type"] == "digitized"
            assert cfg["signal"]["offset"] == 5.0 and cfg["signal"]["amplitude"] == 5.5
        bad = client.post("/api/teacher/push", json={"preset": "nope"},
                          headers={"X-Teacher-Token": "t0k"})
        assert bad.status_code == 404
        empty = client.post("/api/teacher/push", json={}, headers={"X-Teacher-Token": "t0k"})
        assert empty.status_code == 422
        # the model the teacher edited, checked like a saved parameter set
        edited = {"type": "pi", "p0": 1.1, "thresholds": [0.5, 1.5], "weights": [0.4, 0.3]}
        r = client.post("/api/teacher/push", json={"model": edited},
                        headers={"X-Teacher-Token": "t0k"})
        assert r.status_code == 200
        for code in codes:
            assert client.get(f"/api/sessions/{code}").json()["config"]["model"] == edited
        for bad in ({"model": {**edited, "weights": [0.4]}},
                    {"model": {**edited, "thresholds": [0.5] * 100_000, "weights": [1] * 100_000}},
                    {"model": edited, "preset": "paper000-three-operators"}):
            r = client.post("/api/teacher/push", json=bad, headers={"X-Teacher-Token": "t0k"})
            assert r.status_code in (413, 422), (r.status_code, r.text[:200])
        conn = client.get("/api/teacher/connected", headers={"X-Teacher-Token": "t0k"}).json()
        assert conn["sessions"] == 2 and conn["codes"] == []
        assert client.get("/api/sessions/zzzz-none/events").status_code == 404


def test_teacher_routes_follow_the_broadcast_rule(monkeypatch: pytest.MonkeyPatch) -> None:
    """Beyond loopback a token is generated and needed, compared by Settings.teacher_ok."""
    calls: list[str | None] = []
    real = Settings.teacher_ok
    monkeypatch.setattr(Settings, "teacher_ok",
                        lambda self, tok: calls.append(tok) or real(self, tok))
    app = create_app(Settings(viser_port=None, host="0.0.0.0"))
    token = app.state.settings.teacher_token
    push = {"preset": "paper000-three-operators"}
    with TestClient(app) as client:
        code = client.post("/api/sessions").json()["code"]
        for headers in ({}, {"X-Teacher-Token": "guess"}, {"X-Teacher-Token": token[:-1]}):
            assert client.post("/api/teacher/push", json=push, headers=headers
                               ).status_code == 403
            assert client.get("/api/teacher/connected", headers=headers).status_code == 403
        assert client.get(f"/api/sessions/{code}").json()["config"]["model"]["type"] == "pi"
        ok = {"X-Teacher-Token": token}
        assert client.post("/api/teacher/push", json=push, headers=ok).json()["sessions"] == 1
        assert "codes" in client.get("/api/teacher/connected", headers=ok).json()
    assert calls.count(token) == 2 and "guess" in calls
    # a server that somehow lost its token beyond loopback refuses instead of opening up
    from dataclasses import replace

    app.state.settings = replace(app.state.settings, teacher_token=None)
    with TestClient(app) as client:
        assert client.post("/api/teacher/push", json=push).status_code == 403


def test_a_push_is_stored_and_survives_a_restart(tmp_path: Path) -> None:
    """The push is committed for every session used in the last hour, also those only in
    the store (not in memory) after a restart; a reload then shows the pushed model."""
    cfg = Settings(viser_port=None, teacher_token="t0k", state_dir=str(tmp_path))
    with TestClient(create_app(cfg)) as client:
        before = client.post("/api/sessions").json()["code"]
    # a restart: the session is only in the store now
    with TestClient(create_app(cfg)) as client:
        r = client.post("/api/teacher/push", headers={"X-Teacher-Token": "t0k"},
                        json={"preset": "paper000-three-operators", "use_preset_input": True})
        assert r.json()["sessions"] == 1
        assert client.get(f"/api/sessions/{before}").json()["config"]["model"]["type"] \
            == "digitized"
    with TestClient(create_app(cfg)) as client:  # and another restart keeps it
        got = client.get(f"/api/sessions/{before}").json()["config"]
        assert got["model"]["type"] == "digitized" and got["signal"]["offset"] == 5.0


def test_streams_per_client_are_capped_and_freed() -> None:
    from app.services.teaching.events import StreamsPerClientError

    hub = EventHub()

    async def run() -> tuple[bool, int]:
        subs = [hub.subscribe("a", client="10.0.0.1", per_client=3) for _ in range(3)]
        try:
            hub.subscribe("b", client="10.0.0.1", per_client=3)
            refused = False
        except StreamsPerClientError:
            refused = True
        other = hub.subscribe("a", client="10.0.0.2", per_client=3)  # another computer
        hub.unsubscribe(subs[0])  # a page closed: its slot is free again
        again = hub.subscribe("a", client="10.0.0.1", per_client=3)
        for s in [*subs[1:], other, again]:
            hub.unsubscribe(s)
        return refused, sum(hub.connected().values())

    assert _run(run) == (True, 0)
