"""Slider-to-plot server latency of the explorer (simulate + figure build + JSON).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_app_latency.py [--quick]``

A dragged slider sends about 20 updates/s; each one makes the server (a) simulate the
session's model on its input (4,000 samples, 25 play operators), (b) build the figure that
is on show and (c) serialise it to the JSON that viser or the REST API sends. The target
is ≤ 30 ms per update. Every iteration changes one weight, as a drag does.

Cases, median and 95th percentile of ``--repeat`` iterations, taken round-robin:

* ``loop view``: :func:`app.services.explore.simulation.compute` + the loop figure + ``to_json``
  (what one slider step costs in the GUI and in ``GET /api/sessions/{code}/figures``).
* ``every view``: the same with the six interactive figures (time, loop, operators,
  loading, inverse, digitized) built and serialised.
* ``closed-loop view``: the closed-loop figure alone (three runs of paper 001's loop at
  50 kHz over 2 s, 100,000 samples each); built only while that view is on show.
* ``viser GUI step``: a headless :class:`app.gui.controller.SessionView` on a real
  ``ViserServer``: assigning a weight slider's value (what a browser message does) until
  the render worker has sent the new loop figure (callback, validation, session update,
  simulate, inverse, digitized view, figure, JSON, websocket queue).
* ``REST round trip``: ``PATCH .../config`` + ``GET .../figures?name=loop`` through
  FastAPI's TestClient (validation, routing, JSON response), in process.
* baseline ``go.Figure``: the loop view built as a validated ``plotly.graph_objects``
  figure with plain float lists and ``fig.to_json()``, the obvious implementation;
  the ratio shows what the typed-array builders save.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402

from app.services.explore import figures as F
from app.services.explore.config import Config, SignalSpec  # noqa: E402
from app.services.explore.simulation import compute  # noqa: E402

N_SAMPLES, N_OPS = 4000, 25


def base_config() -> Config:
    """25 operators, 4,000 samples of a 4 sin 2πt input (paper 001 Example 1's input)."""
    r = np.linspace(0.1, 3.6, N_OPS)
    w = 0.6 * np.exp(-r)
    model = {"type": "pi", "p0": 0.72, "thresholds": r.tolist(), "weights": w.tolist()}
    return Config(model=model, signal=SignalSpec(samples=N_SAMPLES))


def drag(cfg: Config, k: int) -> Config:
    """The config after the k-th slider step (weight 3 moves)."""
    m = dict(cfg.model)
    w = list(m["weights"])
    w[3] = 0.2 + 0.01 * (k % 50)
    m["weights"] = w
    return replace(cfg, model=m)


def loop_view(cfg: Config) -> int:
    res = compute(cfg, views=("loop",))
    return len(F.loop_figure(res).to_json())


def every_view(cfg: Config) -> int:
    views = [n for n in F.FIGURES if n != "closed-loop"]
    res = compute(cfg, views=views)
    return sum(len(F.build(n, res).to_json()) for n in views)


def closed_loop_view(cfg: Config) -> int:
    res = compute(cfg, views=("closed-loop",))
    return len(F.closed_loop_figure(res).to_json())


def baseline_go(cfg: Config) -> int:
    import plotly.graph_objects as go

    res = compute(cfg, views=("loop",))
    m = res.model
    r = np.linspace(-4, 4, 201)
    fig = go.Figure(
        [go.Scatter(x=res.u.tolist(), y=res.y.tolist(), mode="lines", name="loop"),
         go.Scatter(x=r.tolist(), y=m.loading_curve(r).tolist(), mode="lines")],
        layout={"title": {"text": "Hysteresis loop"}},
    )
    return len(fig.to_json())


def make_rest():  # noqa: ANN201 - returns a closure
    from fastapi.testclient import TestClient

    from app.server import create_app
    from app.services.settings import Settings

    client = TestClient(create_app(Settings(viser_port=None)))
    client.__enter__()
    code = client.post("/api/sessions").json()["code"]
    cfg = base_config()
    client.patch(f"/api/sessions/{code}/config", json={"model": cfg.model,
                                                       "signal": cfg.signal.__dict__})

    def rest(c: Config) -> int:
        r1 = client.patch(f"/api/sessions/{code}/config", json={"model": c.model})
        r2 = client.get(f"/api/sessions/{code}/figures", params={"name": "loop"})
        assert r1.status_code == 200 and r2.status_code == 200, (r1.text, r2.text)
        return len(r2.content)

    return rest, client


def make_gui():  # noqa: ANN201 - returns a closure
    import viser

    from app.gui.controller import SessionView
    from app.services.session.sessions import SessionRegistry
    from app.services.settings import Settings

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    reg = SessionRegistry()
    view = SessionView(server.gui, reg, reg.create(base_config()), Settings())
    view.worker.wait_idle(60)

    def gui(c: Config) -> int:
        view.ui.param_sliders["weights[3]"].value = c.model["weights"][3]
        view.worker.wait_idle(60)
        assert view.rendered_version == view.session.version
        return len(view.ui.plot.figure.to_json())

    def close() -> None:
        view.close()
        server.stop()

    return gui, close


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=100)
    ap.add_argument("--quick", action="store_true", help="30 iterations")
    args = ap.parse_args(argv)
    reps = 30 if args.quick else args.repeat
    cfg = base_config()
    rest, client = make_rest()
    gui, close_gui = make_gui()
    cases = {"loop view": loop_view, "every view": every_view,
             "closed-loop view": closed_loop_view, "viser GUI step": gui,
             "REST round trip": rest, "baseline go.Figure": baseline_go}
    for fn in cases.values():  # warm-up: numba kernels, imports
        fn(drag(cfg, 0))
    times: dict[str, list[float]] = {k: [] for k in cases}
    sizes: dict[str, int] = {}
    for k in range(reps):
        c = drag(cfg, k + 1)
        for name, fn in cases.items():
            t0 = time.perf_counter()
            sizes[name] = fn(c)
            times[name].append(1e3 * (time.perf_counter() - t0))
    client.__exit__(None, None, None)
    close_gui()
    base = statistics.median(times["baseline go.Figure"])
    print(f"explorer latency, N = {N_SAMPLES} samples, n = {N_OPS} operators, {reps} steps")
    print(f"{'case':<22}{'median ms':>10}{'p95 ms':>9}{'JSON kB':>9}{'vs baseline':>13}")
    for name, ts in times.items():
        med = statistics.median(ts)
        p95 = float(np.percentile(ts, 95))
        print(f"{name:<22}{med:>10.2f}{p95:>9.2f}{sizes[name] / 1e3:>9.1f}{base / med:>12.1f}x")
    for case in ("loop view", "viser GUI step"):
        target = statistics.median(times[case])
        print(f"target: slider step ({case}) <= 30 ms: {'met' if target <= 30 else 'MISSED'} "
              f"({target:.2f} ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
