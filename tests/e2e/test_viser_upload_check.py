"""viser's CSV upload checks a file before keeping any of it (issue 33, item 6), in real
Chromium: a file over the upload limit and a PNG get, in a viser tab, the very words the web
page says for the same files (in the Data section and a toast), nothing of them is kept,
the upload's progress toast goes and the button takes the next file, which loads.

viser's client sends every part of a file without waiting for the server (viser 1.1's
upload button has no size limit), so the tab's refusal comes on the upload's start message
(its declared size) and on its first part (its first bytes), not before the file is sent;
the web page refuses before sending anything (``test_newcomer_files.py``)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from .test_classroom import PIEZO
from .test_newcomer_files import PNG
from .test_viser_gui import _open as _open_viser
from .test_viser_gui import _views, upload_file
from .test_web_journeys import _open, _text_has


def _web_message(page: Any, path: Path, words: str) -> str:
    page.set_input_files("#csv-file", str(path))
    _text_has(page, "csv-msg", words)
    return str(page.inner_text("#csv-msg")).strip()


def _wait(cond: Any, timeout: float = 60.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.1)
    return bool(cond())


def test_viser_refuses_a_large_or_binary_csv_in_the_web_pages_words(
        browser: Any, live_server: dict, tmp_path: Path, shot: Any) -> None:
    app = live_server["app"]
    limit = app.state.settings.max_upload_bytes
    big = tmp_path / "long-run.csv"
    row = "0.000100,1.234567,2.345678\n"
    with big.open("w") as f:
        f.write("t,u,y\n")
        f.write(row * (limit // len(row) + 1000))
    png = tmp_path / "loop.png"
    png.write_bytes(PNG)

    ctx, page, _ = _open(browser, live_server["url"], width=1400, height=1000)
    try:
        web = {big.name: _web_message(page, big, "long-run.csv is"),
               png.name: _web_message(page, png, "not a CSV text file")}
    finally:
        ctx.close()

    known = set(app.state.gui.views)
    vctx, v, errors = _open_viser(browser, live_server["viser_url"], width=1500, height=900)
    try:
        view = _views(app, 1, known=known)[-1]
        states = app.state.viser.get_clients()[next(
            cid for cid, vw in app.state.gui.views.items() if vw is view)
        ].gui._current_file_upload_states
        button = v.get_by_role("button", name="Upload CSV").first
        for path in (big, png):
            upload_file(v, view, path, wait=0)
            said = web[path.name]
            # the Data section and a toast say it (as rendered, word joiners aside)
            v.wait_for_function(
                "s => document.body.innerText.replaceAll('\\u2060', '').split(s).length > 2",
                arg=said, timeout=60_000)
            assert "CSV not loaded" in view.ui.data_md.content
            # viser's own "Uploading" toast is gone
            v.wait_for_function("() => !document.body.innerText.includes('Uploading ')",
                                timeout=30_000)
            assert view.session.recording is None
            v.wait_for_function("b => !b.disabled", arg=button.element_handle(),
                                timeout=30_000)
            if path is png:
                shot(v, "viser-upload-png-refused")
            else:
                shot(v, "viser-upload-large-refused")
        # nothing of either file was kept (the big file's late parts are dropped as they come)
        assert _wait(lambda: not states), states
        # the button takes the next file, and a CSV loads
        upload_file(v, view, PIEZO, wait=60)
        assert view.session.recording is not None
        # the Data section is written just after the recording is kept (the same handler)
        assert _wait(lambda: "CSV not loaded" not in view.ui.data_md.content), \
            view.ui.data_md.content
        assert errors == [], errors
    finally:
        vctx.close()
