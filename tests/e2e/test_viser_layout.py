"""The viser GUI at a phone's and a laptop's size, and markup in a CSV it is given."""

from __future__ import annotations

import json
import time
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np

from app.gui.layout import TITLES
from core.pi import PIModel

from .test_viser_gui import _open, _screenshot, upload_csv


def _new_view(app: Any, known: set[int]) -> Any:
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        new = [v for k, v in app.state.gui.views.items() if k not in known]
        if new and new[0].rendered_version >= 0:
            return new[0]
        time.sleep(0.1)
    raise AssertionError("no new viser view")


def _plot_box(page: Any) -> dict[str, float]:
    page.wait_for_function("""() => [...document.querySelectorAll('.js-plotly-plot')]
      .some(e => e.getBoundingClientRect().width > 150)""", timeout=60_000)
    return page.evaluate("""() => {
      const r = [...document.querySelectorAll('.js-plotly-plot')]
        .map(e => e.getBoundingClientRect()).find(r => r.width > 150);
      return {left: r.left, right: r.right, top: r.top, width: r.width, height: r.height};
    }""")


def _three_operators(url: str, view: Any) -> None:
    """Give ``view``'s session paper 000's three-operator preset through the REST API (as
    a push does) and show its digitized view."""
    preset = next(p for p in json.load(urllib.request.urlopen(url + "api/presets", timeout=30))
                  if p["name"] == "paper000-three-operators")
    body = json.dumps({"model": preset["model"], "signal": preset.get("input"),
                       "use_recording": False}).encode()
    req = urllib.request.Request(f"{url}api/sessions/{view.session.code}/config", data=body,
                                 method="PATCH", headers={"Content-Type": "application/json"})
    urllib.request.urlopen(req, timeout=30).close()
    view.ui.view_dd.value = "Digitized states"
    assert view.worker.wait_idle(30)


def test_digitized_cube_camera_and_step_controls(browser: Any, live_server: dict) -> None:
    """Every vertex of the 3-operator cube apart in the browser's camera; the state is
    stepped with buttons and played at a chosen speed."""
    app = live_server["app"]
    known = set(app.state.gui.views)
    clients_before = set(app.state.viser.get_clients())
    ctx, page, errors = _open(browser, live_server["viser_url"], 1280, 800)
    view = _new_view(app, known)
    _three_operators(live_server["url"], view)
    page.get_by_role("tab", name="Digitized").first.click()
    # the camera the browser reports (viser's public client API) is off the cube's diagonal
    (client,) = [c for k, c in app.state.viser.get_clients().items() if k not in clients_before]
    deadline = time.monotonic() + 30
    pts = view._cube_points
    while time.monotonic() < deadline:
        cam = np.asarray(client.camera.position) - np.asarray(client.camera.look_at)
        d = cam / np.linalg.norm(cam)
        p000, p111 = pts[0] - d * (pts[0] @ d), pts[-1] - d * (pts[-1] @ d)
        if np.linalg.norm(p000 - p111) > 0.5:
            break
        time.sleep(0.2)
    assert np.linalg.norm(p000 - p111) > 0.5, (client.camera.position, client.camera.look_at)
    # step back with the button: the page's state line ("State k/N") goes to k - 1
    shown = "() => (document.body.innerText.match(/State (\\d+)\\/\\d+/) || [])[1] ?? null"
    page.wait_for_function(f"({shown})() !== null")
    k = int(page.evaluate(shown))
    page.get_by_role("button", name="Step back").first.click()
    page.wait_for_function(f"k => ({shown})() === String(k - 1)", arg=k)
    page.get_by_role("button", name="Step forward").first.click()
    page.wait_for_function(f"k => ({shown})() === String(k)", arg=k)
    assert page.locator("text=Speed (states/s)").count() >= 1
    assert errors == []
    ctx.close()


