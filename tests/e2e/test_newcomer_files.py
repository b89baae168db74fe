"""A newcomer's files (issue 33, item 6), in real Chromium: a 6 MB CSV is refused in the
browser from its size before anything is sent; a PNG is "not a CSV text file" in words;
a negative weight is explained (what it does to the slopes and to invertibility); the
exported files are named for the model, without the session's code."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .test_web_journeys import _clean, _open, _text_has

PNG = (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x00\x01\x00\x00\x00\x01\x08\x06"
       b"\x00\x00\x00\x1f\x15\xc4\x89\x00\x00\x00\rIDATx\x9cc\xf8\x0f\x00\x00\x01\x01\x00"
       b"\x05\x18\xd8N\x00\x00\x00\x00IEND\xaeB`\x82")


def test_newcomer_files_are_checked_and_explained(browser: Any, live_server: dict,
                                                  tmp_path: Path, shot: Any) -> None:
    app = live_server["app"]
    limit = app.state.settings.max_upload_bytes
    ctx, page, log = _open(browser, live_server["url"], width=1400, height=1000)
    sent: list[str] = []
    page.on("request", lambda r: sent.append(r.url) if "/csv/preview" in r.url
            or "/recording" in r.url else None)
    try:
        # a file over the limit: refused from its size, nothing sent
        big = tmp_path / "long-run.csv"
        row = "0.000100,1.234567,2.345678\n"
        with big.open("w") as f:
            f.write("t,u,y\n")
            f.write(row * (limit // len(row) + 1000))
        page.set_input_files("#csv-file", str(big))
        _text_has(page, "csv-msg", "long-run.csv is")
        msg = page.inner_text("#csv-msg")
        assert "MB" in msg and "more than" in msg and "bytes" not in msg, msg
        assert page.is_hidden("#mapping")
        # a picture: in plain words, and not sent either
        png = tmp_path / "loop.png"
        png.write_bytes(PNG)
        page.set_input_files("#csv-file", str(png))
        _text_has(page, "csv-msg", "not a CSV text file")
        msg = page.inner_text("#csv-msg")
        assert "PNG image" in msg and "NUL" not in msg and "byte offset" not in msg, msg
        page.locator("#csv-msg").scroll_into_view_if_needed()
        shot(page, "newcomer-png")
        assert sent == [], sent

        def apply(weights: list[float]) -> None:
            doc = {"type": "pi", "p0": 0.72, "thresholds": [0.45, 0.9, 1.35],
                   "weights": weights}
            v = page.get_attribute("body", "data-ready")
            page.fill("#model-json", json.dumps(doc))
            page.click("#apply-json")
            page.wait_for_function("v => document.body.dataset.ready !== v", arg=v)

        # a negative weight: accepted (the slopes stay > 0) and explained
        page.click("#json-edit summary")
        apply([0.6, -0.3, 0.2])
        _text_has(page, "notes", "Negative weight p2 = -0.3")
        note = page.inner_text("#notes")
        assert "stays invertible" in note and "slope" in note, note
        shot(page, "newcomer-negative-weight")
        # a weight that makes a slope negative: no inverse, said so
        apply([0.6, -1.5, 0.2])
        _text_has(page, "notes", "no inverse")

        # exports named for the model, without the session code
        code = page.inner_text("#code")
        for link in ("#dl-json", "#dl-c"):
            with page.expect_download() as dl:
                page.click(link)
            name = dl.value.suggested_filename
            assert code not in name and code.replace("-", "") not in name, name
            assert name.startswith("hysteresis-classical-pi-model"), name
        _clean(page, log)
    finally:
        ctx.close()


_SEEN = """(e) => {
    const r = e.getBoundingClientRect();
    if (!r.width || !r.height || r.top < 0 || r.left < 0 || r.bottom > innerHeight
        || r.right > innerWidth) return false;
    const at = document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2);
    return at === e || e.contains(at);
  }"""
#: Whether the element of a selector is wholly in the window and the one found at its
#: centre (not under another, not scrolled out of its side panel).
_IN_VIEW = f"(sel) => ({_SEEN})(document.querySelector(sel))"

#: The on-screen element that opens the CSV file chooser, or null: #csv-file itself or a
#: control that opens it (aria-controls), wholly inside the window and its scrolling side
#: panel, and the one found at its centre (nothing over it).
_UPLOAD_IN_VIEW = """() => {
  const seen = """ + _SEEN + """;
  const all = [document.getElementById('csv-file'),
               ...document.querySelectorAll('[aria-controls="csv-file"]')];
  const e = all.find((x) => x && seen(x));
  return e ? { id: e.id, top: e.getBoundingClientRect().top, scrollY: window.scrollY,
               aside: document.querySelector('aside').scrollTop } : null;
}"""


def test_newcomer_reaches_the_csv_upload_without_scrolling(
        browser: Any, live_server: dict, tmp_path: Path, shot: Any) -> None:
    """Issue 33 item 6: the upload sat below the fold in the side panel's own scroll (at
    1920x1080 and 1366x768); now a control in view opens the same chooser, and the chosen
    file's column mapping is then in view."""
    csv = tmp_path / "first-try.csv"
    t = [i / 1000 for i in range(400)]
    csv.write_text("t,u,y\n" + "".join(f"{x:.3f},{4 * (x % 0.2):.4f},{3 * (x % 0.2):.4f}\n"
                                       for x in t))
    for width, height in ((1920, 1080), (1366, 768)):
        ctx, page, log = _open(browser, live_server["url"], width=width, height=height)
        try:
            found = page.evaluate(_UPLOAD_IN_VIEW)
            assert found is not None, f"no CSV upload in view at {width}x{height}"
            assert found["scrollY"] == 0 and found["aside"] == 0, found
            shot(page, f"newcomer-upload-{width}")
            with page.expect_file_chooser() as fc:
                page.click(f"#{found['id']}")
            fc.value.set_files(str(csv))
            _text_has(page, "csv-msg", "400 rows")
            assert page.evaluate(_IN_VIEW, "#use-csv"), "the mapping's button is out of view"
            assert page.evaluate(_IN_VIEW, "#upload-open"), "the header scrolled away"
            shot(page, f"newcomer-upload-mapping-{width}")
            page.click("#use-csv")
            _text_has(page, "csv-msg", "Loaded first-try.csv")
            _clean(page, log)
        finally:
            ctx.close()


