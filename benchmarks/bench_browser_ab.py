"""Paired A/B slider-to-redraw latency of two explorer checkouts, in one real Chromium.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_browser_ab.py A_ROOT B_ROOT
[--views loop,operators] [--repeat 80]``

``bench_browser_latency.py --app-root`` measures one checkout after the other; on a shared
machine the load changes between the two runs by more than the difference sought. Here
both explorers run at once (``python -m app serve --no-viser`` in each root, on free
loopback ports, with throw-away state directories), one page each in one browser, and
every slider step of one page is followed by the same step of the other (the order
alternates), so both see the same load. The step, the session (25 operators, 4,000
samples) and the timing are those of ``bench_browser_latency.py``.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

_BB = Path(__file__).resolve().parent / "bench_browser_latency.py"


def _latency_module() -> Any:
    spec = importlib.util.spec_from_file_location("bench_browser_latency", _BB)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def start(root: str, state: str) -> tuple[subprocess.Popen, str]:
    """Serve the explorer of checkout ``root`` on a free loopback port; (process, url)."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "serve", "--no-browser", "--no-viser", "--port", "0",
         "--state-dir", state], cwd=root, env=env, stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    for line in proc.stdout:
        m = re.search(r"(http://127\.0\.0\.1:\d+/)", line)
        if m:
            return proc, m.group(1)
    raise RuntimeError(f"the explorer of {root} did not start")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("a_root", help="checkout A (e.g. the main branch)")
    ap.add_argument("b_root", help="checkout B (e.g. this branch)")
    ap.add_argument("--views", default="loop,operators",
                    help="comma-separated views (default loop,operators)")
    ap.add_argument("--repeat", type=int, default=80, help="slider steps per view and page")
    args = ap.parse_args(argv)
    bb = _latency_module()
    views = [v for v in args.views.split(",") if v]
    unknown = [v for v in views if v not in bb.VIEWS]
    if unknown:
        ap.error(f"unknown view(s) {unknown}; known: {', '.join(bb.VIEWS)}")
    from playwright.sync_api import sync_playwright

    r = np.linspace(0.1, 3.6, bb.N_OPS)
    cfg = {"model": {"type": "pi", "p0": 0.72, "thresholds": r.round(4).tolist(),
                     "weights": (0.6 * np.exp(-r)).round(4).tolist()},
           "signal": {"kind": "sine", "amplitude": 4.0, "frequency": 1.0, "offset": 0.0,
                      "duration": 2.0, "samples": bb.N_SAMPLES}}
    tmp = tempfile.mkdtemp(prefix="hyst-ab-")
    procs = [start(root, os.path.join(tmp, str(i)))
             for i, root in enumerate((args.a_root, args.b_root))]
    times: dict[str, tuple[list[float], list[float]]] = {}
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(
                executable_path=shutil.which("chromium") or "/usr/bin/chromium", headless=True,
                args=["--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"])
            pages = []
            for _, url in procs:
                page = browser.new_context(viewport={"width": 1400, "height": 860}).new_page()
                page.set_default_timeout(60_000)
                page.goto(url)
                page.wait_for_selector("body[data-ready]")
                assert page.evaluate(bb._CONFIG_JS, cfg) == 200
                page.reload()
                page.wait_for_selector(bb.P3, state="attached")
                page.wait_for_selector("body[data-ready]")
                page.wait_for_selector("#figure .main-svg")
                pages.append(page)
            w3 = float(pages[0].input_value(bb.P3))
            for view in views:
                for page in pages:
                    page.click(f"#tabs button[data-fig='{view}']")
                    page.wait_for_function("f => document.body.dataset.fig === f", arg=view)
                    page.wait_for_timeout(300)
                got: tuple[list[float], list[float]] = ([], [])
                for k in range(args.repeat + 2):
                    value = round(w3 + (0.01 if k % 2 == 0 else 0.0), 3)
                    for i in ((0, 1) if k % 2 == 0 else (1, 0)):
                        ms = pages[i].evaluate(bb._STEP_JS, [bb.P3, value])
                        if k >= 2:  # the first two steps warm plotly's path for this view
                            got[i].append(ms)
                times[view] = got
            browser.close()
    finally:
        for proc, _ in procs:
            proc.terminate()
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"paired A/B: {bb.N_OPS} operators, {bb.N_SAMPLES} samples, {args.repeat} steps "
          "per view and page, steps interleaved")
    print(f"A = {args.a_root}\nB = {args.b_root}")
    print(f"{'view':<12} {'A median':>9} {'A p95':>7} {'B median':>9} {'B p95':>7}  B / A")
    for view, (a, b) in times.items():
        ma, mb = statistics.median(a), statistics.median(b)
        print(f"{view:<12} {ma:9.1f} {bb.pct(a, 0.95):7.1f} {mb:9.1f} {bb.pct(b, 0.95):7.1f}"
              f"  {mb / ma:5.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
