"""The viser GUI in real Chromium: per-tab views, sliders, two students, CSV upload, fit,
download, screenshots."""

from __future__ import annotations

import importlib.util
import json
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from core.pi import PIModel


def _open(browser: Any, url: str, width: int = 1500, height: int = 900,
          init: str | None = None) -> tuple[Any, Any, list[str]]:
    ctx = browser.new_context(viewport={"width": width, "height": height},
                              accept_downloads=True)
    if init is not None:  # a script run in the page before viser's own (class_run.py)
        ctx.add_init_script(init)
    page = ctx.new_page()
    page.set_default_timeout(60_000)  # the 2 shared vCPUs can be very busy
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    # the viser page's own CSP (app/gui/viser_guard.py): a blocked script, style or socket
    # is reported on the console
    page.on("console", lambda m: errors.append(f"console: {m.text}")
            if "Content Security Policy" in m.text or "Refused to" in m.text else None)
    page.on("request", lambda r: errors.append(f"external request {r.url}")
            if not r.url.startswith(("http://127.0.0.1", "ws://127.0.0.1", "data:", "blob:"))
            else None)
    response = page.goto(url)
    assert response is not None
    assert "frame-ancestors 'none'" in (response.header_value("content-security-policy")
                                        or ""), "the viser page must send its CSP"
    assert response.header_value("x-frame-options") == "DENY"
    page.wait_for_function(
        "() => !document.body.innerText.includes('Connecting...')", timeout=60_000)
    page.wait_for_selector("text=Session code", timeout=60_000)
    return ctx, page, errors


def _views(app: Any, n: int, timeout: float = 60.0, known: Any = ()) -> list[Any]:
    """The rendered viser views, at least ``n`` of them, leaving out those whose keys are in
    ``known`` (tabs an earlier test left open on the shared server)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        views = [v for k, v in app.state.gui.views.items() if k not in known]
        if len(views) >= n and all(v.rendered_version >= 0 for v in views):
            return views
        time.sleep(0.1)
    raise AssertionError(f"expected {n} rendered viser views, got {app.state.gui.views}")


def upload_csv(page: Any, view: Any, path: Path, t: Any, u: Any, y: Any) -> None:
    """Write ``t, u, y`` to ``path`` and upload it through the Data tab of ``page``."""
    path.write_text("t,u,y\n" + "\n".join(
        f"{a},{b},{c}" for a, b, c in zip(t, u, y, strict=True)))
    upload_file(page, view, path)


def upload_file(page: Any, view: Any, path: Path, wait: float = 30.0) -> None:
    """Upload the file ``path`` through the Data tab of ``page``; wait up to ``wait`` s
    for ``view``'s session to hold a recording (0: do not wait)."""
    page.get_by_role("tab", name="Data").first.click()
    with page.expect_file_chooser() as fc:
        page.get_by_role("button", name="Upload CSV").first.click()
    fc.value.set_files(str(path))
    deadline = time.monotonic() + wait
    while view.session.recording is None and time.monotonic() < deadline:
        time.sleep(0.1)


def _screenshot(page: Any, shot: Any, name: str) -> None:
    page.wait_for_selector(".js-plotly-plot .main-svg", timeout=60_000)
    close = page.locator("[class*='Notification-closeButton']")
    for i in range(close.count()):  # headless-only "Software WebGL" toast
        try:  # a toast may close (and leave the DOM) on its own while we reach for it
            close.nth(i).click(timeout=5_000)
        except Exception as exc:  # playwright's TimeoutError; the page itself is checked below
            if type(exc).__name__ != "TimeoutError":
                raise
    page.wait_for_timeout(800)
    shot(page, name)


