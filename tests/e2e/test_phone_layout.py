"""The explorer on a phone (issue 33, item 4), in real Chromium at 390x844, device-pixel
ratio 3: the plot's toolbar clear of its title; the 7-digit state diagram with no labels on
each other, none cut at the screen's edge, no blank screen under its plots, opened at the
first state so that "step forward" steps; a number box beside every slider, whose exact
value (finer than a finger's drag) reaches the session; nothing overlapping."""

from __future__ import annotations

from typing import Any

from .test_web_journeys import _CSP_WATCH, _clean

PHONE = {"viewport": {"width": 390, "height": 844}, "device_scale_factor": 3,
         "is_mobile": True, "has_touch": True}

#: Boxes (left, top, right, bottom in CSS px) of the selector's elements inside the figure.
BOXES = """sel => [...document.querySelectorAll(sel)].map(e => e.getBoundingClientRect())
  .filter(r => r.width > 0 && r.height > 0).map(r => [r.left, r.top, r.right, r.bottom])"""

#: The session's stored configuration (what the server keeps, not what the page shows).
CONFIG = """async () => (await (await fetch(`/api/sessions/${
  document.getElementById('code').textContent}`)).json()).config"""


def _overlap(a: list[float], b: list[float], slack: float = 1.0) -> bool:
    return (min(a[2], b[2]) - max(a[0], b[0]) > slack
            and min(a[3], b[3]) - max(a[1], b[1]) > slack)


def _plotly_drawn(page: Any, view: str) -> None:
    page.wait_for_function("f => document.body.dataset.fig === f && window.Plotly && "
                           "document.getElementById('figure')._fullLayout && "
                           "!document.getElementById('figure').classList.contains('live')",
                           arg=view)


def test_phone_toolbar_state_diagram_and_number_boxes(browser: Any, live_server: dict,
                                                       shot: Any) -> None:
    ctx = browser.new_context(**PHONE)
    ctx.add_init_script(_CSP_WATCH)
    log: dict[str, list[str]] = {"errors": [], "outside": []}
    try:
        page = ctx.new_page()
        page.set_default_timeout(60_000)
        page.on("pageerror", lambda e: log["errors"].append(str(e)))
        page.goto(live_server["url"])
        page.wait_for_selector("body[data-ready]")
        _plotly_drawn(page, "loop")

        # the toolbar (shown on a tap) is clear of the title
        bar = page.evaluate(BOXES, "#figure .modebar")
        title = page.evaluate(BOXES, "#figure .gtitle")
        assert bar and title, (bar, title)
        assert not any(_overlap(a, b) for a in bar for b in title), (bar, title)
        assert page.evaluate("() => document.scrollingElement.scrollWidth") <= 390
        shot(page, "phone-loop")

        # the state diagram of paper 001 Example 1 as a digitized model (7 digits)
        page.click("#tabs button[data-fig='digitized']")
        _plotly_drawn(page, "digitized")
        page.wait_for_function("() => document.body.dataset.digiState === '0'")
        assert page.input_value("#digi-step") == "0"
        labels = page.evaluate(BOXES, "#figure .textpoint")
        assert labels, "the current state is not named"
        for i, a in enumerate(labels):
            assert a[0] >= 0 and a[2] <= 390, f"a label is cut at the screen's edge: {a}"
            for b in labels[i + 1:]:
                assert not _overlap(a, b), (a, b)
        fig = page.evaluate("() => { const r = document.getElementById('figure')"
                            ".getBoundingClientRect(); return [r.top, r.bottom]; }")
        drawn = page.evaluate(BOXES, "#figure g.subplot, #figure .infolayer text")
        blank = fig[1] - max(a[3] for a in drawn)
        assert blank < 60, f"{blank:.0f} px blank under the plots"
        title = page.evaluate(BOXES, "#figure .gtitle")
        bar = page.evaluate(BOXES, "#figure .modebar")
        assert not any(_overlap(a, b) for a in bar for b in title), (bar, title)
        shot(page, "phone-digitized-first-state")
        page.click("#digi-next")
        page.wait_for_function("() => document.body.dataset.digiState === '1'")
        page.locator("#digi-controls").scroll_into_view_if_needed()
        shot(page, "phone-digitized-step-1")

        # a number box beside each slider; an exact value typed reaches the session
        boxes = page.evaluate("""() => [...document.querySelectorAll('aside input[type=range]')]
            .filter(r => r.id !== 'digi-step').map(r => [r.id,
              Boolean(r.parentElement.querySelector('input[type=number]'))])""")
        assert boxes and all(has for _, has in boxes), boxes
        page.fill("#amplitude-num", "4.013")
        page.press("#amplitude-num", "Enter")
        page.wait_for_function(f"async () => ({CONFIG})().then(c => c.signal.amplitude === 4.013)")
        box = page.locator("aside label.ctl input[type=number]:not([disabled])").first
        path = box.evaluate("b => b.parentElement.querySelector('input[type=range]')"
                            ".dataset.path")
        old = float(box.input_value())
        new = round(old * 1.0007 + 1e-4, 6)  # well under one pixel of the slider
        box.fill(str(new))
        box.press("Enter")
        page.wait_for_function(
            """async ([path, v]) => { const c = await (""" + CONFIG + """)();
               let node = c.model;
               for (const t of path.match(/[^.[\\]]+|\\[\\d+\\]/g))
                 node = t.startsWith('[') ? node[Number(t.slice(1, -1))] : node[t];
               return Math.abs(node - v) < 1e-9; }""", arg=[path, new])
        # the slider, its number box and its label sit side by side, inside the screen
        rows = page.evaluate("""() => [...document.querySelectorAll('aside label.ctl')]
            .slice(0, 6).map(l => [...l.querySelectorAll('input')].map(e => {
              const r = e.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom];
            }))""")
        for row in rows:
            assert len(row) == 2 and not _overlap(row[0], row[1]), row
            assert all(r[2] <= 390 for r in row), row
        box.scroll_into_view_if_needed()
        shot(page, "phone-number-boxes")
        assert page.evaluate("() => window.__csp") == [] and log["errors"] == []
        _clean(page, log)
    finally:
        ctx.close()


