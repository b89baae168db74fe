"""The list of a session's jobs (``GET /api/sessions/{code}/jobs``): a page reloaded during
a fit or a diagnosis finds the job and follows it."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.services.jobs.manager import JobManager
from app.services.jobs.worker import Task
from tests.app import job_work
from tests.app import test_security_jobs as jobs_api
from tests.app.test_security import csv_text, upload
from tests.app.test_security_jobs import _poll

client = jobs_api.client  # the jobs tests' module-scoped server fixture


def test_list_shows_the_running_job_then_its_end(client: TestClient) -> None:
    code = client.post("/api/sessions").json()["code"]
    other = client.post("/api/sessions").json()["code"]
    assert client.get(f"/api/sessions/{code}/jobs").json() == {"jobs": []}
    upload(client, code, csv_text(400))
    fit = client.post(f"/api/sessions/{code}/jobs", json={"kind": "fit", "params": {"n": 3}})
    assert _poll(client, code, fit.json()["id"])["state"] == "done"
    diag = client.post(f"/api/sessions/{code}/jobs", json={"kind": "diagnose"}).json()
    listed = client.get(f"/api/sessions/{code}/jobs").json()["jobs"]
    # newest first; the running diagnosis is there with its progress, no result in a list
    assert [j["id"] for j in listed] == [diag["id"], fit.json()["id"]]
    assert listed[0]["kind"] == "diagnose" and listed[0]["state"] in ("queued", "running")
    assert set(listed[0]) == {"id", "kind", "state", "progress", "message", "time_left", "error"}
    assert 0.0 <= listed[0]["progress"] <= 1.0
    assert listed[1]["state"] == "done" and listed[1]["progress"] == 1.0
    # per session: another session sees none of them, and cannot read them by id
    assert client.get(f"/api/sessions/{other}/jobs").json() == {"jobs": []}
    assert client.get(f"/api/sessions/{other}/jobs/{diag['id']}").status_code == 404
    assert client.get(f"/api/sessions/{code}/jobs", params={"limit": 1}).json()["jobs"][0][
        "id"] == diag["id"]
    client.delete(f"/api/sessions/{code}/jobs/{diag['id']}")
    assert _poll(client, code, diag["id"])["state"] == "cancelled"
    assert client.get(f"/api/sessions/{code}/jobs").json()["jobs"][0]["state"] == "cancelled"


@pytest.mark.parametrize("query", ["limit=0", "limit=21", "limit=-1", "limit=1e9",
                                   "limit=abc", "limit=%00", "limit=" + "9" * 400])
def test_hostile_limits_are_refused_plainly(client: TestClient, query: str) -> None:
    code = client.post("/api/sessions").json()["code"]
    r = client.get(f"/api/sessions/{code}/jobs?{query}")
    assert r.status_code == 422, (query, r.status_code)


@pytest.mark.parametrize("code", ["abcd-efgh-jkmn-pqrs", "..%2F..%2Fetc", "x" * 5000,
                                  "%3Cscript%3E", "' OR 1=1 --"])
def test_unknown_or_hostile_codes_are_404(client: TestClient, code: str) -> None:
    r = client.get(f"/api/sessions/{code}/jobs")
    assert r.status_code in (404, 422), (code, r.status_code)
    assert "<script>" not in r.text


def test_the_list_is_bounded_and_keeps_an_unfinished_job_alive(tmp_path: Path) -> None:
    jobs = JobManager(max_workers=1, idle_cancel_s=1.5)
    for _ in range(30):
        j = jobs.submit("s1", "fit", Task(job_work.constant, (1,)))
        assert j.finished.wait(60) and j.view().state == "done"
    assert len(jobs.recent("s1", 10)) == 10 and len(jobs.recent("s1", 100)) == 30
    assert jobs.recent("s1", 0) == [] and jobs.recent("nobody") == []
    gate = tmp_path / "go"
    job = jobs.submit("s1", "diagnose", Task(job_work.until_file, (str(gate), 2)))
    # nobody polls the job by id, but a page keeps listing the session's jobs: alive for
    # twice the idle time (1.5 s: a loaded machine can stall a 0.1 s wait by a few tenths)
    for _ in range(30):
        assert jobs.recent("s1", 1)[0] is job
        assert not job.finished.wait(0.1)
    assert job.state == "running"
    gate.touch()
    assert job.finished.wait(30) and job.state == "done" and job.result == 2
    jobs.cancel_all()
