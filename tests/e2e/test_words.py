"""The diagnosis view in one voice and in words (issue 33, item 2), in real Chromium: an
engineer uploads the piezo recording, fits a dead-zone GPI and runs the diagnosis. One
"after" error is on the screen (the findings' first sentence, the effect's sentence and the
plot's title give the same number), and no text a person reads in any view (the page's text,
the plot's titles, legends and axes, the fit menu, the progress, the status line, the
slider groups) holds a name of the code: the registry's type names and class names, its
field names (``app.services.words.internal_names``). The viser tab is scanned the same way
for the dead-zone GPI and its fit menu."""

from __future__ import annotations

import re
from typing import Any

from app.services.words import internal_names

from .test_classroom import PIEZO
from .test_viser_gui import _open as _open_viser
from .test_viser_gui import _screenshot as _viser_shot
from .test_viser_gui import _views
from .test_web_journeys import _clean, _load_preset, _open, _text_has, _upload

VIEWS = ("loop", "time", "operators", "loading", "inverse", "digitized", "closed-loop", "fit",
         "diagnosis")
#: Everything a person reads on the web page: its text (not the Model JSON editor, which
#: shows the document itself, nor the API link), the plot's SVG text, the menus' options.
PAGE_TEXT = """() => {
  const skip = new Set(['json-edit']);
  const parts = [];
  const walk = (n) => {
    if (n.nodeType === 3) { parts.push(n.textContent); return; }
    if (n.nodeType !== 1 || skip.has(n.id) || n.tagName === 'SCRIPT' || n.tagName === 'STYLE'
        || n.tagName === 'TEXTAREA') return;
    if (n.tagName === 'SELECT') { for (const o of n.options) parts.push(o.textContent); return; }
    if (n.hidden || (n.getClientRects && !n.getClientRects().length && n.tagName !== 'OPTION'
        && !(n instanceof SVGElement))) return;
    if (n.title) parts.push(n.title);
    for (const c of n.childNodes) walk(c);
  };
  walk(document.body);
  return parts.join('\\n');
}"""


def _leaks(text: str, extra: tuple[str, ...] | list[str] = ()) -> list[str]:
    """The internal names in ``text`` (a name is a whole token: ``pi`` in "a pi model",
    not in "PI" or "spin"; ``state0``, ``gpi-deadzone``, ``PIModel``), and the names in
    ``extra`` (a diagnosis's fitted parameters: asymmetry's ``a2`` is no field of a
    registered type, so ``internal_names`` does not hold it)."""
    found = []
    for name in (*internal_names(), *extra):
        if re.search(rf"(?<![\w\-.]){re.escape(name)}(?![\w\-])", text):
            found.append(name)
    return found