def test_phone_shows_a_plot(browser: Any, live_server: dict, shot: Any) -> None:
    app = live_server["app"]
    known = set(app.state.gui.views)
    ctx, page, errors = _open(browser, live_server["viser_url"], 390, 844)
    _new_view(app, known)
    box = _plot_box(page)  # waits until a plot is drawn at a readable width
    assert box["right"] <= 390 and box["width"] >= 200 and box["height"] >= 150
    _screenshot(page, shot, "viser-phone")
    assert errors == []
    ctx.close()


def test_phone_plot_title_inside_the_plot(browser: Any, live_server: dict, shot: Any) -> None:
    """On a 390x844 phone at device-pixel ratio 3 (and at 1) the plot's title is broken into
    lines the plot holds: viser's control sheet left the plot about 230 px wide, and a
    title broken for 350 px was cut at both sides ("Hysteresis loop (Classical PI model, r").
    The sheet now takes the phone's width: the plot at least 330 x 280 px (issue 33)."""
    app = live_server["app"]
    for dpr in (3, 1):
        known = set(app.state.gui.views)
        ctx = browser.new_context(viewport={"width": 390, "height": 844}, device_scale_factor=dpr,
                                  is_mobile=dpr > 1, has_touch=dpr > 1)
        try:
            page = ctx.new_page()
            page.set_default_timeout(60_000)
            page.goto(live_server["viser_url"])
            page.wait_for_selector("text=Session code", timeout=60_000)
            _new_view(app, known)
            page.wait_for_function("""() => { const p = [...document.querySelectorAll(
                '.js-plotly-plot')].find(e => e.getBoundingClientRect().width > 150);
                return p && p._fullLayout && p.querySelector('.gtitle'); }""", timeout=60_000)
            parts = page.evaluate("""() => {
              const p = [...document.querySelectorAll('.js-plotly-plot')]
                .find(e => e.getBoundingClientRect().width > 150);
              const r = (e) => { const b = e.getBoundingClientRect();
                                 return [b.left, b.top, b.right, b.bottom]; };
              return { plot: r(p), title: [...p.querySelectorAll('.gtitle')].map(r) };
            }""")
            left, top, right, bottom = parts["plot"]
            for t in parts["title"]:
                assert t[0] >= left - 1 and t[2] <= right + 1, (dpr, t, parts["plot"])
            # the control sheet takes the phone's width (viser's own 20em sheet at the
            # bottom right left the plot 228 x 207 px, its loop squeezed to a line)
            assert right - left >= 330 and bottom - top >= 280, (dpr, parts["plot"])
            if dpr == 3:
                _screenshot(page, shot, "viser-phone-title")
        finally:
            ctx.close()


def test_seven_digit_state_labels_do_not_pile(browser: Any, live_server: dict,
                                              shot: Any) -> None:
    """Paper 001 Example 1 as 7 digits in a viser tab's 3D state graph at 1500x900: the
    labels (drawn in WebGL, so read from what the tab's scene was sent) are one, the
    current state's, beside the red ball; the 23 visited states' labels piled on each
    other ("0011111" on "1011111")."""
    from app.services.explore.simulation import state_text

    app = live_server["app"]
    known = set(app.state.gui.views)
    ctx, page, errors = _open(browser, live_server["viser_url"], 1500, 900)
    try:
        view = _new_view(app, known)
        d = view.last_result.digitized
        assert d is not None and d.model.n == 7
        labels = [h for h in view.cube._handles if type(h).__name__ == "LabelHandle"]
        k = int(view.ui.digi_step.value)
        assert [h.text for h in labels] == [state_text(np.asarray(d.trace.digits[k]))]
        _screenshot(page, shot, "viser-state-labels")
        assert errors == []
    finally:
        ctx.close()