def test_the_diagnosis_report_is_named_for_the_recording(browser: Any, live_server: dict,
                                                         tmp_path: Path) -> None:
    """The diagnosis report, the last export with the session code in its name, is named for
    the recording on both interfaces; a viser tab reloaded onto a diagnosed session can
    download it (its button stayed disabled until the tab ran a diagnosis itself)."""
    from tests.app.recordings import small_diagnosis

    from .test_viser_gui import _open as _open_viser
    from .test_viser_gui import _views
    from .test_web_journeys import _upload

    rec, _ = small_diagnosis()
    csv = tmp_path / "creep-run.csv"
    csv.write_text("t,u,y\n" + "".join(f"{a:.6f},{b:.6f},{c:.6f}\n"
                                       for a, b, c in zip(rec.t, rec.u, rec.y, strict=True)))
    app = live_server["app"]
    ctx, page, log = _open(browser, live_server["url"], width=1400, height=1000)
    try:
        code = page.inner_text("#code")
        _upload(page, csv, "1500")
        page.click("#diagnose")
        page.wait_for_selector("#diagnosis", timeout=180_000)
        href = page.get_attribute("#report a[href$='report.html']", "href")
        assert href, page.inner_text("#report")
        link = page.evaluate("h => new URL(h, location.href).href", href)
        disposition = page.request.get(link).headers.get("content-disposition", "")
        assert "diagnosis-creep-run.html" in disposition, disposition
        assert code not in disposition and code.replace("-", "") not in disposition
        _clean(page, log)
    finally:
        ctx.close()

    known = set(app.state.gui.views)
    vctx, v, errors = _open_viser(browser, live_server["viser_url"])
    try:
        view = _views(app, 1, known=known)[-1]
        code = view.session.code
        with open(csv, "rb") as f:  # the tab's session diagnosed elsewhere (the REST API)
            body = f.read()
        req = v.request
        r = req.post(f"{live_server['url']}api/sessions/{code}/recording?name=creep-run.csv",
                     data=body, headers={"Content-Type": "text/csv"})
        assert r.ok, r.text()
        r = req.post(f"{live_server['url']}api/sessions/{code}/diagnose", timeout=180_000)
        assert r.ok, r.text()
        known = set(app.state.gui.views)
        v.reload()  # the tab comes back onto its session, diagnosed
        v.wait_for_selector("text=Session code", timeout=60_000)
        _views(app, 1, known=known)
        v.get_by_role("tab", name="Data").first.click()
        button = v.get_by_role("button", name="Download diagnosis report (HTML)").first
        v.wait_for_function("b => !b.disabled", arg=button.element_handle(), timeout=60_000)
        with v.expect_download() as dl:
            button.click()
        name = dl.value.suggested_filename
        assert name == "diagnosis-creep-run.html", name
        assert errors == [], errors
    finally:
        vctx.close()
