"""What each piece of a lesson move costs one viser tab's browser, in CPU.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_viser_move.py [--repeats 8]``

The explorer serves in this process; one viser tab (1200x800) in Debian's ``chromium``
(playwright). After the tab's start-up, each piece of a *PI basics* move is sent to it
alone, in turn, three times in a row, and repeated: the step's plot (the figures of steps
2, 3 and 5, as the tab was sent them; also with half and a quarter of their points, and
without the legend), the "Lesson"
toast (removed and shown again, as main did, and changed in place, :mod:`app.gui.toasts`),
the *View* dropdown, the Lesson text, the status line, and nothing; the plot cut to the
samples its pixels draw (:meth:`app.gui.controller.SessionView._cut`, as the tab now gets
it); and whole lesson moves of the class (steps 1, 2, 3 and 5 in turn) as main sent them
(every sample, message by message), with the cut only, with the one batch only, and with
both. ``--react N`` also times ``Plotly.react`` alone in the tab, every sample against
cut. ``--only "plot;lesson move"`` runs some of the pieces. For each, the tab's
renderer main-thread CPU over the next ``--gap`` seconds (CDP ``Performance.getMetrics``
``TaskDuration``, thread time; "nothing" is the tab idle over as long). CPU time, not wall
time: the pieces compare at any load of the machine (issue 33: 31 renderers on 2 cores).
"""

from __future__ import annotations

import argparse
import base64
import copy
import json
import os
import shutil
import statistics
import struct
import sys
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))


def _every(fig: dict[str, Any], stride: int) -> dict[str, Any]:
    """``fig`` with every ``stride``-th point of its traces' typed arrays."""
    fig = copy.deepcopy(fig)
    for t in fig["data"]:
        for a in ("x", "y"):
            v = t.get(a)
            if isinstance(v, dict) and v.get("dtype") == "f4":
                raw = base64.b64decode(v["bdata"])
                xs = struct.unpack(f"<{len(raw) // 4}f", raw)[::stride]
                v["bdata"] = base64.b64encode(struct.pack(f"<{len(xs)}f", *xs)).decode()
    return fig


def _captured(view: Any, reg: Any) -> tuple[list[dict[str, Any]], list[str]]:
    """The plots of *PI basics* steps 2, 3 and 5 and the Lesson texts of steps 1-5, as
    ``view``'s tab was sent them."""
    from app.services.teaching import lessons

    lesson = lessons.builtin_lesson("pi-basics")
    figs: list[dict[str, Any]] = []
    texts: list[str] = []
    view.pixel_cut = False  # every sample, as main sent them ("plot, cut to pixels": cut)
    for k in range(5):
        if k == 0:
            lessons.start(reg, lesson)
        else:
            lessons.go_to(reg, move=1)
        time.sleep(0.5)
        assert view.worker.wait_idle(30)
        texts.append(str(view.lesson.md.content))
        if k in (1, 2, 4):
            figs.append({**json.loads(view.ui.plot._plotly_json_str),
                         "aspect": view.ui.plot.aspect})
    view.pixel_cut = True
    return figs, texts


def _pieces(view: Any, client: Any, figs: list[dict[str, Any]], texts: list[str]
            ) -> dict[str, Any]:
    """name -> ``send(k)`` (``None``: nothing sent)."""
    from app.gui.toasts import Toasts
    from app.services.explore.figures import FigureJSON

    shown: dict[str, Any] = {}

    def toast_main(k: int) -> None:  # main 64c07be's notify: removed, shown again
        old = shown.pop("Lesson", None)
        if old is not None:
            old.remove()
        shown["Lesson"] = client.add_notification(
            "Lesson", f"the class is at step {k % 6 + 1} of 6", auto_close_seconds=6.0)

    toasts = Toasts(client.add_notification)

    def plot(fs: list[dict[str, Any]]) -> Any:
        def send(k: int) -> None:
            f = fs[k % len(fs)]
            view.ui.plot.aspect = f["aspect"]
            view.ui.plot.figure = FigureJSON(f["data"], f["layout"])
        return send

    def dropdown(k: int) -> None:
        dd = view.ui.view_dd
        dd.value = list(dd.options)[k % 3]

    def status(k: int) -> None:
        view.ui.status_md.content = f"v{k} · 670 samples · {k % 10}.1 ms"

    def lesson_text(k: int) -> None:
        view.lesson.md.content = texts[k % len(texts)]

    # as this tab's render cuts them (its plot's aspect, the Expand window's width)
    cut = [{**view._cut(FigureJSON(f["data"], f["layout"]), f["aspect"]).to_dict(),
            "aspect": f["aspect"]} for f in figs]
    from contextlib import nullcontext

    from app.services.teaching import lessons

    atomic = view._atomic

    def lesson_move(cut: bool, batch: bool) -> Any:
        def send(k: int) -> None:  # the class moves between steps 1, 2, 3 and 5
            view.pixel_cut = cut
            view._atomic = atomic if batch else nullcontext
            lessons.go_to(view.registry, step=(1, 2, 3, 5)[k % 4])
        return send

    no_legend = copy.deepcopy(figs)
    for f in no_legend:
        f["layout"]["showlegend"] = False
    return {
        "nothing": None,
        "plot": plot(figs),
        "plot, half the points": plot([_every(f, 2) for f in figs]),
        "plot, a quarter": plot([_every(f, 4) for f in figs]),
        "plot, no legend": plot(no_legend),
        "plot, cut to pixels": plot(cut),
        "toast removed, shown": toast_main,
        "toast changed in place": lambda k: toasts(
            "Lesson ", f"the class is at step {k % 6 + 1} of 6", False),
        "View dropdown": dropdown,
        "Lesson text": lesson_text,
        "status line": status,
        "lesson move, as main": lesson_move(False, False),
        "lesson move, cut only": lesson_move(True, False),
        "lesson move, batch only": lesson_move(False, True),
        "lesson move": lesson_move(True, True),
    }