def test_laptop_panel_leaves_the_cube_in_view(browser: Any, live_server: dict,
                                              shot: Any) -> None:
    app = live_server["app"]
    known = set(app.state.gui.views)
    ctx, page, errors = _open(browser, live_server["viser_url"], 1280, 800)
    view = _new_view(app, known)
    _three_operators(live_server["url"], view)
    box = _plot_box(page)
    # the cube is drawn at the scene origin, the centre of the canvas: the plot panel
    # ends well left of it
    assert box["right"] < 0.42 * 1280
    # the camera is off the cube's diagonal: 000 and 111 project to different points
    cam = np.asarray(view.camera.position) - np.asarray(view.camera.look_at)
    pts = view._cube_points
    d = cam / np.linalg.norm(cam)
    p000, p111 = pts[0] - d * (pts[0] @ d), pts[-1] - d * (pts[-1] @ d)
    assert np.linalg.norm(p000 - p111) > 0.5
    # stepping back moves the state, the 3D marker and the plot's marker together
    last = int(view.ui.digi_step.value)
    view._step_by(-1)
    tr = view.last_result.digitized.trace
    cur = next(t for t in view.ui.plot.figure.data if t["name"] == "current state")
    assert cur["x"] == [float(tr.x_b[last - 1])]
    assert f"State {last - 1}/" in view.ui.digi_md.content
    # the plot toolbar offers nothing that uploads the chart
    page.hover(".js-plotly-plot")
    page.wait_for_selector(".modebar-btn")
    titles = page.locator(".modebar-btn").evaluate_all(
        "els => els.map(e => e.getAttribute('data-title') || '')")
    assert titles and not any("Share" in t or "Cloud" in t or "Studio" in t for t in titles)
    _screenshot(page, shot, "viser-digitized-cube")
    assert errors == []
    ctx.close()


def test_markup_in_a_csv_is_not_drawn(browser: Any, live_server: dict, tmp_path: Path) -> None:
    app = live_server["app"]
    known = set(app.state.gui.views)
    ctx, page, errors = _open(browser, live_server["viser_url"])
    view = _new_view(app, known)
    t = np.arange(300) * 1e-3
    u = 3.0 * np.sin(2 * np.pi * 4 * t)
    y = PIModel(0.7, [0.5, 1.0], [0.5, 0.4])(u)
    upload_csv(page, view, tmp_path / "<img src=x onerror=alert(1)>.csv", t, u, y)
    assert view.session.recording is not None
    page.wait_for_selector("text=<img src=x onerror=alert(1)>.csv")
    assert page.locator("img[src=x]").count() == 0
    assert errors == []
    ctx.close()


_PANEL_AND_TOASTS = """() => {
  const label = [...document.querySelectorAll("label")]
    .find((e) => e.textContent.trim() === "Projector: large plot");
  let panel = label;
  while (panel && !["absolute", "fixed"].includes(getComputedStyle(panel).position)) {
    panel = panel.parentElement;
  }
  const box = (e) => { const r = e.getBoundingClientRect();
    return {left: r.left, top: r.top, right: r.right, bottom: r.bottom}; };
  return {panel: panel ? box(panel) : null,
          toasts: [...document.querySelectorAll("[class*='Notification-root']")]
            .filter((e) => e.getClientRects().length).map(box)};
}"""


def _overlap(a: dict[str, float], b: dict[str, float]) -> bool:
    return (a["left"] < b["right"] and b["left"] < a["right"] and a["top"] < b["bottom"]
            and b["top"] < a["bottom"])


