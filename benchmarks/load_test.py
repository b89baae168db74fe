"""Load test: simulated students changing parameters against a local explorer.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/load_test.py [--clients 30]
[--duration 60] [--url http://127.0.0.1:PORT]``

Without ``--url`` the script starts ``python -m app serve --no-viser --no-browser`` on a free
loopback port in a subprocess (so the clients and the server do not share a GIL) and stops
it at the end. Each client opens its own session, then repeats one "slider step" until the
duration is over: ``PATCH /api/sessions/{code}/config`` with a new weight and ``p0`` and
``GET /api/sessions/{code}/figures?name=loop`` (the figure the page redraws), with a
50 ms pause between steps like a browser's throttled slider. It reports the step latency
(p50, p95, max), the throughput and the number of errors (any non-2xx status, timeout or
connection error); zero errors is the bar. Only loopback addresses are accepted.
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import random
import socket
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from urllib.parse import urlparse

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
MAX_STEPS_PER_CLIENT = 100_000  # hard bound on every loop


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def start_server() -> tuple[subprocess.Popen, str]:
    """Start the explorer on a free loopback port; returns the process and its URL."""
    port = free_port()
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "serve", "--no-viser", "--no-browser", "--port", str(port)],
        cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"server exited: {proc.stderr.read().decode()[-2000:]}")
        try:
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=2)
            c.request("GET", "/api/health")
            if c.getresponse().status == 200:
                return proc, url
        except OSError:
            time.sleep(0.2)
    proc.terminate()
    raise RuntimeError("server did not start within 60 s")


class Client(threading.Thread):
    """One simulated student (own session, own keep-alive connection)."""

    def __init__(self, host: str, port: int, deadline: float, seed: int, pause: float) -> None:
        super().__init__(daemon=True)
        self.host, self.port, self.deadline, self.pause = host, port, deadline, pause
        self.rng = random.Random(seed)
        self.latencies: list[float] = []
        self.errors: list[str] = []

    def _req(self, conn: http.client.HTTPConnection, method: str, path: str,
             body: dict | None = None) -> bytes:
        data = None if body is None else json.dumps(body).encode()
        headers = {"Content-Type": "application/json"} if data else {}
        conn.request(method, path, body=data, headers=headers)
        r = conn.getresponse()
        payload = r.read()
        if not 200 <= r.status < 300:
            raise RuntimeError(f"{method} {path}: {r.status} {payload[:200]!r}")
        return payload

    def run(self) -> None:
        conn = http.client.HTTPConnection(self.host, self.port, timeout=30)
        try:
            code = json.loads(self._req(conn, "POST", "/api/sessions"))["code"]
            base = json.loads(self._req(conn, "GET", f"/api/sessions/{code}"))["config"]["model"]
        except Exception as exc:  # noqa: BLE001 - counted, reported
            self.errors.append(f"setup: {exc}")
            return
        for _ in range(MAX_STEPS_PER_CLIENT):
            if time.monotonic() >= self.deadline:
                break
            model = dict(base)
            model["p0"] = round(0.5 + self.rng.random(), 4)
            w = list(model["weights"])
            w[self.rng.randrange(len(w))] = round(self.rng.random(), 4)
            model["weights"] = w
            t0 = time.perf_counter()
            try:
                self._req(conn, "PATCH", f"/api/sessions/{code}/config", {"model": model})
                self._req(conn, "GET", f"/api/sessions/{code}/figures?name=loop")
            except Exception as exc:  # noqa: BLE001 - counted, reported
                self.errors.append(str(exc))
                conn.close()
                conn = http.client.HTTPConnection(self.host, self.port, timeout=30)
                continue
            self.latencies.append(1e3 * (time.perf_counter() - t0))
            time.sleep(self.pause)
        conn.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clients", type=int, default=30)
    ap.add_argument("--duration", type=float, default=60.0, help="seconds")
    ap.add_argument("--pause", type=float, default=0.05, help="seconds between a client's steps")
    ap.add_argument("--url", default=None, help="a running explorer (loopback only)")
    args = ap.parse_args(argv)
    if not 1 <= args.clients <= 500 or not 0 < args.duration <= 3600:
        ap.error("--clients must be 1..500 and --duration 0..3600 s")
    proc = None
    url = args.url
    if url is None:
        proc, url = start_server()
    parsed = urlparse(url)
    if parsed.hostname not in ("127.0.0.1", "localhost", "::1"):
        ap.error("the load test only targets loopback addresses")
    try:
        deadline = time.monotonic() + args.duration
        clients = [Client(parsed.hostname, parsed.port or 80, deadline, i, args.pause)
                   for i in range(args.clients)]
        t0 = time.monotonic()
        for c in clients:
            c.start()
        for c in clients:
            c.join(timeout=args.duration + 120)
        wall = time.monotonic() - t0
    finally:
        if proc is not None:
            proc.terminate()
            proc.wait(timeout=10)
    lat = [x for c in clients for x in c.latencies]
    errors = [e for c in clients for e in c.errors]
    print(f"load test: {args.clients} clients, {args.duration:g} s, {url}")
    if lat:
        print(f"steps: {len(lat)} ({len(lat) / wall:.1f}/s)  latency ms: "
              f"p50 {statistics.median(lat):.1f}  p95 {np.percentile(lat, 95):.1f}  "
              f"max {max(lat):.1f}")
    print(f"errors: {len(errors)}")
    for e in errors[:5]:
        print(f"  {e}")
    return 1 if errors or not lat else 0


if __name__ == "__main__":
    sys.exit(main())
