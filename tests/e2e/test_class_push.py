"""A teacher's push during a lesson (issue 33, item 3), in real Chromium: the teacher leads
"PI basics" on the web page to two web students and a viser student, edits the model and
pushes it. Every student stays on the class step (the push changed the step), the teacher's
page does not say "Your teacher pushed", and the teacher's counts are the class connected
(3 web pages, 1 viser tab, 4 sessions), not every session of the last hour nor the pages
that happened to hold a stream at that instant."""

from __future__ import annotations

import json
import time
import urllib.request
from typing import Any

from .conftest import TEACHER_TOKEN
from .test_lesson_journey import AT_STEP, _lesson, _wait
from .test_viser_gui import _open as _open_viser
from .test_viser_gui import _screenshot as _viser_shot
from .test_viser_gui import _views
from .test_web_journeys import _clean, _listening, _open, _text_has

CLASS = "3 web pages and 1 3D / GUI tab open, in 4 sessions"


def _connected(url: str) -> dict[str, Any]:
    req = urllib.request.Request(url + "api/teacher/connected",
                                 headers={"X-Teacher-Token": TEACHER_TOKEN})
    with urllib.request.urlopen(req, timeout=10) as r:
        return json.load(r)


def test_a_push_during_a_lesson_keeps_the_class_on_its_step(browser: Any, live_server: dict,
                                                            shot: Any) -> None:
    url, app = live_server["url"], live_server["app"]
    # sessions of the last hour that no page shows any more: not the class
    for _ in range(3):
        urllib.request.urlopen(urllib.request.Request(url + "api/sessions", method="POST"),
                               timeout=10).close()
    known = set(app.state.gui.views)
    ctx_a, a, log_a = _open(browser, url)
    ctx_b, b, log_b = _open(browser, url, width=390, height=844)
    ctx_t, t, log_t = _open(browser, url, width=1400, height=1000)
    ctx_v, v, _ = _open_viser(browser, live_server["viser_url"])
    try:
        view = _views(app, 1, known=known)[-1]
        _listening(url, a, b, t)
        t.click("#teacher summary")
        t.fill("#teacher-token", TEACHER_TOKEN)
        t.select_option("#lesson-pick", "name:pi-basics")
        t.click("#lesson-start")
        _text_has(t, "lesson-msg", "Step 1 of 6")
        t.click("#lesson-next")
        _text_has(t, "lesson-msg", "Step 2 of 6")
        step = _lesson(url)
        for page in (a, b, t):
            page.wait_for_function(AT_STEP, arg=["2", step["view"]])
        # the counts are the class: the pages and the tab open, not the sessions of the
        # last hour (3 more above), whichever stream is reconnecting at the moment
        assert t.inner_text("#lesson-msg") == f"Step 2 of 6 sent to the class: {CLASS}."
        deadline = time.monotonic() + 11.0  # every stream ends once (10 s) and comes back
        while time.monotonic() < deadline:
            c = _connected(url)
            assert (c["pages"], c["viser_tabs"], c["sessions_live"]) == (3, 1, 4), c
            time.sleep(0.1)

        # the teacher edits the model and pushes it to the class
        t.locator("#ctl-p0").focus()
        for _ in range(4):
            t.locator("#ctl-p0").press("ArrowRight")
        t.wait_for_function("() => document.body.dataset.lessonStep === 'exploring'")
        code_t = t.inner_text("#code")
        _wait(lambda: app.state.registry.get(code_t).config.model != step["model"],
              "the teacher's edit was not stored")
        # the page sends its slider moves one at a time (each checked by the server): the
        # edit is the model once the last of the four is stored (none for 1 s)
        edited = app.state.registry.get(code_t).config.model
        quiet = time.monotonic()
        while time.monotonic() - quiet < 1.0:
            time.sleep(0.1)
            now = app.state.registry.get(code_t).config.model
            if now != edited:
                edited, quiet = now, time.monotonic()
        t.click("#teacher-push-mine")
        _text_has(t, "teacher-msg", "to the class")
        assert t.inner_text("#teacher-msg") == f"Pushed a model to the class: {CLASS}."

        # every student has the teacher's model and is still on the class step
        for page in (a, b):
            code = page.inner_text("#code")
            _wait(lambda c=code: app.state.registry.get(c).config.model == edited,
                  "a student did not get the pushed model")
            _text_has(page, "live-note", "Your teacher changed the class step")
            page.wait_for_function(AT_STEP, arg=["2", step["view"]])
            assert page.inner_text("#lesson-state") == "You are on the class step."
            assert "exploring" not in page.inner_text("#lesson-state")
        # the teacher's page speaks of the teacher's own push, and is on the step too
        _text_has(t, "live-note", "You changed the class step")
        t.wait_for_function(AT_STEP, arg=["2", step["view"]])
        assert "Your teacher" not in t.inner_text("#live-note")
        assert _lesson(url)["model"] == edited  # the class step is the pushed model now
        _wait(lambda: view.session.config.model == edited
              and "on the class step" in view.lesson.md.content,
              "the viser student is not on the class step after the push")
        assert "exploring" not in view.lesson.md.content
        shot(t, "class-push-teacher")
        shot(a, "class-push-student")
        shot(b, "class-push-student-phone")
        _viser_shot(v, shot, "class-push-viser-student")

        # a student who explores and comes back gets the pushed model
        a.locator("#ctl-p0").focus()
        a.locator("#ctl-p0").press("ArrowLeft")
        a.wait_for_function("() => document.body.dataset.lessonStep === 'exploring'")
        a.click("#lesson-return")
        a.wait_for_function(AT_STEP, arg=["2", step["view"]])
        assert app.state.registry.get(a.inner_text("#code")).config.model == edited

        t.click("#lesson-end")
        _text_has(t, "lesson-msg", "Lesson ended")
        for page, log in ((a, log_a), (b, log_b), (t, log_t)):
            _clean(page, log)
    finally:
        for ctx in (ctx_a, ctx_b, ctx_t, ctx_v):
            ctx.close()
