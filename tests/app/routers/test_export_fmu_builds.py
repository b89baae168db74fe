"""FMU builds wait for a compiler without holding the workers other requests need (issue 35,
item 7: 60 concurrent FMU builds had delayed a new session by 9 s).

The build is replaced by one that records how many run at once and blocks until the test
lets it go: while eight builds are requested, at most ``FMU_BUILDS`` run, and a new session
opens before any of them is let go."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import pytest
from fastapi.testclient import TestClient

from app.routers import export as export_router
from app.server import create_app
from app.services.session import actions
from app.services.settings import Settings


@pytest.fixture
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(viser_port=0))) as c:
        yield c


def test_fmu_builds_queue_for_a_compiler_and_leave_the_workers_free(client, monkeypatch):
    gate, lock = threading.Event(), threading.Lock()
    running, peak, started = [0], [0], threading.Semaphore(0)
    real = actions.export

    def slow_build(session, fmt, **kw):
        if fmt != "fmu":
            return real(session, fmt, **kw)
        with lock:
            running[0] += 1
            peak[0] = max(peak[0], running[0])
        started.release()
        gate.wait(30)
        with lock:
            running[0] -= 1
        return "m.fmu", b"fmu"

    monkeypatch.setattr(actions, "export", slow_build)
    code = client.post("/api/sessions").json()["code"]
    n = 8
    with ThreadPoolExecutor(n) as pool:
        futures = [pool.submit(client.get, f"/api/sessions/{code}/export/fmu")
                   for _ in range(n)]
        for _ in range(export_router.FMU_BUILDS):
            assert started.acquire(timeout=30)
        # the builds hold the compilers; a new session still opens (not behind them)
        assert client.post("/api/sessions").status_code == 201
        assert not started.acquire(timeout=0.5)  # no third build got a compiler
        gate.set()
        statuses = [f.result(timeout=60).status_code for f in futures]
    assert statuses == [200] * n
    assert peak[0] == export_router.FMU_BUILDS


def test_a_full_queue_of_fmu_builds_says_busy(client, monkeypatch):
    monkeypatch.setattr(export_router, "FMU_QUEUE", 0)
    code = client.post("/api/sessions").json()["code"]
    r = client.get(f"/api/sessions/{code}/export/fmu")
    assert r.status_code == 503 and "compiling many FMUs" in r.json()["detail"]
    assert r.headers["retry-after"] == "30"