def test_toasts_leave_the_plot_panel_free(browser: Any, live_server: dict, shot: Any) -> None:
    """Issue 33: viser's toasts (top left) covered the floating panel's view selector and
    the plot's title. Two toasts on a 1500x900 laptop, then with the projector's panel at
    1920x1080: none overlaps the plot panel or another toast; four quick "Lesson" toasts
    leave one, the newest."""
    app = live_server["app"]
    for width, height, projector in ((1500, 900, False), (1920, 1080, True)):
        known = set(app.state.gui.views)
        ctx, page, errors = _open(browser, live_server["viser_url"], width, height)
        view = _new_view(app, known)
        _plot_box(page)
        if projector:
            view.ui.projector.value = True
            page.wait_for_function("""() => [...document.querySelectorAll('.js-plotly-plot')]
              .some(e => e.getBoundingClientRect().width > 1000)""", timeout=60_000)
        view._toast("Lesson", "the class is at step 2 of 6: The same run in time")
        view._toast("Your teacher pushed a change", "Your teacher moved the class to step 2.")
        page.wait_for_function(f"() => ({_PANEL_AND_TOASTS})().toasts.length >= 2",
                               timeout=30_000)
        page.wait_for_timeout(600)  # the toasts' entry animation
        seen = page.evaluate(_PANEL_AND_TOASTS)
        assert seen["panel"] is not None, seen
        assert not any(_overlap(t, seen["panel"]) for t in seen["toasts"]), seen
        # nor over each other (issue 33: they stacked on one another)
        ts = seen["toasts"]
        assert not any(_overlap(a, b) for i, a in enumerate(ts) for b in ts[i + 1:]), seen
        assert all(t["right"] <= width and t["bottom"] <= height for t in seen["toasts"]), seen
        shot(page, f"viser-toasts-{width}")
        if not projector:
            # a lesson's quick moves: one "Lesson" toast, the newest (four piled up and
            # climbed over the plot panel, issue 33)
            for k in range(3, 7):
                view._toast("Lesson", f"the class is at step {k} of 6")
                page.wait_for_timeout(300)
            page.wait_for_timeout(1200)  # the replaced toasts' exit animation
            lessons = page.evaluate("""() => [...document.querySelectorAll(
                "[class*='Notification-root']")].filter((e) => e.getClientRects().length
                && e.textContent.startsWith("Lesson")).map((e) => e.textContent)""")
            assert lessons == ["Lessonthe class is at step 6 of 6"], lessons
            seen = page.evaluate(_PANEL_AND_TOASTS)
            assert not any(_overlap(t, seen["panel"]) for t in seen["toasts"]), seen
            shot(page, "viser-toasts-lesson-moves")
        assert errors == []
        ctx.close()



_LESSON_TOASTS = """() => [...document.querySelectorAll("[class*='Notification-root']")]
  .filter((e) => e.getClientRects().length && e.textContent.startsWith("Lesson"))
  .map((e) => [e.textContent, e.dataset.seen || ""])"""


def test_a_lesson_toast_changes_in_place_and_stays_its_time(browser: Any, live_server: dict,
                                                            shot: Any) -> None:
    """Issue 33 (a class of thirty): each move's "Lesson" toast removed the one on show
    and showed a new one, two transitions in every student's tab per move (~50 ms of its
    main thread). The toast on show now takes the new text in place (the same element,
    marked here, is still there with the new text) and stays 6 s after its last change,
    not after it was first shown; a toast that has closed is shown anew."""
    from app.gui.toasts import AUTO_CLOSE_S, CHANGE_WITHIN_S

    app = live_server["app"]
    known = set(app.state.gui.views)
    ctx, page, errors = _open(browser, live_server["viser_url"], 1500, 900)
    view = _new_view(app, known)
    _plot_box(page)
    # The server changes a toast in place only within CHANGE_WITHIN_S of its last change (the
    # browser may have closed it since): on a loaded machine the first toast can take seconds
    # to show, and step 2 then rightly comes as a new toast. That case is the machine's, not
    # the feature's: the sequence is tried again (at most three times) until every change
    # was sent within the window on the server's clock.
    for _attempt in range(3):
        sent = [time.monotonic()]
        view._toast("Lesson", "the class is at step 1 of 6")
        page.wait_for_function(f"() => ({_LESSON_TOASTS})().length === 1", timeout=30_000)
        t0 = time.monotonic()
        page.evaluate("""() => [...document.querySelectorAll("[class*='Notification-root']")]
          .forEach((e) => { e.dataset.seen = "first"; })""")
        for k in (2, 3):
            page.wait_for_timeout(1500)
            sent.append(time.monotonic())
            view._toast("Lesson", f"the class is at step {k} of 6")
        if max(np.diff(sent)) < CHANGE_WITHIN_S - 0.5:
            break
        page.wait_for_function(f"() => ({_LESSON_TOASTS})().length === 0", timeout=30_000)
    else:
        raise AssertionError(f"the first toast took {np.diff(sent)} s to show three times")
    page.wait_for_function(f"() => ({_LESSON_TOASTS})().some((t) => t[0].includes('step 3'))",
                           timeout=30_000)
    t_last = time.monotonic()
    page.wait_for_timeout(700)
    assert page.evaluate(_LESSON_TOASTS) == [["Lessonthe class is at step 3 of 6", "first"]]
    shot(page, "viser-toast-changed-in-place")
    # past the first showing's 6 s, within the last change's: still on show
    page.wait_for_timeout(max(0.0, t0 + AUTO_CLOSE_S + 1.0 - time.monotonic()) * 1e3)
    assert time.monotonic() - t_last < AUTO_CLOSE_S - 0.5
    assert page.evaluate(_LESSON_TOASTS) == [["Lessonthe class is at step 3 of 6", "first"]]
    # and closed after its own 6 s; the next move shows a new one
    page.wait_for_function(f"() => ({_LESSON_TOASTS})().length === 0", timeout=30_000)
    assert time.monotonic() - t_last >= AUTO_CLOSE_S - 0.5
    view._toast("Lesson", "the class is at step 4 of 6")
    page.wait_for_function(f"() => ({_LESSON_TOASTS})().length === 1", timeout=30_000)
    assert page.evaluate(_LESSON_TOASTS) == [["Lessonthe class is at step 4 of 6", ""]]
    assert errors == []
    ctx.close()

