"""A newcomer, a teacher of paper 000 and a slow classroom network, on the web page.

Help beside each control group, presets by title, a recording's own units on the axes,
messages written for users (issue 11, failure 9); a paper 000 preset's input that visits
every state of its loop (failure 8); the first figure drawn before the plotting library
is fetched (failure 10).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from .test_jobs_page import PIEZO, _upload
from .test_web_journeys import _clean, _load_preset, _open

#: Words of the server's command-line messages a page user must never read.
DEVELOPER = ("skiprows", "no such file", "header=True", "max_rows", "run=", "(POST ",
             "(GET ", "Method Not Allowed", "Internal Server Error")


def test_newcomer_reads_help_titles_units_and_plain_messages(
        browser: Any, live_server: dict, tmp_path: Path) -> None:
    ctx, page, log = _open(browser, live_server["url"])
    # short help beside each control group and each view
    groups = page.locator("aside > section, aside > details")
    for i in range(groups.count()):
        help_ = groups.nth(i).locator(".help")
        assert help_.count(), groups.nth(i).inner_text()[:60]
        assert len(help_.first.text_content().strip()) > 40, groups.nth(i).inner_text()[:60]
    assert groups.count() >= 6  # model, input, inverse, data, export, teacher
    assert len(page.inner_text("#view-help")) > 40
    # presets by their title, with a one-line description from the papers
    titles = page.locator("#preset option").all_inner_texts()
    assert titles and not any(re.fullmatch(r"paper\d{3}-[\w=-]+", t.strip()) for t in titles)
    assert any("Example 4" in t for t in titles)
    page.select_option("#preset", "paper001-example4")
    assert "dead zone" in page.inner_text("#preset-desc")
    # a recording's axes carry its own quantities and units (the file says V and µm)
    _upload(page, PIEZO, "50001")
    page.wait_for_function("""() => {
      const l = document.getElementById('figure').layout || {};
      return /V/.test((l.xaxis?.title?.text) || '') && /µm/.test((l.yaxis?.title?.text) || '');
    }""", timeout=60_000)
    # a file of one line: a message for the user, not for a programmer
    one = tmp_path / "one-line.csv"
    one.write_text("t,u,y")
    page.set_input_files("#csv-file", str(one))
    page.wait_for_function(
        "() => document.getElementById('csv-msg').textContent.includes('not')")
    msg = page.inner_text("#csv-msg")
    assert not any(w in msg for w in DEVELOPER), msg
    assert "line" in msg, msg
    log["errors"] = [e for e in log["errors"] if "422" not in e]  # the refused preview
    _clean(page, log)
    ctx.close()


def test_paper000_preset_input_visits_every_state(browser: Any, live_server: dict) -> None:
    """The digitized presets' loops span 0…10, so their input must too (not ±4)."""
    ctx, page, log = _open(browser, live_server["url"])
    _load_preset(page, "paper000-three-operators")
    page.click("#tabs button[data-fig=time]")
    page.wait_for_function("() => document.body.dataset.fig === 'time'")
    page.wait_for_function("() => (document.getElementById('figure')._fullData || []).length")
    u = page.evaluate("""() => {
      const t = document.getElementById('figure')._fullData[0];
      return Array.from(t.y);
    }""")
    assert min(u) <= 0.05 and max(u) >= 9.95, (min(u), max(u))
    _clean(page, log)
    ctx.close()


_FIRST_FIGURE = """
window.__firstFigure = null;
new MutationObserver((_, obs) => {
  const f = document.getElementById('figure');
  if (f && f.querySelector('svg')) { window.__firstFigure = performance.now(); obs.disconnect(); }
}).observe(document, {subtree: true, childList: true});
"""


def test_first_figure_comes_before_the_plotting_library(browser: Any,
                                                        live_server: dict) -> None:
    """What the first figure waits for is small: plotly.js (4.8 MB) is fetched after it."""
    ctx = browser.new_context(viewport={"width": 1400, "height": 860})
    ctx.add_init_script(_FIRST_FIGURE)
    page = ctx.new_page()
    page.set_default_timeout(60_000)
    page.goto(live_server["url"])
    page.wait_for_function("() => window.__firstFigure !== null")
    page.wait_for_selector("#figure .main-svg")  # plotly arrives and takes over
    before = page.evaluate("""() => performance.getEntriesByType('resource')
      .filter(e => e.startTime < window.__firstFigure)
      .map(e => [e.name, e.encodedBodySize])""")
    names = [n for n, _ in before]
    assert not any("plotly" in n and n.endswith(".js") for n in names), names
    assert sum(size for _, size in before) < 500_000, before
    assert "Hysteresis loop" in page.inner_text("#figure")
    ctx.close()
