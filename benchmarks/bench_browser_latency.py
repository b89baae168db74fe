"""Slider-to-redraw latency of the web page, measured in real Chromium.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_browser_latency.py [--quick]``

The explorer (REST API + static page, viser off) runs in this process under uvicorn on
127.0.0.1; Debian's chromium is driven through playwright. The session holds a 25-operator
PI model and a 4,000-sample sine, as ``bench_app_latency.py`` uses.

For every view (loop, time, operators, inverse, digitized, closed loop) the benchmark moves
the weight slider ``p3`` ``--repeat`` times. One step is timed inside the page from the
``input`` event to the frame after the page reports the new figure drawn
(``body[data-ready]`` changes), so it includes the request, the server's simulation and
figure, JSON parsing, the redraw and one paint. Steps are sequential (each waits for its
redraw), the worst case of a slow drag. The page draws the frames of a drag with its SVG
plotter and lets plotly redraw once the slider rests; that redraw's duration (reported
by the page) is the last column. A page without that split (``--app-root`` of an older
checkout) redraws with plotly at every step.

First load: a fresh browser context (empty cache) opens ``/`` and the clock stops when the
loop plot's SVG exists; the bytes are the transfer sizes the browser reports.

Targets (issue 11): median ≤ 50 ms and p95 ≤ 100 ms per view, closed loop ≤ 150 ms,
first load ≤ 1.5 s.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import sys
import threading
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402

VIEWS = ("loop", "time", "operators", "inverse", "digitized", "closed-loop")
TARGETS = {v: (50.0, 100.0) for v in VIEWS} | {"closed-loop": (150.0, 150.0)}
N_SAMPLES, N_OPS = 4000, 25

#: The slider the steps move: weight p3, found by the label the user sees (the page's ids
#: changed when its sliders came to be built from the model's description).
P3 = "input[aria-label='p3']"

_STEP_JS = """
async ([selector, value]) => {
  const el = document.querySelector(selector);
  const v0 = document.body.dataset.ready;
  const t0 = performance.now();
  el.value = String(value);
  el.dispatchEvent(new Event("input", { bubbles: true }));
  await new Promise((resolve, reject) => {
    const t = setTimeout(() => reject(new Error("no redraw in 30 s")), 30000);
    const check = () => {
      if (document.body.dataset.ready !== v0) { clearTimeout(t); resolve(); }
      else requestAnimationFrame(check);
    };
    check();
  });
  await new Promise((r) => requestAnimationFrame(() => setTimeout(r, 0)));
  return performance.now() - t0;
}
"""

_CONFIG_JS = """
async (cfg) => {
  const code = localStorage.getItem("hyst-session");
  const r = await fetch(`/api/sessions/${code}/config`, {
    method: "PATCH", headers: { "Content-Type": "application/json" },
    body: JSON.stringify(cfg) });
  return r.status;
}
"""


def serve() -> tuple[str, Any]:
    """Start the explorer (no viser) on a free loopback port; returns (url, server)."""
    import uvicorn

    from app.server import create_app
    from app.services.settings import Settings

    app = create_app(Settings(viser_port=None, port=0))
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=0, log_level="warning"))
    th = threading.Thread(target=server.run, daemon=True)
    th.start()
    deadline = time.monotonic() + 60
    while not server.started:
        if time.monotonic() > deadline:
            raise RuntimeError("explorer did not start")
        time.sleep(0.05)
    port = server.servers[0].sockets[0].getsockname()[1]
    return f"http://127.0.0.1:{port}/", server


def first_load(browser: Any, url: str) -> tuple[float, float, int]:
    """Seconds until the first plot is drawn in a fresh context (any SVG plot: the
    page's quick plotter or plotly), until plotly's interactive plot is there, and bytes
    transferred."""
    ctx = browser.new_context(viewport={"width": 1400, "height": 860})
    page = ctx.new_page()
    t0 = time.perf_counter()
    page.goto(url)
    page.wait_for_selector("#figure svg", timeout=60_000)
    page.wait_for_selector("body[data-ready]", timeout=60_000)
    dt = time.perf_counter() - t0
    page.wait_for_selector("#figure .main-svg", timeout=60_000)
    dt_plotly = time.perf_counter() - t0
    size = page.evaluate(
        "() => performance.getEntriesByType('resource').concat("
        "performance.getEntriesByType('navigation'))"
        ".reduce((a, e) => a + (e.transferSize || e.encodedBodySize || 0), 0)")
    ctx.close()
    return dt, dt_plotly, int(size)


def pct(xs: list[float], q: float) -> float:
    """The q-quantile (0..1) of ``xs`` (nearest rank)."""
    s = sorted(xs)
    return s[min(len(s) - 1, int(round(q * (len(s) - 1))))]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=40, help="slider steps per view")
    ap.add_argument("--loads", type=int, default=3, help="first-load repetitions")
    ap.add_argument("--quick", action="store_true", help="10 steps, 1 load")
    ap.add_argument("--app-root", default=None,
                    help="serve the explorer of another checkout (e.g. an export of main, "
                         "for a before/after comparison in one session)")
    args = ap.parse_args(argv)
    if args.app_root:
        sys.path.insert(0, str(Path(args.app_root).resolve()))
    if args.quick:
        args.repeat, args.loads = 10, 1
    chromium = shutil.which("chromium") or "/usr/bin/chromium"
    from playwright.sync_api import sync_playwright

    url, server = serve()
    r = np.linspace(0.1, 3.6, N_OPS)
    model = {"type": "pi", "p0": 0.72, "thresholds": r.round(4).tolist(),
             "weights": (0.6 * np.exp(-r)).round(4).tolist()}
    cfg = {"model": model, "signal": {"kind": "sine", "amplitude": 4.0, "frequency": 1.0,
                                      "offset": 0.0, "duration": 2.0, "samples": N_SAMPLES}}
    rows = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, headless=True,
                                    args=["--no-sandbox", "--disable-gpu",
                                          "--disable-dev-shm-usage"])
        first_load(browser, url)  # server warm-up (compiled kernels, caches)
        loads = [first_load(browser, url) for _ in range(args.loads)]
        ctx = browser.new_context(viewport={"width": 1400, "height": 860})
        page = ctx.new_page()
        page.set_default_timeout(60_000)
        page.goto(url)
        page.wait_for_selector("body[data-ready]")
        assert page.evaluate(_CONFIG_JS, cfg) == 200
        page.reload()
        page.wait_for_selector(P3, state="attached")
        page.wait_for_selector("body[data-ready]")
        page.wait_for_selector("#figure .main-svg")  # time plotly's redraws
        w3 = float(page.input_value(P3))
        for view in VIEWS:
            page.click(f"#tabs button[data-fig='{view}']")
            page.wait_for_function("f => document.body.dataset.fig === f", arg=view)
            page.wait_for_timeout(300)
            times = []
            for k in range(args.repeat + 2):
                value = round(w3 + (0.01 if k % 2 == 0 else 0.0), 3)
                ms = page.evaluate(_STEP_JS, [P3, value])
                if k >= 2:  # the first two steps warm plotly's code path for this view
                    times.append(ms)
            # plotly's own redraw once the slider rests (the page reports its duration)
            settle = [float("nan")]
            split = page.evaluate("() => 'settled' in document.body.dataset")
            for k in range(3 if split else 0):
                page.evaluate(_STEP_JS, [P3, round(w3 + 0.005 * (k + 1), 3)])
                page.wait_for_function(
                    "() => document.body.dataset.settled === document.body.dataset.ready")
                settle.append(float(page.get_attribute("body", "data-plotly-ms") or "nan"))
            rows.append((view, statistics.median(times), pct(times, 0.95),
                         statistics.median(settle[1:] or settle)))
        ctx.close()
        browser.close()
    server.should_exit = True

    import app

    print(f"web page of {Path(app.__file__).resolve().parent.parent}: {N_OPS} operators, "
          f"{N_SAMPLES} samples, {args.repeat} steps per view")
    print(f"{'view':<12} {'median ms':>10} {'p95 ms':>8}  target (median/p95)       "
          "plotly redraw at rest")
    for view, med, p95, settle in rows:
        tm, tp = TARGETS[view]
        ok = "ok" if med <= tm and p95 <= tp else "MISSED"
        print(f"{view:<12} {med:10.1f} {p95:8.1f}  ≤ {tm:.0f} / {tp:.0f} ms  {ok:<8}"
              f"{settle:8.1f} ms")
    secs = [s for s, _, _ in loads]
    secs_plotly = [s for _, s, _ in loads]
    print(f"first load   {statistics.median(secs):10.2f} s  to the first plot "
          f"(target ≤ 1.5 s); {statistics.median(secs_plotly):.2f} s to plotly's "
          f"interactive plot; {loads[0][2] / 1e6:.2f} MB transferred")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
