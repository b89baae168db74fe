"""Projector mode with a lesson open (issue 33, item 1), in real Chromium at 1920x1080: the
teacher leads "Inverse compensation" (inverse, loop, closed-loop views) and "PI basics" with
the page in projector mode. On every step the whole plot is on the screen without
scrolling: its title inside the plot, its axis titles and its legend above the fold."""

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
           legend: box('.legend') };
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