#: The header's controls (those shown).
HEADER = ("header h1, #session, #join-code, #join, #new-session, #my-name, #upload-open, "
          "#projector, #viser-link, header a[href='/api.html']")


def test_phone_header_rows_are_packed(browser: Any, live_server: dict, shot: Any) -> None:
    """At 390x844 (DPR 3) the header wraps no row more than its controls need: no row
    starts with a control that would have fitted at the end of the row above (the name field
    held a row of its own and *API docs* another, so the plot began 49 px lower); nothing
    overlaps, nothing leaves the screen, the tabs start under the header."""
    ctx = browser.new_context(**PHONE)
    try:
        page = ctx.new_page()
        page.set_default_timeout(60_000)
        page.goto(live_server["url"])
        page.wait_for_selector("body[data-ready]")
        _plotly_drawn(page, "loop")
        items = page.evaluate(BOXES, HEADER)
        assert len(items) >= 9, items
        for i, a in enumerate(items):
            assert a[0] >= 0 and a[2] <= 390, f"a header control leaves the screen: {a}"
            for b in items[i + 1:]:
                assert not _overlap(a, b), (a, b)
        end, gap = page.evaluate("""() => { const h = document.querySelector('header');
            const s = getComputedStyle(h); return [h.getBoundingClientRect().right
              - parseFloat(s.paddingRight), parseFloat(s.columnGap)]; }""")
        rows: list[list[list[float]]] = []
        for box in sorted(items, key=lambda r: (r[1], r[0])):
            if rows and abs(box[1] - rows[-1][0][1]) < 8:
                rows[-1].append(box)
            else:
                rows.append([box])
        for above, row in zip(rows, rows[1:], strict=False):
            first = min(row, key=lambda r: r[0])
            room = end - max(r[2] for r in above) - gap
            assert first[2] - first[0] > room, (
                f"a header row starts with a control {first[2] - first[0]:.0f} px wide that "
                f"fits in the {room:.0f} px left on the row above: {rows}")
        header = page.evaluate(BOXES, "header")[0]
        tabs = page.evaluate(BOXES, "#tabs")[0]
        assert tabs[1] >= header[3] - 1, (header, tabs)
        shot(page, "phone-header")
    finally:
        ctx.close()
