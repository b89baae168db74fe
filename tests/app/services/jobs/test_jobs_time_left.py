"""A long job says how long it has left (issue 31: "a long diagnosis shows progress with an
estimated time left in the command line and both interfaces"), from the same measured cost
model as ``hyst diagnose``'s progress lines: the web page and the 3D / GUI interface read it
from the job's view (``time_left``)."""

from __future__ import annotations

import re
import time
from pathlib import Path

from app.services.jobs.manager import Job, JobManager
from app.services.jobs.worker import Task
from app.services.runs.cost import DIAGNOSE, ETA_FROM_S, time_left_text
from tests.app import job_work


def test_time_left_in_words() -> None:
    # the reference: what is left is the expected time less the time taken, in words
    assert time_left_text(100.0, 40.0) == "about 60 s left"
    assert time_left_text(600.0, 0.0) == "about 10 min left"
    assert time_left_text(80.0, 80.0) == "taking longer than the 80 s estimated"
    assert time_left_text(300.0, 290.0) == "about 10 s left"
    # a short run says nothing (the bar and its percentage are enough)
    assert time_left_text(ETA_FROM_S - 1, 0.0) == ""


def _wait_running(job: Job, limit_s: float = 60.0) -> None:
    deadline = time.monotonic() + limit_s
    while job.view().state != "running":
        assert time.monotonic() < deadline, "the job never started"
        time.sleep(0.02)


def test_a_long_job_shows_its_time_left_while_it_runs(tmp_path: Path) -> None:
    jobs = JobManager(max_workers=1)
    samples = 2_000_000  # the cost model's CPU time for it: 35 s, above ETA_FROM_S
    expected = DIAGNOSE.cpu_s(samples)
    assert expected >= ETA_FROM_S
    gate = tmp_path / "go"
    job = jobs.submit("s1", "diagnose", Task(job_work.until_file, (str(gate), 7),
                                             samples=samples, cost=DIAGNOSE))
    _wait_running(job)
    left = job.view().time_left
    m = re.fullmatch(r"about (\d+) s left", left)
    assert m, left
    assert 1 <= int(m.group(1)) <= round(expected)
    gate.touch()
    assert job.finished.wait(60) and job.view().state == "done"
    assert job.view().time_left == ""  # a finished job has nothing left


def test_a_short_or_unknown_job_says_nothing(tmp_path: Path) -> None:
    jobs = JobManager(max_workers=1)
    for task_samples in (50_000, 0):  # the shipped piezo recording: ~5.8 s; no size known
        gate = tmp_path / f"go{task_samples}"
        job = jobs.submit(f"s{task_samples}", "diagnose",
                          Task(job_work.until_file, (str(gate), 1), samples=task_samples,
                               cost=DIAGNOSE))
        _wait_running(job)
        assert job.view().time_left == ""
        gate.touch()
        assert job.finished.wait(60)