_BAR_AND_TITLE = """() => {
  const plot = [...document.querySelectorAll('.js-plotly-plot')]
    .filter((e) => e.getBoundingClientRect().width > 150)[0];
  const box = (e) => { const r = e.getBoundingClientRect();
    return {left: r.left, top: r.top, right: r.right, bottom: r.bottom}; };
  const bar = plot && plot.querySelector('.modebar');
  const title = plot && plot.querySelector('.gtitle');
  return {bar: bar && bar.getClientRects().length ? box(bar) : null,
          title: title ? box(title) : null};
}"""


def test_the_plot_title_is_clear_of_the_toolbar(browser: Any, live_server: dict,
                                                shot: Any) -> None:
    """Issue 33: in the floating panel plotly's toolbar (shown on hover, top right) sat on
    the centred plot title (Loop and Time views of a 1500x900 laptop)."""
    app = live_server["app"]
    known = set(app.state.gui.views)
    ctx, page, errors = _open(browser, live_server["viser_url"], 1500, 900)
    view = _new_view(app, known)
    for name in ("loop", "time"):
        view.ui.view_dd.value = TITLES[name]
        assert view.worker.wait_idle(30) and view.shown_figure == name
        page.wait_for_function(f"() => {{ const t = document.querySelector("
                               f"'.js-plotly-plot .gtitle'); return t && t.textContent"
                               f".includes({json.dumps(TITLE_WORDS[name])}); }}",
                               timeout=30_000)
        page.locator(".js-plotly-plot").first.hover()
        page.wait_for_function(f"() => ({_BAR_AND_TITLE})().bar !== null", timeout=30_000)
        seen = page.evaluate(_BAR_AND_TITLE)
        assert seen["title"] is not None, seen
        assert not _overlap(seen["bar"], seen["title"]), (name, seen)
        shot(page, f"viser-title-toolbar-{name}")
    assert errors == []
    ctx.close()


TITLE_WORDS = {"loop": "Hysteresis loop", "time": "Input and output"}


#: The time view's x-axis title and the lower plot's area (plotly's drag rectangle of the
#: subplot "xy2"), boxes in CSS px.
TIME_AXIS = """() => {
  const plot = [...document.querySelectorAll('.js-plotly-plot')]
    .filter((e) => e.getBoundingClientRect().width > 150)[0];
  const box = (e) => { const r = e.getBoundingClientRect();
    return {left: r.left, top: r.top, right: r.right, bottom: r.bottom}; };
  const title = plot && [...plot.querySelectorAll('.g-xtitle text, .xtitle')]
    .find((e) => e.textContent.includes('time t'));
  const lower = plot && plot.querySelector('.nsewdrag[data-subplot="xy2"]');
  const legend = plot && plot.querySelector('.legend');
  return title && lower ? {title: box(title), lower: box(lower),
                           legend: legend ? box(legend) : null} : null;
}"""


