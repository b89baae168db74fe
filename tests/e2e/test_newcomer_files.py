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