def test_viser_gui_two_students(browser: Any, live_server: dict, shot: Any,
                                tmp_path: Any) -> None:
    app = live_server["app"]
    known = set(app.state.gui.views)
    ctx_a, a, errors_a = _open(browser, live_server["viser_url"])
    (view_a,) = _views(app, 1, known=known)
    _screenshot(a, shot, "viser-loop")

    ctx_b, b, errors_b = _open(browser, live_server["viser_url"])
    views = _views(app, 2, known=known)
    view_b = next(v for v in views if v is not view_a)
    assert view_a.session is not view_b.session

    # student A drags p0 with the keyboard; student B's session and controls do not move
    slider = a.get_by_role("slider").first
    slider.focus()
    v0 = view_a.session.version
    for _ in range(5):
        slider.press("ArrowRight")
    deadline = time.monotonic() + 30
    while view_a.session.version == v0 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert view_a.session.version > v0
    assert view_a.worker.wait_idle(30)
    assert view_a.rendered_version == view_a.session.version
    assert view_b.session.version == 0
    assert view_b.session.config.model["p0"] == pytest.approx(0.72)

    # a change made through the session (REST, teacher push) reaches A's controls only
    view_a.session.update(lambda c: c.with_model({**c.model, "p0": 1.25}))
    assert view_a.worker.wait_idle(30)
    assert view_a.ui.param_sliders["p0"].value == pytest.approx(1.25)
    assert view_b.ui.param_sliders["p0"].value == pytest.approx(0.72)

    view_a.ui.view_dd.value = "Digitized states"
    assert view_a.worker.wait_idle(30)
    a.get_by_role("tab", name="Digitized").first.click()
    _screenshot(a, shot, "viser-digitized")
    # upload a recording, fit, download the parameter set: all through A's own GUI
    t = np.arange(1000) * 1e-3
    u = 3.0 * np.sin(2 * np.pi * 2 * t)
    y = PIModel(0.7, [0.5, 1.0, 1.5], [0.5, 0.4, 0.3])(u)
    upload_csv(a, view_a, tmp_path / "rec.csv", t, u, y)
    assert view_a.session.recording is not None and view_a.session.recording.n_samples == 1000
    assert view_b.session.recording is None
    a.get_by_role("button", name="Fit model").first.click()
    deadline = time.monotonic() + 30
    while view_a.session.fitted is None and time.monotonic() < deadline:
        time.sleep(0.1)
    assert view_a.session.fitted is not None
    a.get_by_role("tab", name="Export").first.click()
    with a.expect_download(timeout=30_000) as dl:
        a.get_by_role("button", name="Download parameter set (JSON)").first.click()
    doc = json.loads(Path(dl.value.path()).read_text())
    assert doc["model"] == view_a.session.config.model
    if shutil.which("gcc") and importlib.util.find_spec("fmpy"):  # an FMU, compiled
        with a.expect_download(timeout=60_000) as dl:
            a.get_by_role("button", name="Download FMU: compensator").first.click()
        assert dl.value.suggested_filename.endswith("-compensator-fmi3.fmu")
        assert Path(dl.value.path()).read_bytes()[:2] == b"PK"

    assert errors_a == [] and errors_b == []
    ctx_a.close()
    ctx_b.close()


def test_viser_fit_is_a_job_with_progress_and_cancel(browser: Any, live_server: dict,
                                                     shot: Any, monkeypatch: Any) -> None:
    """A fit clicked in viser runs as a job of the server's job manager: its progress and
    a "Cancel the fit" button show under the buttons; Cancel kills its worker process and
    the session's model is left as it was; then a real fit of a real recording runs."""
    from app.services.jobs import tasks
    from tests.app import job_work

    from .test_classroom import PIEZO
    from .test_viser_layout import _new_view

    app = live_server["app"]
    known = set(app.state.gui.views)
    ctx, page, errors = _open(browser, live_server["viser_url"])
    view = _new_view(app, known)
    upload_file(page, view, PIEZO, wait=60)
    assert view.session.recording is not None
    model = view.session.snapshot()[0].model
    monkeypatch.setattr(tasks, "run_fit", job_work.stalled_fit)
    page.get_by_role("button", name="Fit model").first.click()
    cancel = page.get_by_role("button", name="Cancel the fit").first
    cancel.wait_for(timeout=30_000)
    page.wait_for_selector("text=fitting… 50 %", timeout=30_000)
    [pid] = app.state.jobs.workers()
    job = app.state.jobs.recent(view.session.code)[0]
    assert (job.kind, job.state) == ("fit", "running")
    cancel.scroll_into_view_if_needed()
    shot(page, "viser-fit-progress")
    cancel.click()
    page.wait_for_selector("text=Fit cancelled", timeout=30_000)
    job_work.wait_gone(pid)
    assert job.state == "cancelled" and not cancel.is_visible()
    assert view.session.fitted is None and view.session.snapshot()[0].model == model
    monkeypatch.undo()
    page.get_by_role("button", name="Fit model").first.click()
    page.wait_for_selector("text=RMS error", timeout=120_000)
    assert view.session.fitted is not None
    assert app.state.jobs.recent(view.session.code)[0].state == "done"
    _screenshot(page, shot, "viser-fit-done")
    assert errors == []
    ctx.close()
