"""A teacher-led lesson in real Chromium (issue 19): the teacher starts "PI basics" on the
web page and moves the class two steps; two web students and a viser student follow live
(the step's prompt, model and view); a student explores and returns to the class step; a
viser tab with the teacher token moves the class on; the teacher makes a lesson from the
screen, downloads it and loads the file again."""

from __future__ import annotations

import json
import re
import time
import urllib.request
from pathlib import Path
from typing import Any

from app.gui.layout import TITLES
from app.services.teaching.lessons import class_lesson, parse_lesson

from .conftest import TEACHER_TOKEN
from .test_viser_gui import _open as _open_viser
from .test_viser_gui import _screenshot as _viser_shot
from .test_viser_gui import _views
from .test_web_journeys import _clean, _listening, _open, _text_has

AT_STEP = ("([n, fig]) => document.body.dataset.lessonStep === n"
           " && document.body.dataset.fig === fig")


def _lesson(url: str) -> dict[str, Any]:
    with urllib.request.urlopen(url + "api/lesson", timeout=10) as r:
        return json.load(r)


def _wait(cond: Any, what: str, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError(what)
        time.sleep(0.1)


def test_teacher_leads_pi_basics_and_a_student_returns(browser: Any, live_server: dict,
                                                        shot: Any, tmp_path: Path) -> None:
    url, app = live_server["url"], live_server["app"]
    ctx_a, a, log_a = _open(browser, url)
    ctx_b, b, log_b = _open(browser, url, width=390, height=844)  # a phone
    ctx_t, t, log_t = _open(browser, url)
    ctx_v, v, errors_v = _open_viser(browser, live_server["viser_url"])
    _listening(url, a, b)
    try:
        view = _views(app, 1)[-1]  # the newest tab: this test's viser student
        # the teacher starts the lesson from the web page's Teacher panel
        t.click("#teacher summary")
        t.fill("#teacher-token", TEACHER_TOKEN)
        t.select_option("#lesson-pick", "name:pi-basics")
        t.click("#lesson-start")
        _text_has(t, "lesson-msg", "Step 1 of 6")
        for k in (2, 3):
            t.click("#lesson-next")
            _text_has(t, "lesson-msg", f"Step {k} of 6")
        step = _lesson(url)
        assert (step["step"], step["view"]) == (3, "operators")

        # both web students see the step's prompt, model and view, live
        for page in (a, b):
            page.wait_for_function(AT_STEP, arg=["3", "operators"])
            assert page.inner_text("#lesson-prompt") == step["prompt"]
            assert "step 3 of 6" in page.inner_text("#lesson-where")
            assert "step 3 of 6" in page.inner_text("#live-note")
            session = app.state.registry.get(page.inner_text("#code"))
            assert session.config.model == step["model"]
        shot(a, "lesson-student-step3")
        shot(b, "lesson-student-phone-step3")
        shot(t, "lesson-teacher")

        # so does the viser student (its view, its model, the prompt in its Lesson folder)
        _wait(lambda: view.session.config.model == step["model"]
              and view.figure_name == "operators", "the viser tab did not follow the class")
        assert view.ui.view_dd.value == TITLES["operators"]
        assert view.worker.wait_idle(30) and view.shown_figure == "operators"
        v.get_by_text("What each operator adds").first.wait_for()
        assert "step 3 of 6" in view.lesson.md.content
        _viser_shot(v, shot, "lesson-viser-step3")

        # student A explores (drags p0), then returns to the class step with one button
        a.locator("#ctl-p0").focus()
        for _ in range(5):
            a.locator("#ctl-p0").press("ArrowRight")
        a.wait_for_function("() => document.body.dataset.lessonStep === 'exploring'")
        _text_has(a, "lesson-state", "exploring")
        code_a = a.inner_text("#code")
        _wait(lambda: app.state.registry.get(code_a).config.model["p0"] > 0.72,
              "the explored p0 was not stored")
        a.select_option("#preset", "paper001-example4")  # and looks at another view
        a.click("#load-preset")
        a.click("#tabs button[data-fig='loop']")
        shot(a, "lesson-student-exploring")
        a.click("#lesson-return")
        a.wait_for_function(AT_STEP, arg=["3", "operators"])
        assert app.state.registry.get(code_a).config.model == step["model"]
        assert b.evaluate("() => document.body.dataset.lessonStep") == "3"  # B untouched
        b.reload()  # a reloaded page is back on the class step, with its view and prompt
        b.wait_for_function(AT_STEP, arg=["3", "operators"])
        assert b.inner_text("#lesson-prompt") == step["prompt"]
        _listening(url, b)

        # the viser student explores and comes back too
        view.session.update(lambda c: c.with_model({**c.model, "p0": 1.1}))
        _wait(lambda: "exploring" in view.lesson.md.content, "viser did not say exploring")
        v.get_by_role("button", name="Back to the class step").first.click()
        _wait(lambda: view.session.config.model == step["model"]
              and "on the class step" in view.lesson.md.content, "viser did not return")

        # a teacher's viser tab leads too: with the token it moves the class on a step
        # (the folder's header, not the "type it under *Session*" note)
        v.locator("div.mantine-Paper-root", has_text=re.compile(r"^Session$")).first.click()
        label = v.locator("label", has_text="Teacher token").first
        label.wait_for()  # its input is in the same row (viser gives it no accessible name)
        label.locator("xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]//input"
                      ).fill(TEACHER_TOKEN)
        _wait(lambda: view.ui.teacher_token.value == TEACHER_TOKEN, "viser: no token typed")
        v.get_by_text("Teacher: lead a lesson").first.click()
        v.get_by_role("button", name="Next step ▶").first.click()
        for page in (a, b, t):
            page.wait_for_function(AT_STEP, arg=["4", "loading"])
        assert view.ui.teacher_token.value == ""  # cleared: a projector shows it no longer

        # the teacher makes a lesson from the screen, downloads it, loads the file again
        t.click("#lesson-make summary")
        t.fill("#lesson-new-title", "<b>my</b> loading curve")
        t.fill("#lesson-new-prompt", "Which operator moves last?")
        t.click("#lesson-add")
        _text_has(t, "lesson-msg", "Added step 1")
        shot(t, "lesson-teacher-made")
        with t.expect_download() as dl:
            t.click("#lesson-download")
        mine = parse_lesson(Path(dl.value.path()).read_bytes())
        assert [(s.title, s.view) for s in mine.steps] == [("<b>my</b> loading curve",
                                                             "loading")]
        t.set_input_files("#lesson-file", str(dl.value.path()))
        _text_has(t, "lesson-msg", "1 step.")
        assert "file: My lesson" in t.inner_text("#lesson-pick")
        t.click("#lesson-end")
        for page in (a, b):
            page.wait_for_selector("#lesson", state="hidden")
            _text_has(page, "live-note", "ended the lesson")
        _wait(lambda: view.lesson.md.content == "*No lesson is running.*", "viser: still on")
        # the lesson being made survives a reload of the teacher's page, until cleared
        t.reload()
        t.wait_for_selector("body[data-ready]")
        t.wait_for_selector("#lesson-pick option[value='draft']", state="attached")
        t.click("#teacher summary")
        t.click("#lesson-make summary")
        t.click("#lesson-clear")
        assert t.locator("#lesson-pick option[value='draft']").count() == 0
        for page, log in ((a, log_a), (b, log_b), (t, log_t)):
            _clean(page, log)
        assert errors_v == []
    finally:
        class_lesson(app.state.registry)._move(None)  # other journeys see no lesson
        for ctx in (ctx_a, ctx_b, ctx_t, ctx_v):
            ctx.close()


def _teach(url: str, method: str, path: str, body: dict[str, Any] | None = None) -> Any:
    req = urllib.request.Request(
        url + path, method=method, data=None if body is None else json.dumps(body).encode(),
        headers={"X-Teacher-Token": TEACHER_TOKEN, "Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=30) as r:
        return json.load(r)


#: Records plotly's redraws of the page's figure: for each, when the lesson's "step k of n"
#: last changed, and the last change of it the page had painted (a frame after it).
REDRAWS = """() => {
  window.__reacts = [];
  window.__changed = 0;
  window.__painted = 0;
  const real = Plotly.react;
  Plotly.react = function (el, ...rest) {
    if (el.id === "figure") window.__reacts.push([window.__changed, window.__painted]);
    return real.call(this, el, ...rest);
  };
  // a change counts as painted in the first frame after it: the frame's callbacks run before
  // it is painted and before any timer they queue, such as the page's own wait for the
  // paint (rAF, then a timer) before it redraws; a marker set a timer later raced that wait
  new MutationObserver(() => { const t = performance.now();
    window.__changed = t;
    requestAnimationFrame(() => { window.__painted = t; }); })
    .observe(document.getElementById("lesson-where"), { childList: true, characterData: true,
                                                         subtree: true });
}"""


def test_a_step_that_changes_only_its_texts_is_not_drawn_again(browser: Any,
                                                                live_server: dict) -> None:
    """A lesson's step with the same model, input and view as the one before it shows its
    texts and does not run plotly's redraw again (issue 33: in a class of thirty every
    redraw is a long task on the shared machine); a step with another view is drawn after
    its texts are painted."""
    url = live_server["url"]
    ctx, page, log = _open(browser, url)
    _listening(url, page)
    steps = [{"title": f"Same loop {k}", "preset": "paper001-example1", "view": "loop",
              "prompt": f"Prompt {k}."} for k in (1, 2)]
    steps.append({"title": "In time", "preset": "paper001-example1", "view": "time",
                  "prompt": "Prompt 3."})
    # body[data-plotted] is only cleared here, before each move: it then names the moved-to
    # step's figure once plotly has drawn (or skipped) it. Left as it was, it still named the
    # figure before the move, the wait ended before the move's drawing and a late redraw
    # (step 1 at the lesson's height) was counted against step 2.
    drawn = ("([n, fig]) => document.body.dataset.lessonStep === n && "
             "document.body.dataset.plotted === `${fig}@${document.body.dataset.ready}`")
    unplotted = "() => { delete document.body.dataset.plotted; }"
    try:
        page.wait_for_function("() => window.Plotly && document.body.dataset.plotted === "
                               "`loop@${document.body.dataset.ready}`")
        page.evaluate(unplotted)
        _teach(url, "POST", "api/teacher/lesson",
               {"lesson": {"title": "Texts only", "steps": steps}})
        page.wait_for_function(drawn, arg=["1", "loop"])
        page.evaluate(REDRAWS)
        page.evaluate(unplotted)
        _teach(url, "POST", "api/teacher/lesson/step", {"move": 1})
        page.wait_for_function(drawn, arg=["2", "loop"])
        assert page.inner_text("#lesson-prompt") == "Prompt 2."
        assert page.evaluate("window.__reacts.length") == 0  # the same figure: not redrawn
        page.evaluate(unplotted)
        _teach(url, "POST", "api/teacher/lesson/step", {"move": 1})
        page.wait_for_function(drawn, arg=["3", "time"])
        reacts = page.evaluate("window.__reacts")
        assert len(reacts) == 1, reacts
        # the step's texts were painted (a frame after their change) before the redraw
        assert reacts[0][0] > 0 and reacts[0][1] == reacts[0][0], reacts
        assert log["errors"] == []
    finally:
        _teach(url, "DELETE", "api/teacher/lesson")
        ctx.close()
