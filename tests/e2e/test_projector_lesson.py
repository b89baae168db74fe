"""Projector mode with a lesson open (issue 33, item 1), in real Chromium at 1920x1080: the
teacher leads "Inverse compensation" (inverse, loop, closed-loop views) and "PI basics" with
the page in projector mode. On every step the whole plot is on the screen without
scrolling: its title inside the plot, its axis titles and its legend above the fold, and
the notes and status line under it."""

from __future__ import annotations

import json
import urllib.request
from typing import Any

from .conftest import TEACHER_TOKEN
from .test_lesson_journey import AT_STEP
from .test_web_journeys import _clean, _open

#: Where the plot's parts are, in CSS px of the viewport (the page not scrolled).
PARTS = """() => {
  window.scrollTo(0, 0);
  const fig = document.getElementById('figure').getBoundingClientRect();
  const box = (sel) => [...document.querySelectorAll('#figure ' + sel)]
    .map((e) => e.getBoundingClientRect()).filter((r) => r.width > 0 && r.height > 0)
    .map((r) => [r.left, r.top, r.right, r.bottom]);
  return { fig: [fig.left, fig.top, fig.right, fig.bottom], height: window.innerHeight,
           width: window.innerWidth, title: box('.gtitle'), axes: box('.xtitle, .ytitle, '
           + '[class*="x2title"], [class*="y2title"], [class*="x3title"], [class*="y3title"]'),
           legend: box('.legend'),
           under: ['notes', 'status'].map((id) => document.getElementById(id))
             .filter((e) => e.textContent.trim()).map((e) => [e.id, e.getBoundingClientRect()
             .bottom]) };
}"""


def _api(url: str, method: str, path: str, body: dict | None = None) -> dict:
    req = urllib.request.Request(url + path, method=method,
                                 data=None if body is None else json.dumps(body).encode(),
                                 headers={"X-Teacher-Token": TEACHER_TOKEN,
                                          "Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=30) as r:
        return json.load(r)


def _whole_plot_on_screen(page: Any, where: str) -> None:
    p = page.evaluate(PARTS)
    fl, ft, fr, fb = p["fig"]
    assert fb <= p["height"] + 1, f"{where}: the plot ends at {fb:.0f} px of {p['height']}"
    assert p["title"], f"{where}: no plot title"
    for left, top, right, _bottom in p["title"]:  # the title inside the plot, not cut
        assert left >= fl - 1 and right <= fr + 1 and top >= ft - 1, (where, p)
    assert p["axes"], f"{where}: no axis titles"
    for left, top, right, bottom in p["axes"] + p["legend"]:
        assert bottom <= min(fb, p["height"]) + 1 and right <= p["width"] + 1, (where, p)
        assert left >= 0 and top >= 0, (where, p)
    # the notes under the plot (the closed-loop step's explanation) and the status line too
    for name, bottom in p["under"]:
        assert bottom <= p["height"] + 1, f"{where}: #{name} ends at {bottom:.0f} px"


def test_projector_shows_the_whole_plot_on_every_lesson_step(browser: Any, live_server: dict,
                                                             shot: Any) -> None:
    url = live_server["url"]
    ctx, page, log = _open(browser, url, width=1920, height=1080)
    try:
        page.click("#projector")
        page.wait_for_function("() => document.body.classList.contains('projector')")
        for name in ("inverse-compensation", "pi-basics"):
            pos = _api(url, "POST", "api/teacher/lesson", {"name": name})
            for k in range(1, pos["steps"] + 1):
                if k > 1:
                    pos = _api(url, "POST", "api/teacher/lesson/step", {"move": 1})
                page.wait_for_function(AT_STEP, arg=[str(k), pos["view"]])
                page.wait_for_function("() => document.body.dataset.settled === "
                                       "document.body.dataset.ready && window.Plotly")
                page.wait_for_timeout(400)  # plotly's relayout of the new height
                _whole_plot_on_screen(page, f"{name} step {k} ({pos['view']})")
                if pos["view"] in ("closed-loop", "operators"):
                    shot(page, f"projector-lesson-{pos['view']}")
        _api(url, "DELETE", "api/teacher/lesson")
        _clean(page, log)
    finally:
        ctx.close()


def test_viser_projector_with_a_lesson_open(browser: Any, live_server: dict,
                                            shot: Any) -> None:
    """viser at 1920x1080 in projector mode while a lesson runs: the plot is wide, and its
    legend sits clear of the x-axis titles (the legend moves above the plot)."""
    from .test_viser_gui import _open as _open_viser
    from .test_viser_gui import _screenshot as _viser_shot
    from .test_viser_gui import _views

    url, app = live_server["url"], live_server["app"]
    known = set(app.state.gui.views)
    ctx, v, errors = _open_viser(browser, live_server["viser_url"], width=1920, height=1080)
    try:
        _views(app, 1, known=known)
        pos = _api(url, "POST", "api/teacher/lesson", {"name": "inverse-compensation"})
        for _ in range(pos["steps"] - 1):
            pos = _api(url, "POST", "api/teacher/lesson/step", {"move": 1})
        v.add_style_tag(content="[class*='Notifications-root'], [class*='Notifications-root'] "
                                "* {pointer-events:none !important}")
        v.get_by_text("Projector: large plot", exact=True).first.click()
        v.wait_for_function("() => { const p = document.querySelector('.js-plotly-plot');"
                            " return p && p.getBoundingClientRect().width > 0.55 * 1920"
                            " && p._fullLayout && p._fullLayout.width > 0.55 * 1920"
                            " && p._fullLayout.legend && p._fullLayout.legend.y >= 1"
                            " && p._fullLayout.title.text.includes('<br>'); }",
                            timeout=60_000)
        v.wait_for_timeout(500)
        parts = v.evaluate("""() => {
          const p = document.querySelector('.js-plotly-plot');
          const r = (e) => { const b = e.getBoundingClientRect();
                             return [b.left, b.top, b.right, b.bottom]; };
          return { plot: r(p), title: [...p.querySelectorAll('.gtitle')].map(r),
                   legend: [...p.querySelectorAll('.legend')].map(r),
                   xtitles: [...p.querySelectorAll('.xtitle, [class*="x2title"]')].map(r) };
        }""")
        assert parts["legend"] and parts["xtitles"] and parts["title"], parts
        left, _, right, _ = parts["plot"]
        for t in parts["title"]:  # the long closed-loop title in lines, not cut
            assert t[0] >= left - 1 and t[2] <= right + 1, (t, parts["plot"])
        for lg in parts["legend"]:
            for xt in parts["xtitles"]:
                apart = lg[2] <= xt[0] or xt[2] <= lg[0] or lg[3] <= xt[1] or xt[3] <= lg[1]
                assert apart, ("the legend sits on an x-axis title", lg, xt)
        _viser_shot(v, shot, "projector-lesson-viser")
        _api(url, "DELETE", "api/teacher/lesson")
        assert errors == []
    finally:
        ctx.close()
