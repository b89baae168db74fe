"""Bounded, cancellable work: fit and diagnosis jobs (issue 10, failure 3)."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.jobs import tasks
from app.services.jobs.manager import JobBusy, JobManager
from app.services.jobs.worker import Task
from app.services.settings import Settings

from . import job_work
from .test_security import csv_text, upload


def _poll(c: TestClient, code: str, job: str, timeout: float = 120.0) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        j = c.get(f"/api/sessions/{code}/jobs/{job}").json()
        if j["state"] in ("done", "failed", "cancelled"):
            return j
        time.sleep(0.05)
    raise AssertionError("job did not finish")


def _poll_until(c: TestClient, code: str, job: str, cond, timeout: float = 120.0) -> dict:  # noqa: ANN001
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        j = c.get(f"/api/sessions/{code}/jobs/{job}").json()
        if cond(j):
            return j
        time.sleep(0.05)
    raise AssertionError(f"the job never got there: {j}")


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory):  # noqa: ANN201
    app = create_app(Settings(viser_port=None, state_dir=str(tmp_path_factory.mktemp("s"))))
    with TestClient(app) as c:
        yield c


def test_fit_job_contract(client: TestClient) -> None:
    code = client.post("/api/sessions").json()["code"]
    assert upload(client, code, csv_text(400)).status_code == 201
    r = client.post(f"/api/sessions/{code}/jobs", json={"kind": "fit", "params": {"n": 4}})
    assert r.status_code == 202 and set(r.json()) == {"id", "kind", "state"}
    assert r.json()["kind"] == "fit" and r.json()["state"] in ("queued", "running", "done")
    j = _poll(client, code, r.json()["id"])
    assert set(j) == {"id", "kind", "state", "progress", "message", "time_left", "result", "error"}
    assert j["state"] == "done" and j["progress"] == 1.0 and j["error"] is None
    assert j["result"]["report"]["n_operators"] == 4 and "figure" in j["result"]
    assert client.get(f"/api/sessions/{code}").json()["fitted"] == j["result"]["model"]
    bad = client.post(f"/api/sessions/{code}/jobs", json={"kind": "fit", "params": {"n": 999}})
    assert bad.status_code == 422
    assert client.post(f"/api/sessions/{code}/jobs", json={"kind": "x"}).status_code == 422
    assert client.get(f"/api/sessions/{code}/jobs/nope").status_code == 404


def test_one_job_per_session_cancel_and_the_api_stays_responsive(client: TestClient) -> None:
    codes = []
    for _ in range(6):
        code = client.post("/api/sessions").json()["code"]
        upload(client, code, csv_text(600))
        codes.append(code)
    ids = [client.post(f"/api/sessions/{c}/jobs", json={"kind": "diagnose"}).json()["id"]
           for c in codes]
    again = client.post(f"/api/sessions/{codes[0]}/jobs", json={"kind": "diagnose"})
    assert again.status_code == 409 and "already" in again.json()["detail"]
    t0 = time.monotonic()
    assert client.get("/api/health").status_code == 200  # not starved by 6 diagnoses
    assert time.monotonic() - t0 < 2.0
    assert client.app.state.jobs.running() <= 2  # bounded concurrency (max_jobs)
    for c, i in zip(codes, ids, strict=True):
        client.delete(f"/api/sessions/{c}/jobs/{i}")
    states = {_poll(client, c, i)["state"] for c, i in zip(codes, ids, strict=True)}
    assert states <= {"cancelled", "done"} and "cancelled" in states
    # the session is free again
    r = client.post(f"/api/sessions/{codes[-1]}/jobs", json={"kind": "fit", "params": {}})
    assert r.status_code == 202


def test_jobs_nobody_waits_for_are_cancelled(tmp_path: Path) -> None:
    jobs = JobManager(max_workers=1, idle_cancel_s=0.5)
    gate = str(tmp_path / "never")
    a = jobs.submit("s1", "diagnose", Task(job_work.until_file, (gate,)))
    b = jobs.submit("s2", "diagnose", Task(job_work.until_file, (gate,)))  # queued behind a
    with pytest.raises(JobBusy):
        jobs.submit("s1", "fit", Task(job_work.constant, (1,)))
    assert a.finished.wait(60) and b.finished.wait(60)  # nobody polled: both cancelled
    assert a.view().state == "cancelled" and b.view().state == "cancelled"
    assert jobs.running() == 0 and jobs.workers() == []
    jobs.cancel_all()


def test_sync_endpoints_run_through_the_queue(tmp_path: Path) -> None:
    app = create_app(Settings(viser_port=None, max_jobs=1))
    with TestClient(app) as c:
        code = c.post("/api/sessions").json()["code"]
        upload(c, code, csv_text(400))
        assert c.post(f"/api/sessions/{code}/fit", json={"n": 3}).status_code == 200
        assert app.state.jobs.running() == 0


def test_a_diagnosis_cancelled_after_its_last_report_leaves_the_session_alone(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The cancel arrives after the diagnosis' last progress report, while the report is
    being built: the job ends cancelled at once, its worker is gone, and the session holds
    no diagnosis (before: the job stayed "cancelling" until the diagnosis had run to its
    end, and a cancel that came that late still left the result in the session)."""
    monkeypatch.setattr(tasks, "run_diagnosis", job_work.stalled_diagnosis)
    app = create_app(Settings(viser_port=None))
    with TestClient(app) as c:
        code = c.post("/api/sessions").json()["code"]
        upload(c, code, csv_text(400))
        job = c.post(f"/api/sessions/{code}/jobs", json={"kind": "diagnose"}).json()["id"]
        seen = _poll_until(c, code, job, lambda j: j["progress"] >= 0.99)
        assert seen["state"] == "running" and seen["message"] == "building the report"
        [pid] = app.state.jobs.workers()
        end = c.delete(f"/api/sessions/{code}/jobs/{job}").json()
        assert end["state"] == "cancelled" and end["progress"] < 1
        job_work.wait_gone(pid)
        assert app.state.registry.get(code).diagnosis is None
        assert app.state.jobs.running() == 0


def test_a_cancel_while_the_result_is_stored_is_too_late(tmp_path: Path) -> None:
    """The worker is done and its result is being stored: a cancel then changes nothing
    and the job ends done (a cancelled job never leaves a result behind, a done one always
    does)."""
    jobs = JobManager(max_workers=1)
    storing, release, kept = threading.Event(), threading.Event(), []

    def keep(value: int) -> int:
        storing.set()
        assert release.wait(30)
        kept.append(value)
        return value + 1

    job = jobs.submit("s1", "fit", Task(job_work.constant, (41,), keep))
    assert storing.wait(60)
    assert jobs.cancel("s1", job.id).view().state == "running"
    release.set()
    assert job.finished.wait(30)
    assert job.view().state == "done" and job.view().result == 42 and kept == [41]
    jobs.cancel_all()


def test_a_task_that_raises_or_whose_worker_dies_fails_with_the_reason() -> None:
    jobs = JobManager(max_workers=1)
    failed = jobs.submit("s1", "fit", Task(job_work.fail, ("no good",)))
    assert failed.finished.wait(60) and failed.view().error == "no good"
    died = jobs.submit("s1", "fit", Task(job_work.die, (3,)))  # as if out of memory
    assert died.finished.wait(30) and died.view().state == "failed"
    assert "stopped unexpectedly (exit code 3" in died.view().error
    jobs.cancel_all()
