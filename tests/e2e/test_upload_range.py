"""After an upload the Loop view shows the recording (issue 33, item 5), in real Chromium:
an engineer uploads the piezo recording (+-150 V in, about -20..20 um out) while the session
still holds paper 001's Example 1, whose output on that input spans about +-380. The Loop
view's output axis is the measurement's range (the measured loop fills the plot instead of
a flat line) and a note says the model was not fitted to it; after a fit the preset box no
longer says Example 1. The same on a viser tab.

Each read of plotly's axes waits until plotly has drawn the view asked for at the session's
version (``body[data-plotted]`` is ``view@version``, set after ``Plotly.react``):
``body[data-fig]`` and the notes are set when a draw ends, which a quick plot (a live move)
ends before plotly draws, and ``data-settled === data-ready`` holds across views of one
version (the Fit view and the Loop view after a fit), so those waits could read the Fit
view's axes under the Loop tab. A draw overtaken by a newer one draws nothing
(``test_a_slow_figure_never_replaces_the_newer_view``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from core.csvio import read_csv

from .test_classroom import PIEZO
from .test_viser_gui import _open as _open_viser
from .test_viser_gui import _screenshot as _viser_shot
from .test_viser_gui import _views, upload_file
from .test_web_journeys import _clean, _open, _text_has, _upload

Y_RANGE = "() => document.getElementById('figure')._fullLayout.yaxis.range"
X_RANGE = "() => document.getElementById('figure')._fullLayout.xaxis.range"


def _plotted(page: Any, view: str) -> None:
    """Wait until plotly has drawn ``view`` at the version the page shows."""
    page.wait_for_function("v => document.body.dataset.fig === v && document.body.dataset"
                           ".plotted === `${v}@${document.body.dataset.ready}`", arg=view)


def _measured() -> tuple[float, float]:
    rec = read_csv(PIEZO)
    rec = rec[0] if isinstance(rec, list) else rec
    return float(np.min(rec.y)), float(np.max(rec.y))


def _on_the_measurement(rng: list[float], lo: float, hi: float) -> None:
    span = hi - lo
    # the axis holds the measurement, padded by less than a fifth of its span each side
    assert rng[0] <= lo and rng[1] >= hi, (rng, lo, hi)
    assert rng[0] >= lo - 0.2 * span and rng[1] <= hi + 0.2 * span, (rng, lo, hi)


def test_the_loop_view_shows_the_uploaded_recording(browser: Any, live_server: dict,
                                                     shot: Any) -> None:
    lo, hi = _measured()
    app = live_server["app"]
    ctx, page, log = _open(browser, live_server["url"], width=1400, height=1000)
    try:
        assert page.input_value("#preset") == "paper001-example1"
        _upload(page, PIEZO, "50001")
        page.click("#tabs button[data-fig='loop']")
        page.wait_for_function("() => document.body.dataset.fig === 'loop'")
        _text_has(page, "notes", "not fitted to this recording")
        _plotted(page, "loop")
        assert page.evaluate(X_RANGE)[1] > 100  # the recording's input, +-150 V
        _on_the_measurement(page.evaluate(Y_RANGE), lo, hi)
        shot(page, "upload-loop-range")
        # a fit: the preset box says the model is the recording's now
        page.click("#fit")
        page.wait_for_selector("#report .msg.ok", timeout=120_000)
        _plotted(page, "fit")
        # the Fit view's loop holds the measurement (it was drawn on y = -1..4 after the
        # Loop view on the measurement's range)
        _on_the_measurement(page.evaluate(Y_RANGE), lo, hi)
        shot(page, "upload-fit-view")
        shown = page.evaluate("() => { const s = document.getElementById('preset');"
                              " return s.options[s.selectedIndex].textContent; }")
        assert "Example 1" not in shown and "fitted" in shown, shown
        assert "Example 1" not in page.inner_text("#preset-desc")
        # the fitted model on its recording: on one plot, no note
        page.click("#tabs button[data-fig='loop']")
        page.wait_for_function("() => document.body.dataset.fig === 'loop'")
        _plotted(page, "loop")
        assert "not fitted" not in page.inner_text("#notes")
        # the whole measured loop is in view again (no range kept from before the fit)
        _on_the_measurement(page.evaluate(Y_RANGE), lo, hi)
        shot(page, "upload-fitted-preset-box")
        _clean(page, log)
    finally:
        ctx.close()

    known = set(app.state.gui.views)
    vctx, v, _ = _open_viser(browser, live_server["viser_url"])
    try:
        view = _views(app, 1, known=known)[-1]
        upload_file(v, view, PIEZO, wait=60)
        assert view.session.recording is not None
        # the tab may draw a figure on the way (under load one with y = +-9.1 was read); the
        # view it settles on holds the measurement, read once it does (or after the deadline)
        try:
            v.wait_for_function("([lo, hi]) => { const p = document.querySelector("
                                "'.js-plotly-plot'); const r = p && p._fullLayout && "
                                "p._fullLayout.yaxis && p._fullLayout.yaxis.range;"
                                " return r && r[0] <= lo && r[1] >= hi; }", arg=[lo, hi],
                                timeout=60_000)
        except Exception as exc:  # playwright's TimeoutError: the assertion below says what
            if type(exc).__name__ != "TimeoutError":  # was drawn
                raise
        rng = v.evaluate("() => document.querySelector('.js-plotly-plot')._fullLayout"
                         ".yaxis.range")
        _on_the_measurement(rng, lo, hi)
        assert "not fitted to this recording" in view.ui.notes_md.content
        _viser_shot(v, shot, "upload-loop-range-viser")
    finally:
        vctx.close()


def test_a_slow_figure_never_replaces_the_newer_view(browser: Any, live_server: dict) -> None:
    """An engineer clicks Loop, then Time before the Loop figure came (a long recording, a
    busy server): the Time view stays when the Loop figure comes late (it used to be drawn
    under the Time tab, and the page said the Loop view was the Time view)."""
    ctx, page, log = _open(browser, live_server["url"], width=1400, height=1000)
    held: list[Any] = []
    try:
        page.route("**/figures?name=loop*", lambda route: held.append(route))
        page.click("#tabs button[data-fig='loop']")
        page.wait_for_function("() => document.querySelector(\"#tabs button.active\")"
                               ".dataset.fig === 'loop'")
        while not held:  # the Loop figure's request is held
            page.wait_for_timeout(50)
        page.click("#tabs button[data-fig='time']")
        _plotted(page, "time")
        with page.expect_response("**/figures?name=loop*") as late:
            held[0].continue_()
        assert late.value.ok
        page.unroute("**/figures?name=loop*")
        # the page has the late figure; the next draw (another Time click) comes after it
        v = page.get_attribute("body", "data-plotted")
        page.click("#tabs button[data-fig='time']")
        _plotted(page, "time")
        assert page.get_attribute("body", "data-plotted") == v
        title = page.evaluate("() => document.getElementById('figure')._fullLayout"
                              ".xaxis.title.text")
        assert title.startswith("time"), title
        assert page.evaluate("() => document.body.dataset.fig") == "time"
        _clean(page, log)
    finally:
        ctx.close()
