"""A reloaded or rejoined web page shows its session as it is, in real Chromium.

A page reloaded during a diagnosis finds the job (``GET /api/sessions/{code}/jobs``) and
follows it: the bar, the message, Cancel, and the result once it is done. The preset list
shows the session's preset, not the first one.
"""

from __future__ import annotations

import json
from typing import Any

from .test_jobs_page import PIEZO, _buttons, _job, _upload
from .test_web_journeys import _clean, _load_preset, _open, _redrawn, _session, _text_has


def _reload(page: Any) -> None:
    page.reload()
    page.wait_for_selector("body[data-ready]")
    page.wait_for_selector("#figure .main-svg")


def test_reload_during_a_diagnosis_follows_it(browser: Any, live_server: dict,
                                              shot: Any, slow_diagnosis: None) -> None:
    app = live_server["app"]
    ctx, page, log = _open(browser, live_server["url"])
    _upload(page, PIEZO, "50001")
    code = page.inner_text("#code")
    page.click("#diagnose")
    page.wait_for_selector("#cancel-job:not([hidden])")
    first = _job(app, code)
    _reload(page)
    # the reloaded page follows the same job: bar, message, Cancel, busy buttons
    page.wait_for_selector("#job-progress:not([hidden])", timeout=30_000)
    page.wait_for_selector("#cancel-job:not([hidden])")
    assert _buttons(page) == [True, True]
    _text_has(page, "busy", "Diagnosing (started before this page was loaded)")
    page.wait_for_function("() => document.getElementById('job-progress').value > 0.02",
                           timeout=120_000)
    page.locator("#busy").scroll_into_view_if_needed()
    shot(page, "web-reload-during-diagnosis")
    page.click("#cancel-job")
    _text_has(page, "csv-msg", "Diagnosis cancelled")
    assert first.finished.wait(30) and first.state == "cancelled"
    assert _buttons(page) == [False, False] and page.is_hidden("#job-progress")
    # a second diagnosis, the page reloaded while it runs: its result is shown when done
    page.click("#diagnose")
    page.wait_for_selector("#cancel-job:not([hidden])")
    second = _job(app, code)
    assert second is not first
    _reload(page)
    page.wait_for_selector("#cancel-job:not([hidden])", timeout=30_000)
    page.wait_for_selector("#diagnosis", timeout=240_000)
    assert second.state == "done"
    assert _session(app, page).diagnosis is not None
    shown = page.inner_text("#diagnosis")
    assert second.result.summary.findings[0] in shown  # the job's own result, in sentences
    assert _buttons(page) == [False, False] and page.is_hidden("#cancel-job")
    _clean(page, log)
    ctx.close()


def test_preset_list_shows_the_sessions_preset(browser: Any, live_server: dict) -> None:
    ctx, page, log = _open(browser, live_server["url"])
    _load_preset(page, "paper001-example4")
    _reload(page)
    assert page.input_value("#preset") == "paper001-example4"
    desc = next(p["description"] for p in page.evaluate(
        "async () => (await fetch('/api/presets')).json()") if p["name"] == "paper001-example4")
    assert page.inner_text("#preset-desc") == desc
    # the model changed in the JSON editor: this browser still shows the preset it
    # started from, and says it was changed
    code = page.inner_text("#code")
    model = json.loads(page.input_value("#model-json"))
    model["pi"]["p0"] = 0.7
    v = page.get_attribute("body", "data-ready")
    page.click("#json-edit summary")  # a GPI has sliders: the JSON box starts closed
    page.fill("#model-json", json.dumps(model))
    page.click("#apply-json")
    _redrawn(page, v)
    assert _session(live_server["app"], page).config.model["pi"]["p0"] == 0.7
    _reload(page)
    assert page.input_value("#preset") == "paper001-example4"
    assert "changed since" in page.inner_text("#preset-desc")
    # another browser joining with the code has no memory of it: "a changed model"
    ctx_b, other, log_b = _open(browser, live_server["url"])
    other.fill("#join-code", code)
    other.click("#join")
    _text_has(other, "model-msg", "Joined")
    assert other.input_value("#preset") == ""
    assert other.locator("#preset option:checked").inner_text() == "(a changed model)"
    assert "not one of the presets" in other.inner_text("#preset-desc")
    # it loads the three-operator preset of paper 000; the first page, reloaded, shows it
    _load_preset(other, "paper000-three-operators")
    assert other.locator("#preset option[value='']").count() == 0
    _reload(page)
    assert page.input_value("#preset") == "paper000-three-operators"
    assert "changed since" not in page.inner_text("#preset-desc")
    assert _session(live_server["app"], page).config.model["type"] == "digitized"
    for p, lg in ((page, log), (other, log_b)):
        _clean(p, lg)
    ctx.close()
    ctx_b.close()
