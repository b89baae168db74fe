"""Load and fault test: a class of simulated students against a local explorer.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/load_test.py [--students 100]
[--duration 60] [--think 1.0] [--fault] [--url http://127.0.0.1:PORT]``

Without ``--url`` the script starts ``python -m app serve --no-viser --no-browser`` on a free
loopback port with a fresh ``--state-dir`` in a subprocess (clients and server do not share
a GIL) and stops it at the end. Each student opens its own session, then repeats one
"slider step" (``PATCH /api/sessions/{code}/config`` with a new weight and ``p0``, then
``GET /api/sessions/{code}/figures?name=loop``, the figure the page redraws), with every
10th step also rejoining by code (``PUT /api/sessions/{code}``) and a stateless
``POST /api/simulate``; between steps it thinks for a random 0.2..1.8 x ``--think``
seconds. Reported: step latency (p50, p95, p99, max), throughput, errors (any non-2xx,
timeout or connection error; the bar is 0) and the p95 bar of 150 ms.

``--fault``: at half time the server is killed with SIGKILL and restarted on the same port
and state directory; students retry until it is back (those failures are counted apart, as
downtime). At the end every session is read back: a session is **lost** when it is gone or
its model is neither the last one the server acknowledged nor the one in flight at the kill.
Only loopback addresses are accepted; every loop is bounded in count and time.
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import random
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from urllib.parse import urlparse

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
MAX_STEPS_PER_CLIENT = 100_000  # hard bound on every loop
P95_BAR_MS = 150.0


def free_port(lo: int = 8100, hi: int = 8199) -> int:
    """A free loopback port in ``lo..hi`` (the range set aside for these tests)."""
    for port in range(lo, hi + 1):
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
            return port
    raise RuntimeError(f"no free port in {lo}..{hi}")


def start_server(port: int, state_dir: str, root: Path = ROOT) -> subprocess.Popen:
    """Start the explorer of the checkout ``root`` on ``port`` (loopback) with
    ``state_dir``; wait until it answers."""
    path = os.pathsep.join(p for p in (str(root), os.environ.get("PYTHONPATH")) if p)
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": path}
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "serve", "--no-viser", "--no-browser", "--port",
         str(port), "--state-dir", state_dir],
        cwd=root, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"server exited: {proc.stderr.read().decode()[-2000:]}")
        try:
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=2)
            c.request("GET", "/api/health")
            if c.getresponse().status == 200:
                return proc
        except OSError:
            time.sleep(0.1)
    proc.terminate()
    raise RuntimeError("server did not start within 60 s")


class Down(Exception):  # noqa: N818
    """The server is not reachable (connection refused or reset)."""


class Student(threading.Thread):
    """One simulated student (own session, own keep-alive connection)."""

    def __init__(self, host: str, port: int, deadline: float, seed: int, think: float,
                 outage: threading.Event) -> None:
        super().__init__(daemon=True)
        self.host, self.port, self.deadline, self.think = host, port, deadline, think
        self.outage = outage
        self.rng = random.Random(seed)
        self.latencies: list[float] = []
        self.by_kind: dict[str, list[float]] = {}
        self.errors: list[str] = []
        self.downtime_errors = 0
        self.code: str | None = None
        self.acked: float | None = None  # p0 of the last acknowledged PATCH
        self.in_flight: float | None = None

    def _conn(self) -> http.client.HTTPConnection:
        return http.client.HTTPConnection(self.host, self.port, timeout=30)

    def _req(self, conn: http.client.HTTPConnection, method: str, path: str,
             body: dict | None = None) -> bytes:
        data = None if body is None else json.dumps(body).encode()
        headers = {"Content-Type": "application/json"} if data else {}
        t0 = time.perf_counter()
        try:
            conn.request(method, path, body=data, headers=headers)
            r = conn.getresponse()
            payload = r.read()
            kind = f"{method} {path.split('?')[0].rsplit('/', 1)[-1]}"
            self.by_kind.setdefault(kind, []).append(1e3 * (time.perf_counter() - t0))
        except (ConnectionError, http.client.RemoteDisconnected, OSError) as exc:
            raise Down(f"{method} {path}: {exc}") from None
        if not 200 <= r.status < 300:
            raise RuntimeError(f"{method} {path}: {r.status} {payload[:200]!r}")
        return payload

    def run(self) -> None:
        conn = self._conn()
        try:
            self.code = json.loads(self._req(conn, "POST", "/api/sessions"))["code"]
            code = self.code
            base = json.loads(self._req(conn, "GET", f"/api/sessions/{code}"))["config"]["model"]
        except Exception as exc:  # noqa: BLE001 - counted, reported
            self.errors.append(f"setup: {exc}")
            return
        for step in range(MAX_STEPS_PER_CLIENT):
            if time.monotonic() >= self.deadline:
                break
            model = dict(base)
            model["p0"] = round(0.5 + self.rng.random(), 6)
            w = list(model["weights"])
            w[self.rng.randrange(len(w))] = round(self.rng.random(), 4)
            model["weights"] = w
            t0 = time.perf_counter()
            try:
                self.in_flight = model["p0"]
                self._req(conn, "PATCH", f"/api/sessions/{code}/config", {"model": model})
                self.acked, self.in_flight = model["p0"], None
                self._req(conn, "GET", f"/api/sessions/{code}/figures?name=loop")
                if step % 10 == 9:
                    self._req(conn, "PUT", f"/api/sessions/{code}")
                    self._req(conn, "POST", "/api/simulate",
                              {"model": model, "figures": ["time"]})
            except Down as exc:
                conn.close()
                conn = self._conn()
                if self.outage.is_set():
                    self.downtime_errors += 1
                    time.sleep(0.1)
                else:
                    self.errors.append(str(exc))
                continue
            except Exception as exc:  # noqa: BLE001 - counted, reported
                self.errors.append(str(exc))
                conn.close()
                conn = self._conn()
                continue
            self.latencies.append(1e3 * (time.perf_counter() - t0))
            time.sleep(self.think * (0.2 + 1.6 * self.rng.random()))
        conn.close()


def lost_sessions(host: str, port: int, students: list[Student]) -> list[str]:
    """Codes whose stored model is neither the acknowledged nor the in-flight one."""
    lost = []
    conn = http.client.HTTPConnection(host, port, timeout=30)
    for s in students:
        if s.code is None:
            continue
        conn.request("GET", f"/api/sessions/{s.code}")
        r = conn.getresponse()
        body = r.read()
        if r.status != 200:
            lost.append(f"{s.code}: {r.status}")
            continue
        p0 = json.loads(body)["config"]["model"]["p0"]
        if s.acked is not None and p0 not in (s.acked, s.in_flight):
            lost.append(f"{s.code}: p0 {p0} but the server acknowledged {s.acked}")
    conn.close()
    return lost


def main(argv: list[str] | None = None) -> int:  # noqa: C901 - a script's argv handling, one branch per option
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--students", "--clients", type=int, default=100, dest="students")
    ap.add_argument("--duration", type=float, default=60.0, help="seconds")
    ap.add_argument("--think", type=float, default=1.0,
                    help="mean seconds a student waits between slider steps")
    ap.add_argument("--fault", action="store_true",
                    help="kill -9 the server at half time and restart it")
    ap.add_argument("--url", default=None, help="a running explorer (loopback only)")
    ap.add_argument("--root", type=Path, default=ROOT,
                    help="the checkout to serve (to compare two in the same conditions)")
    ap.add_argument("--quick", action="store_true", help="10 students for 5 s (smoke test)")
    args = ap.parse_args(argv)
    if args.quick:
        args.students, args.duration = 10, 5.0
    if not 1 <= args.students <= 500 or not 0 < args.duration <= 3600:
        ap.error("--students must be 1..500 and --duration 0..3600 s")
    if args.fault and args.url:
        ap.error("--fault starts its own server; leave out --url")
    state = tempfile.TemporaryDirectory(prefix="hyst-load-")
    proc = None
    if args.url is None:
        port = free_port()
        proc = start_server(port, state.name, args.root)
        url = f"http://127.0.0.1:{port}"
    else:
        url = args.url
    parsed = urlparse(url)
    if parsed.hostname not in ("127.0.0.1", "localhost", "::1"):
        ap.error("the load test only targets loopback addresses")
    host, port = parsed.hostname, parsed.port or 80
    outage = threading.Event()
    restart_s = None
    try:
        deadline = time.monotonic() + args.duration
        students = [Student(host, port, deadline, i, args.think, outage)
                    for i in range(args.students)]
        t0 = time.monotonic()
        for s in students:
            s.start()
        if args.fault:
            time.sleep(args.duration / 2)
            outage.set()
            proc.send_signal(signal.SIGKILL)  # type: ignore[union-attr]
            proc.wait(timeout=10)  # type: ignore[union-attr]
            k0 = time.monotonic()
            proc = start_server(port, state.name, args.root)
            restart_s = time.monotonic() - k0
            time.sleep(1.0)  # let the retries in flight land
            outage.clear()
        for s in students:
            s.join(timeout=args.duration + 120)
        wall = time.monotonic() - t0
        lost = lost_sessions(host, port, students) if args.fault else []
    finally:
        if proc is not None:
            proc.terminate()
            proc.wait(timeout=10)
        state.cleanup()
    lat = [x for s in students for x in s.latencies]
    errors = [e for s in students for e in s.errors]
    print(f"load test: {args.students} students, {args.duration:g} s, think {args.think:g} s, "
          f"{url}")
    p95 = float(np.percentile(lat, 95)) if lat else float("nan")
    if lat:
        print(f"steps: {len(lat)} ({len(lat) / wall:.1f}/s)  latency ms: "
              f"p50 {statistics.median(lat):.1f}  p95 {p95:.1f}  "
              f"p99 {np.percentile(lat, 99):.1f}  max {max(lat):.1f}  "
              f"(target p95 <= {P95_BAR_MS:g})")
    kinds: dict[str, list[float]] = {}
    for s in students:
        for k, v in s.by_kind.items():
            kinds.setdefault("PATCH config" if k.startswith("PATCH") else
                             "PUT session" if k.startswith("PUT") else k, []).extend(v)
    print("per request ms (p50 / p95): " + ", ".join(
        f"{k} {statistics.median(v):.1f} / {np.percentile(v, 95):.1f}"
        for k, v in sorted(kinds.items()) if len(v) >= 20))
    print(f"errors: {len(errors)}")
    for e in errors[:5]:
        print(f"  {e}")
    if args.fault:
        down = sum(s.downtime_errors for s in students)
        print(f"fault: kill -9 at {args.duration / 2:g} s, restarted in {restart_s:.1f} s, "
              f"{down} requests refused while down; sessions lost: {len(lost)} of "
              f"{sum(s.code is not None for s in students)}")
        for x in lost[:5]:
            print(f"  {x}")
    bad = bool(errors) or not lat or bool(lost) or (not args.quick and p95 > P95_BAR_MS)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
