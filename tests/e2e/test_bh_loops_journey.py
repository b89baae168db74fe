"""A new engineer's B-H loops in real Chromium: the shipped MnZn ferrite file (four closed
loops of rising amplitude in a ``loop`` column, no time axis) is uploaded with every loop
kept as its own recording, fitted with the automatic model choice and the operator count
left to cross-validation, and exported as JSON and C.

The page says which model was chosen and that it was chosen automatically, gives the held-out
error ``hyst fit`` gives on the same file (the core's fit of the file as the command line reads
it, computed here), says in words that each loop starts from the memory its own cycle leaves,
words every warning without a name of the code (``app.services.words.internal_names``) or a
command-line option, and never invents a time axis (no seconds or speeds: the file has
none). The exported JSON holds the fitted model; the C code compiles where gcc is installed.
The diagnosis of the same loops names saturation and says where it acts in sample numbers.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

from .test_web_journeys import _clean, _open, _upload
from .test_words import PAGE_TEXT, _leaks

ROOT = Path(__file__).resolve().parents[2]
BH = ROOT / "examples" / "data" / "bh_loops" / "MnZn_HP_ferrite.csv"


def _cli_fit() -> Any:
    """The fit ``hyst fit FILE`` makes (its defaults: every run of the file a recording,
    ``--model auto``, n by cross-validation), through the core's reader and entry point."""
    from core.csvio import read_csv
    from core.fitting import fit_recordings

    return fit_recordings(read_csv(BH), "auto")


def test_bh_loops_fit_automatically_and_export(browser: Any, live_server: dict, tmp_path: Path,
                                               shot: Any) -> None:
    cli = _cli_fit()
    assert cli.report.test is not None
    ctx, page, log = _open(browser, live_server["url"], width=1400, height=1000)
    try:
        _upload(page, BH, "516")  # every loop, each its own, as the command line reads it
        assert page.is_visible("#run-pick")
        options = page.locator("#run-pick option").all_inner_texts()
        each = [o for o in options if "each its own loop" in o]
        assert len(each) == 1, options
        assert page.input_value("#run-pick") == "each"  # the picker shows what was kept
        page.select_option("#fit-kind", "auto")
        page.fill("#fit-n", "")  # the operator count chosen by cross-validation
        page.click("#fit")
        page.wait_for_selector("#report .msg.ok", timeout=60_000)
        page.wait_for_function("() => document.body.dataset.fig === 'fit'")
        report = page.inner_text("#report")
        shot(page, "bh-loops-fit")

        # the chosen model in words, and that it was chosen
        from app.services.words import type_words
        first = page.inner_text("#report .msg.ok")
        assert type_words(cli.kind) in first and "chosen automatically" in first, first
        # the held-out error of hyst fit on the same file, within rounding
        pct = re.search(r"Held-out error[^:]*: RMS [\d.e+-]+ T, ([\d.]+) % of the range", first)
        assert pct, first
        assert abs(float(pct.group(1)) - cli.report.test.rmse_pct) <= 0.006 * max(
            1.0, cli.report.test.rmse_pct), (pct.group(1), cli.report.test.rmse_pct)
        # each loop starts in periodic steady state, said in words
        assert "periodic steady state" in report and "memory its own cycle leaves" in report
        # no name of the code, no command-line option, no time the file does not hold
        text = page.evaluate(PAGE_TEXT)
        assert _leaks(text) == [], _leaks(text)
        for word in ("--model", "--train", "hyst diagnose", " s of ", "/s,", "A/m/s"):
            assert word not in report, (word, report)
        page.click("#report summary")  # how the model was chosen: the candidates in words
        choice = page.inner_text("#report details")
        assert "cross-validated" in choice and _leaks(choice) == [], choice
        page.locator("#report").scroll_into_view_if_needed()
        shot(page, "bh-loops-report")

        # the exports of that fit, from the browser
        saved: dict[str, Path] = {}
        for link in ("#dl-json", "#dl-c"):
            with page.expect_download() as dl:
                page.click(link)
            path = tmp_path / dl.value.suggested_filename
            dl.value.save_as(path)
            saved[link] = path
        doc = json.loads(saved["#dl-json"].read_text())
        assert type_words(cli.kind).split()[0].lower() in json.dumps(doc).lower() or \
            cli.kind in json.dumps(doc), str(doc)[:300]
        c_code = saved["#dl-c"]
        assert c_code.stat().st_size > 200
        if shutil.which("gcc") and c_code.suffix == ".c":
            r = subprocess.run(["gcc", "-std=c99", "-fsyntax-only", str(c_code)],
                               capture_output=True, text=True, timeout=60)
            assert r.returncode == 0, r.stderr[:2000]

        # the diagnosis of the same loops: saturation named (the Menegotto-Pinto bank is
        # not taken where the PI with a tanh envelope predicts the loops far better), and
        # where it acts said in sample numbers of a named loop, never in seconds
        page.click("#diagnose")
        page.wait_for_selector("#diagnosis", timeout=180_000)
        page.wait_for_function("() => /saturat/i.test("
                               "document.getElementById('diagnosis').innerText)",
                               timeout=180_000)
        diag = page.inner_text("#diagnosis")
        assert "samples" in diag and not re.search(r"\d s\b", diag), diag
        assert "--" not in diag, diag  # no command-line option in the browser
        # the residuals' axis: sample numbers, not a time in seconds
        titles = page.evaluate("() => [...document.querySelectorAll('#figure .g-x2title')]"
                               ".map(e => e.textContent)")
        assert any("sample number" in t for t in titles), titles
        assert not any("[s]" in t for t in titles), titles
        assert _leaks(diag) == [], _leaks(diag)
        page.locator("#diagnosis").scroll_into_view_if_needed()
        shot(page, "bh-loops-diagnosis")
        _clean(page, log)
    finally:
        ctx.close()