def test_the_loop_legend_is_clear_of_the_axis_title(browser: Any, live_server: dict,
                                                   shot: Any) -> None:
    """In the 470 px floating panel (1500x900) the Loop view's legend, placed at a fraction of
    the short plot's height below it, sat on the x-axis title ("input u [a.u.]" on "initial
    loading curve"); the legend now sits at the figure's foot."""
    app = live_server["app"]
    known = set(app.state.gui.views)
    ctx, page, errors = _open(browser, live_server["viser_url"], 1500, 900)
    try:
        view = _new_view(app, known)
        assert view.shown_figure == "loop"
        page.wait_for_function("""() => { const p = document.querySelector('.js-plotly-plot');
            return p && p.querySelector('.legend') && p.querySelector('.xtitle'); }""",
                               timeout=60_000)
        page.wait_for_timeout(300)
        seen = page.evaluate("""() => { const p = document.querySelector('.js-plotly-plot');
          const r = (e) => { const b = e.getBoundingClientRect();
                             return [b.left, b.top, b.right, b.bottom]; };
          return { legend: r(p.querySelector('.legend')), title: r(p.querySelector('.xtitle')),
                   plot: r(p) }; }""")
        lg, tt = seen["legend"], seen["title"]
        apart = lg[2] <= tt[0] or tt[2] <= lg[0] or lg[3] <= tt[1] or tt[3] <= lg[1]
        assert apart, ("the legend sits on the x-axis title", seen)
        assert lg[3] <= seen["plot"][3] + 1, seen
        _screenshot(page, shot, "viser-loop-legend")
        assert errors == []
    finally:
        ctx.close()


def test_the_time_axis_title_is_under_the_lower_plot(browser: Any, live_server: dict,
                                                     shot: Any) -> None:
    """Issue 33: in the floating panel the Time view's x-axis title "time t [s]" (of the
    axis anchored to the upper plot) was drawn inside the lower plot."""
    app = live_server["app"]
    known = set(app.state.gui.views)
    ctx, page, errors = _open(browser, live_server["viser_url"], 1500, 900)
    view = _new_view(app, known)
    view.ui.view_dd.value = TITLES["time"]
    assert view.worker.wait_idle(30) and view.shown_figure == "time"
    page.wait_for_function(f"() => ({TIME_AXIS})() !== null", timeout=30_000)
    page.wait_for_timeout(300)
    seen = page.evaluate(TIME_AXIS)
    assert seen["title"]["top"] >= seen["lower"]["bottom"], seen
    assert seen["legend"] is not None and not _overlap(seen["legend"], seen["title"]), seen
    shot(page, "viser-time-axis")
    assert errors == []
    ctx.close()


def test_the_time_axis_title_is_under_the_lower_plot_on_the_web_page(
        browser: Any, live_server: dict, shot: Any) -> None:
    """The same figure on the web page (1366x768 and a 390x844 phone): the time axis's
    title under the lower plot, the legend clear of it."""
    from .test_web_journeys import _clean
    from .test_web_journeys import _open as _open_web

    for width, height in ((1366, 768), (390, 844)):
        ctx, page, log = _open_web(browser, live_server["url"], width=width, height=height)
        page.click("#tabs button[data-fig=time]")
        page.wait_for_function("() => document.body.dataset.fig === 'time'")
        page.wait_for_function(f"() => ({TIME_AXIS})() !== null", timeout=30_000)
        page.wait_for_timeout(400)
        seen = page.evaluate(TIME_AXIS)
        assert seen["title"]["top"] >= seen["lower"]["bottom"], (width, seen)
        if seen["legend"] is not None:  # (a phone drops the legend)
            assert not _overlap(seen["legend"], seen["title"]), (width, seen)
        page.locator(".js-plotly-plot").first.scroll_into_view_if_needed()
        shot(page, f"web-time-axis-{width}")
        _clean(page, log)
        ctx.close()