def test_diagnosis_in_one_voice_and_no_code_names(browser: Any, live_server: dict,
                                                   shot: Any) -> None:
    url, app = live_server["url"], live_server["app"]
    ctx, page, log = _open(browser, url, width=1400, height=1000)
    try:
        seen: dict[str, list[str]] = {}
        fitted: list[str] = []  # the diagnosis's parameter names that are symbols

        def scan(where: str) -> None:
            leaks = _leaks(page.evaluate(PAGE_TEXT), fitted)
            if leaks:
                seen[where] = leaks

        _load_preset(page, "paper001-example4")  # a dead-zone GPI
        for view in VIEWS[:7]:  # (data-fig is set once the view is drawn)
            page.click(f"#tabs button[data-fig='{view}']")
            page.wait_for_function("f => document.body.dataset.fig === f", arg=view)
            scan(f"dead-zone GPI, {view}")
        _upload(page, PIEZO, "50001")
        page.select_option("#fit-kind", "gpi-deadzone")
        page.click("#fit")
        page.wait_for_selector("#report .msg.ok", timeout=120_000)
        fit_msg = page.inner_text("#report")
        assert re.search(r"RMS error [\d.]+ µm", fit_msg), fit_msg
        page.wait_for_function("() => document.body.dataset.fig === 'fit'")
        scan("after the fit, fit view")
        shot(page, "words-fit")
        page.click("#diagnose")
        progress: list[str] = []
        while not page.locator("#diagnosis").count():
            progress.append(page.inner_text("#csv-msg"))
            page.wait_for_timeout(150)
        assert not _leaks("\n".join(progress)), progress
        page.wait_for_function("() => document.body.dataset.fig === 'diagnosis'")
        page.wait_for_function(
            "() => ((document.getElementById('figure')._fullLayout || {}).title || {}).text")
        title = page.evaluate("() => document.getElementById('figure')._fullLayout.title.text")
        items = page.locator("#diagnosis li").all_inner_texts()
        doc = app.state.registry.get(page.inner_text("#code")).diagnosis.result.to_dict()
        fitted += [k for e in doc["effects"] for k in e.get("parameters", {})
                   if re.search(r"[_\d]", k)]
        after = f"{doc['final']['heldout_rmse']:.3g}"
        # one "after": the first sentence, the effect's sentence, the plot title
        assert f"by {after} µm" in items[0], items[0]
        assert doc["effects"], "the piezo recording's diagnosis found no effect"
        if len(doc["effects"]) == 1:
            assert f"to {after} µm RMS" in items[1], items[1]
        assert title.endswith(f"→ {after} µm)"), title
        afters = {n for i in items[:len(doc["effects"]) + 1] for n in
                  re.findall(r"(?:\bto|added, by) (\d+(?:\.\d+)?) µm", i)}
        assert afters == {after}, (afters, items)
        assert "Fitted: histo" not in "\n".join(items)
        scan("diagnosis view")
        # the status line names what was diagnosed (it said "Dead-zone GPI → Constant
        # output offset", the session's fitted model, for initial memory plus asymmetry)
        status = page.inner_text("#status")
        for effect in doc["effects"]:
            assert effect["name"].replace("-", " ") in status.lower(), (effect["name"], status)
        assert "GPI" not in status, status
        page.locator("#diagnosis").scroll_into_view_if_needed()
        shot(page, "words-diagnosis")
        for view in VIEWS[:7]:  # the session's model after the fit and the diagnosis
            page.click(f"#tabs button[data-fig='{view}']")
            # (the diagnosed model's closed loop on 50,001 samples is over the cost limit:
            # the page says so in words)
            page.wait_for_function("f => document.body.dataset.fig === f || document."
                                   "getElementById('model-msg').textContent.includes('priced')",
                                   arg=view)
            page.wait_for_timeout(300)
            scan(f"after the diagnosis, {view}")
        _text_has(page, "status", "ms")
        assert seen == {}, seen
        _clean(page, log)
    finally:
        ctx.close()

    # viser: the dead-zone GPI's summary, sliders and plot, the fit menu
    known = set(app.state.gui.views)
    vctx, v, errors = _open_viser(browser, live_server["viser_url"])
    try:
        view = _views(app, 1, known=known)[-1]
        view.session.update(lambda c: c.with_model(
            app.state.registry.get(view.session.code).config.model))
        from app.services.explore.simulation import preset_doc
        view.session.update(lambda c: c.with_model(preset_doc("paper001-example4")["model"]))
        v.wait_for_timeout(1500)
        assert view.worker.wait_idle(30)
        _viser_shot(v, shot, "words-viser-gpi")
        v.get_by_role("tab", name="Data").first.click()
        v.wait_for_timeout(500)
        options = list(view.ui.fit_kind.options)
        text = "\n".join([v.evaluate("() => document.body.innerText"),
                          v.evaluate("() => [...document.querySelectorAll('svg text')]"
                                     ".map(t => t.textContent).join('\\n')"),
                          *options])
        assert _leaks(text) == [], _leaks(text)
        assert "Dead-zone GPI" in options
    finally:
        vctx.close()
