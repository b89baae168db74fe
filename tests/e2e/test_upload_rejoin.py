"""Upload notes, the run picker and a rejoin with an unknown code, on the web page."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from app.services.analysis.loops import split_runs

from .test_web_journeys import _clean, _open, _session, _text_has

BH = Path(__file__).resolve().parents[2] / "examples" / "data" / "bh_loops" / "MnZn_ferrite.csv"
UNKNOWN = "abcd-efgh-jkmn-pqrs"  # well formed, never issued by this server


def test_cleaning_notes_and_run_picker(browser: Any, live_server: dict, tmp_path: Path,
                                       shot: Any) -> None:
    app = live_server["app"]
    ctx, page, log = _open(browser, live_server["url"])
    page.set_input_files("#csv-file", str(BH))
    page.wait_for_selector("#mapping:not([hidden])")
    # columns named with units (u_H_Am, y_B_T) are mapped by their role prefix
    assert page.input_value("#u-col") == "3" and page.input_value("#y-col") == "4"
    assert page.input_value("#t-col") == ""  # no time column: the reader decides
    page.click("#use-csv")
    # by default every loop is kept, each its own, as hyst fit and hyst diagnose read the file
    _text_has(page, "csv-msg", "516 samples")
    notes = page.locator("#csv-notes li").all_inner_texts()
    assert any("all 4 runs" in n and "each its own loop" in n for n in notes), notes
    assert any("sample index" in n for n in notes), notes
    assert not any("run=" in n for n in notes), notes  # no API argument names
    page.wait_for_selector("#runs:not([hidden])")
    options = page.locator("#run-pick option").all_inner_texts()
    assert options == ["run 0", "run 1", "run 2", "run 3",
                       "all 4 runs, each its own loop (fitted together, as hyst fit does)",
                       "all 4 runs as one recording"]
    assert page.input_value("#run-pick") == "each"
    assert len(split_runs(_session(app, page).recording)) == 4
    shot(page, "web-upload-runs")
    page.select_option("#run-pick", "2")
    _text_has(page, "csv-msg", "run 2")
    notes = page.locator("#csv-notes li").all_inner_texts()
    assert any("4 runs" in n and "kept run 2" in n for n in notes), notes
    assert not any("run=" in n for n in notes), notes
    rec = _session(app, page).recording
    assert str(rec.run) == "2" and rec.n_samples == 129
    # every loop of run 2 is the file's rows with loop == 2
    rows = [r.split(",") for r in BH.read_text().splitlines()[1:]]
    want = [float(r[3]) for r in rows if r[0] == "2"]
    assert list(rec.u) == want
    page.select_option("#run-pick", "all")
    _text_has(page, "csv-msg", "516 samples")
    assert _session(app, page).recording.n_samples == len(rows)
    assert any("every row" in n for n in page.locator("#csv-notes li").all_inner_texts())
    assert page.input_value("#run-pick") == "all"
    # a file without runs hides the picker again
    plain_csv = tmp_path / "one.csv"
    plain_csv.write_text("t,u,y\n" + "\n".join(f"{k / 1000},{k % 7},{k % 5}" for k in range(50)))
    page.set_input_files("#csv-file", str(plain_csv))
    page.wait_for_selector("#mapping:not([hidden])")
    page.click("#use-csv")
    _text_has(page, "csv-msg", "50 samples")
    assert page.is_hidden("#runs")
    _clean(page, log)
    ctx.close()


def test_unknown_code_on_join_and_on_reload(browser: Any, live_server: dict, shot: Any) -> None:
    ctx, page, log = _open(browser, live_server["url"])
    code = page.inner_text("#code")
    page.fill("#join-code", UNKNOWN)
    page.click("#join")
    _text_has(page, "model-msg", "No session")
    msg = page.inner_text("#model-msg")
    assert "mistyped" in msg and "expired" in msg and code in msg
    assert page.inner_text("#code") == code  # still in the old session, no blank one
    # a page whose saved code is unknown to the server (expired, or another server's)
    page.evaluate("c => localStorage.setItem('hyst-session', c)", UNKNOWN)
    page.reload()
    page.wait_for_selector("body[data-ready]")
    page.wait_for_selector("#live-note:not([hidden])")
    note = page.inner_text("#live-note")
    assert UNKNOWN in note and "new session" in note and "expired" in note
    assert page.inner_text("#code") not in (UNKNOWN, "…")
    shot(page, "web-rejoin-unknown")
    # the failed look-ups are the expected 404s; nothing else went wrong
    log["errors"] = [e for e in log["errors"] if "404" not in e]
    _clean(page, log)
    ctx.close()
