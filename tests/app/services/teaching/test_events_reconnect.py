"""A page that got no event yet still reconnects with a ``Last-Event-ID``, so a teacher push
sent while its stream reconnects (every ``STREAM_S`` s) is replayed, not lost."""

from __future__ import annotations

import re

import pytest
from fastapi.testclient import TestClient

from app.routers import events
from app.server import create_app
from app.services.settings import Settings


def test_a_push_between_two_streams_is_replayed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(events, "STREAM_S", 0.3)
    with TestClient(create_app(Settings(viser_port=None, teacher_token="t0k"))) as client:
        code = client.post("/api/sessions").json()["code"]
        first = client.get(f"/api/sessions/{code}/events").text  # ends after 0.3 s
        ids = re.findall(r"^id: (\d+)$", first, flags=re.M)
        assert ids, first  # what EventSource sends back as Last-Event-ID on reconnect
        assert "event: push" not in first
        # the push lands while the page is between two streams
        r = client.post("/api/teacher/push", json={"preset": "paper000-three-operators"},
                        headers={"X-Teacher-Token": "t0k"})
        assert r.status_code == 200
        again = client.get(f"/api/sessions/{code}/events",
                           headers={"Last-Event-ID": ids[-1]}).text
        assert "event: push" in again and "paper000-three-operators" in again
        # a new page (no Last-Event-ID) starts after the push: nothing replayed to it
        fresh = client.get(f"/api/sessions/{code}/events").text
        assert "event: push" not in fresh