def _reacts(page: Any, cpu_ms: Any, view: Any, n: int) -> dict[str, float]:
    """The tab's CPU per ``Plotly.react`` of the captured step plots (parsed from their
    JSON each call, as viser's plot component does), every sample against cut to pixels,
    taking turns, ``n`` calls of each."""
    from app.services.explore.figures import FigureJSON

    figs = view._bench_figs
    sets = {"every sample": [json.dumps(f) for f in figs],
            "cut to pixels": [json.dumps({**view._cut(FigureJSON(f["data"], f["layout"]),
                                                      f["aspect"]).to_dict(),
                                          "aspect": f["aspect"]}) for f in figs]}
    js = """async ([strs, n]) => {
      const d = document.querySelector('.js-plotly-plot');
      const w = d._fullLayout.width;
      for (let i = 0; i < n; i++) {
        const f = JSON.parse(strs[i % strs.length]);
        await Plotly.react(d, f.data, {...f.layout, uirevision: 'true', width: w,
                                       height: w * f.aspect});
      }
    }"""
    got: dict[str, list[float]] = {k: [] for k in sets}
    for _ in range(max(1, n // 6)):
        for name, strs in sets.items():
            t0 = cpu_ms()
            page.evaluate(js, [strs, 6])
            got[name].append((cpu_ms() - t0) / 6)
    return {k: statistics.median(v) for k, v in got.items()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=4)
    ap.add_argument("--gap", type=float, default=1.5, help="seconds measured after a piece")
    ap.add_argument("--only", default="", help="pieces to run, separated by ; (default: all)")
    ap.add_argument("--react", type=int, default=0,
                    help="also time N Plotly.react calls in the tab for the step plots, every "
                         "sample against cut to pixels (CPU per call, nothing else running)")
    args = ap.parse_args()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("chromium not installed (Debian's chromium package)")
        return 0
    from bench_class import _serve
    from playwright.sync_api import sync_playwright

    from app.services.settings import Settings
    from app.services.teaching import lessons
    from tests.e2e.conftest import ARGS
    from tests.e2e.test_viser_gui import _open

    app, server, _ = _serve(Settings(viser_port=0, port=0))
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=ARGS, headless=True)
        ctx, page, _ = _open(browser, f"http://127.0.0.1:{app.state.viser_port}/", 1200, 800)
        cdp = ctx.new_cdp_session(page)
        cdp.send("Performance.enable", {"timeDomain": "threadTicks"})

        def cpu_ms() -> float:
            return 1e3 * next(m["value"] for m in cdp.send("Performance.getMetrics")["metrics"]
                              if m["name"] == "TaskDuration")

        view = next(iter(app.state.gui.views.values()))
        client = next(iter(app.state.gui.server.get_clients().values()))
        reg = app.state.registry
        figs, texts = _captured(view, reg)
        view._bench_figs = figs
        pieces = _pieces(view, client, figs, texts)
        if args.only:
            pieces = {k: v for k, v in pieces.items()
                      if k in args.only.split(";") or k == "nothing"}
        time.sleep(15)  # the fresh tab's start-up work is over
        got: dict[str, list[float]] = {name: [] for name in pieces}
        k = 0
        for _ in range(args.repeats):
            for name, send in pieces.items():
                for _ in range(3):  # three moves in a row (a toast changed twice of three)
                    k += 1
                    t0 = cpu_ms()
                    if send is not None:
                        with view._quiet():
                            send(k)
                    time.sleep(args.gap)
                    got[name].append(cpu_ms() - t0)
        reacts = _reacts(page, cpu_ms, view, args.react) if args.react else {}
        lessons.end(reg)
        browser.close()
    server.should_exit = True
    load = os.getloadavg()[0]
    print(f"one viser tab, its renderer's CPU over {args.gap} s after each piece "
          f"({args.repeats} x 3 repeats; load average {load:.1f}):")
    for name, xs in got.items():
        print(f"  {name:<24} median {statistics.median(xs):6.1f} ms   "
              f"min {min(xs):6.1f}   max {max(xs):6.1f}")
    for name, ms in reacts.items():
        print(f"  Plotly.react alone, {name:<22} {ms:6.1f} ms per call")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
