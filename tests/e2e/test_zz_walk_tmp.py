from __future__ import annotations
import re, time
from typing import Any
from .test_classroom import PIEZO
from .test_viser_gui import _open as _open_viser, _views, upload_file, _screenshot
from .test_words import _leaks, PAGE_TEXT
from .test_projector_lesson import _api
from .test_lesson_journey import AT_STEP
from .test_web_journeys import _open

W = "/tmp/uileft-walk/"

def test_walk_viser_diagnosis(browser: Any, live_server: dict) -> None:
    app = live_server["app"]
    known = set(app.state.gui.views)
    vctx, v, errors = _open_viser(browser, live_server["viser_url"], width=1500, height=900)
    try:
        view = _views(app, 1, known=known)[-1]
        upload_file(v, view, PIEZO, wait=60)
        v.get_by_role("button", name="Run diagnosis").first.click()
        t0 = time.monotonic()
        seen = []
        while view.session.diagnosis_result is None and time.monotonic() - t0 < 240:
            seen.append(view.ui.report_md.content)
            time.sleep(0.3)
        v.wait_for_timeout(3000)
        assert view.worker.wait_idle(60)
        _screenshot(v, lambda p, n: p.screenshot(path=W + n + ".png"), "viser-diagnosis")
        print("PROGRESS", sorted(set(seen))[:12])
        open(W + "viser-report.md", "w").write(view.ui.report_md.content)
        title = v.evaluate("() => { const p = document.querySelector('.js-plotly-plot'); return p && p._fullLayout && p._fullLayout.title.text; }")
        print("TITLE", title)
        text = v.evaluate("() => document.body.innerText")
        print("LEAKS", _leaks(text + "\n" + (title or "")))
        print("BODY", text[-1500:])
    finally:
        vctx.close()

def test_walk_web_projector_lesson5(browser: Any, live_server: dict) -> None:
    url = live_server["url"]
    ctx, page, log = _open(browser, url, width=1920, height=1080)
    try:
        page.click("#projector")
        pos = _api(url, "POST", "api/teacher/lesson", {"name": "what-a-diagnosis-finds"})
        for k in range(1, pos["steps"] + 1):
            if k > 1:
                pos = _api(url, "POST", "api/teacher/lesson/step", {"move": 1})
            page.wait_for_function(AT_STEP, arg=[str(k), pos["view"]])
            page.wait_for_function("() => document.body.dataset.settled === document.body.dataset.ready && window.Plotly")
            page.wait_for_timeout(800)
            page.screenshot(path=W + f"web-proj-l5-{k}.png")
            print("STEP", k, pos["view"], _leaks(page.evaluate(PAGE_TEXT)))
        _api(url, "DELETE", "api/teacher/lesson")
    finally:
        ctx.close()

def test_walk_viser_phone(browser: Any, live_server: dict) -> None:
    app = live_server["app"]
    known = set(app.state.gui.views)
    ctx = browser.new_context(viewport={"width": 390, "height": 844}, device_scale_factor=3, is_mobile=True, has_touch=True)
    v = ctx.new_page()
    try:
        v.goto(live_server["viser_url"])
        v.wait_for_selector("text=Session code", timeout=60_000)
        _views(app, 1, known=known)
        for wait in (4000, 8000):
            v.wait_for_timeout(wait)
            print("BOXES", wait, v.evaluate("""() => { const r = (e) => { const b = e.getBoundingClientRect(); return [Math.round(b.left), Math.round(b.top), Math.round(b.right), Math.round(b.bottom)]; };
              const p = document.querySelector('.js-plotly-plot'); return { plot: p && r(p), full: p && p._fullLayout && [p._fullLayout.width, p._fullLayout.height], title: p ? [...p.querySelectorAll('.gtitle')].map(r) : null, ttext: p && p._fullLayout && p._fullLayout.title.text, vw: innerWidth }; }"""))
        v.screenshot(path=W + "viser-phone.png")
        v.screenshot(path=W + "viser-phone-full.png", full_page=True)
    finally:
        ctx.close()
