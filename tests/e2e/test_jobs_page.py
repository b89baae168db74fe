"""Fit and diagnosis on the web page through the real jobs API, in real Chromium.

A measured recording (``examples/data``) is uploaded through the page; the diagnosis runs
as a job whose progress bar and message move, and Cancel stops it (the server's job ends
``cancelled``, the buttons work again); a fit job completes and its result is shown.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from .test_web_journeys import _clean, _open, _session, _text_has, _upload

DATA = Path(__file__).resolve().parents[2] / "examples" / "data"
PIEZO = DATA / "piezo" / "piezo_150V_1Hz.csv"
FRICTION = DATA / "friction_damper" / "2Hz30lbtension0.5amplitude.csv"


def _buttons(page: Any) -> list[bool]:
    return page.evaluate("() => ['fit', 'diagnose'].map(i => document.getElementById(i).disabled)")


def _job(app: Any, code: str) -> Any:
    """The session's newest job, as the server's job manager holds it."""
    jobs = [j for j in app.state.jobs._jobs.values() if j.code == code]
    return jobs[-1]


def test_diagnosis_progress_and_cancel(browser: Any, live_server: dict, shot: Any,
                                       slow_diagnosis: None) -> None:
    app = live_server["app"]
    ctx, page, log = _open(browser, live_server["url"])
    _upload(page, PIEZO, "50001")
    code = page.inner_text("#code")
    page.click("#diagnose")
    assert _buttons(page) == [True, True]
    page.wait_for_selector("#job-progress:not([hidden])")
    page.wait_for_selector("#cancel-job:not([hidden])")
    # the bar starts low and moves as the diagnosis reports its rounds
    first = page.evaluate("() => document.getElementById('job-progress').value")
    page.wait_for_function("v => document.getElementById('job-progress').value > v + 0.05",
                           arg=first, timeout=120_000)
    _text_has(page, "busy", "round")  # the diagnosis' own message, not only a timer
    moved = page.evaluate("() => document.getElementById('job-progress').value")
    assert 0 < moved < 1
    job = _job(app, code)
    assert job.kind == "diagnose" and job.state == "running"
    # a long run says how long it has left (issue 31), from the job's cost-model estimate:
    # 10 min is what the measured model predicts for about 40 million samples
    job.expected_s = 600.0
    _text_has(page, "busy", "min left")
    shot(page, "web-diagnosis-progress")
    page.click("#cancel-job")
    _text_has(page, "csv-msg", "Diagnosis cancelled")
    assert "failed" not in page.inner_text("#csv-msg")
    assert page.is_hidden("#job-progress") and page.is_hidden("#cancel-job")
    assert page.is_hidden("#busy")
    assert _buttons(page) == [False, False]
    assert job.finished.wait(30) and job.state == "cancelled"
    assert _session(app, page).diagnosis is None
    assert page.locator("#diagnosis").count() == 0
    shot(page, "web-diagnosis-cancelled")
    # the session is free again: a fit starts at once (no "already has a job" refusal)
    page.fill("#fit-n", "6")
    page.click("#fit")
    page.wait_for_selector("#report .ok", timeout=120_000)
    _clean(page, log)
    ctx.close()


def test_fit_job_result_shown(browser: Any, live_server: dict, shot: Any) -> None:
    app = live_server["app"]
    ctx, page, log = _open(browser, live_server["url"])
    _upload(page, FRICTION, "3585")
    page.fill("#fit-n", "8")
    page.click("#fit")
    page.wait_for_function("() => document.body.dataset.fig === 'fit'", timeout=120_000)
    page.wait_for_selector("#report .ok")
    job = _job(app, page.inner_text("#code"))
    assert job.kind == "fit" and job.state == "done"
    # the page shows the job's own result: its RMS error and its overlay figure
    rms = job.result.rms_error  # typed in the server, JSON at the REST edge
    shown = page.inner_text("#report")
    assert shown.startswith("Fit: Classical PI model, 8 operators. Held-out error"), shown
    every_row = re.search(r"On every row: RMS error ([\d.e+-]+)", shown)
    assert every_row and float(every_row.group(1)) == pytest.approx(rms, rel=1e-3), shown
    names = page.evaluate("() => document.getElementById('figure')._fullData.map(t => t.name)")
    assert names == [t.get("name") for t in job.result.figure.data]
    fitted = _session(app, page).fitted  # a core Model in the session, JSON in the job
    assert fitted is not None and fitted is job.result.outcome.model
    assert _buttons(page) == [False, False]
    shot(page, "web-fit-job")
    _clean(page, log)
    ctx.close()
