"""Flood benchmark: the attacks of issue 35 against a local explorer, bounded, loopback only.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_flood.py [--slow 1500]
[--uploads 30] [--store-mb 200] [--only slowloris,uploads,store,inverse] [--tree DIR]``

The script starts ``python -m app serve --no-viser --no-browser`` from ``--tree`` (this
checkout by default; give another checkout, such as a ``git worktree`` of an older commit,
to measure it the same way) on a free loopback port with a fresh ``--state-dir``, runs each
scenario and stops the server. Every loop is bounded in count and time; only 127.0.0.0/8 is
ever contacted.

- ``slowloris``: ``--slow`` connections from 127.0.0.1, each sending the start of a request
  up to a header's value, then one more byte of it every 5 s for 40 s; meanwhile another
  computer (127.0.0.2) asks ``GET /api/capabilities`` every second. Reported: connections
  the server still holds at 10, 20 and 40 s, the other computer's answers and worst latency,
  the server's log size.
- ``uploads``: ``--uploads`` sessions each receive a 4.9 MB CSV at the same time. Reported:
  the server's resident memory (RSS) before, just after and 5 s after.
- ``store``: with ``--max-store-mb`` = ``--store-mb``, one computer (127.0.0.1) opens sessions
  and uploads a 4.9 MB CSV to each until refused (at most the store's size / 4.9 MB + 5);
  then another computer (127.0.0.3) and the teacher open one. Reported: the attacker's
  uploads accepted and the status codes of the other two.
- ``inverse``: ``POST /api/simulate`` of a 100 x 97 Preisach model on 200,000 samples with
  ``"figures": ["inverse"]`` (capped at 300 s). Reported: its status and seconds.
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TOKEN = "bench-flood-teacher-token"


def _csv(mb: float = 4.9) -> bytes:
    n = int(mb * 1e6 / 37)
    t = np.arange(n) * 1e-4
    u = 4 * np.sin(2 * np.pi * 3 * t)
    lines = [f"{a:.6f},{b:.9f},{0.5 * b:.9f}" for a, b in zip(t, u, strict=True)]
    return ("t,u,y\n" + "\n".join(lines) + "\n").encode()


class Server:
    """``hyst serve`` of ``tree`` on a free loopback port, its log in a file."""

    def __init__(self, tree: Path, state: Path, *extra: str) -> None:
        self.log = state / "server.log"
        env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1",
               "HYST_TEACHER_TOKEN": TOKEN, "PYTHONPATH": str(tree)}
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "app", "serve", "--no-browser", "--no-viser", "--port", "0",
             "--host", "127.0.0.1", "--state-dir", str(state), *extra],
            cwd=tree, env=env, stdout=open(self.log, "w"), stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            text = self.log.read_text(errors="replace")
            if "web page:" in text:
                url = text.split("web page:")[1].split()[0]
                self.port = int(url.rsplit(":", 1)[1].strip("/"))
                return
            if self.proc.poll() is not None:
                break
            time.sleep(0.2)
        self.stop()
        raise SystemExit(f"the server did not start:\n{self.log.read_text()[-2000:]}")

    def rss_mb(self) -> float:
        for line in Path(f"/proc/{self.proc.pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
        return float("nan")

    def request(self, method: str, path: str, body: bytes | None = None,
                headers: dict[str, str] | None = None, source: str = "127.0.0.1",
                timeout: float = 60.0) -> tuple[int, bytes]:
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout,
                                          source_address=(source, 0))
        try:
            conn.request(method, path, body=body, headers={"Host": "127.0.0.1",
                                                            **(headers or {})})
            r = conn.getresponse()
            return r.status, r.read()
        except (OSError, http.client.HTTPException):
            return 0, b""
        finally:
            conn.close()

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(15)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def slowloris(srv: Server, n: int) -> None:
    socks: list[socket.socket] = []
    for _ in range(n):
        s = socket.socket()
        s.settimeout(2)
        try:
            s.connect(("127.0.0.1", srv.port))
            s.sendall(b"GET /api/capabilities HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ")
            socks.append(s)
        except OSError:
            s.close()
            break
    print(f"slowloris: {len(socks)} of {n} connections opened")
    victim: list[tuple[int, float]] = []
    stop = threading.Event()

    def ask() -> None:
        while not stop.is_set():
            t0 = time.monotonic()
            status, _ = srv.request("GET", "/api/capabilities", source="127.0.0.2", timeout=10)
            victim.append((status, time.monotonic() - t0))
            stop.wait(1.0)

    th = threading.Thread(target=ask, daemon=True)
    th.start()
    t0 = time.monotonic()
    marks = [10, 20, 40]
    while marks:
        time.sleep(0.5)
        el = time.monotonic() - t0
        if int(el) % 5 == 0:
            for s in socks:
                try:
                    s.sendall(b"a")  # one more byte of a header value
                except OSError:
                    pass
        if el >= marks[0]:
            # still held: the server has neither answered nor closed it
            open_ = sum(1 for s in socks if not _readable(s))
            print(f"  at {marks.pop(0)} s: {open_} connections still held by the server")
    stop.set()
    th.join()
    for s in socks:
        s.close()
    ok = sum(1 for st, _ in victim if st == 200)
    print(f"  another computer: {ok}/{len(victim)} answered 200, worst "
          f"{max(t for _, t in victim):.2f} s; server log {srv.log.stat().st_size / 1e6:.2f} MB")


def _readable(s: socket.socket) -> bool:
    """Whether the server answered or closed ``s`` (poll: any descriptor number)."""
    import select

    p = select.poll()
    p.register(s, select.POLLIN | select.POLLHUP | select.POLLERR)
    return bool(p.poll(0))


def uploads(srv: Server, n: int) -> None:
    body = _csv()
    codes = [json.loads(srv.request("POST", "/api/sessions",
                                    headers={"X-Teacher-Token": TOKEN})[1])["code"]
             for _ in range(n)]
    before = srv.rss_mb()
    status: list[int] = []

    def up(code: str) -> None:
        status.append(srv.request("POST", f"/api/sessions/{code}/recording", body,
                                  {"Content-Type": "text/csv"}, timeout=300)[0])

    threads = [threading.Thread(target=up, args=(c,)) for c in codes]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    after = srv.rss_mb()
    time.sleep(5)
    print(f"uploads: {n} x {len(body) / 1e6:.1f} MB, statuses {sorted(set(status))}: server "
          f"RSS {before:.0f} MB before, {after:.0f} MB after, {srv.rss_mb():.0f} MB 5 s later")


def store(srv: Server, store_mb: int) -> None:
    body = _csv()
    accepted = 0
    last = 0
    for _ in range(int(store_mb / 4.9) + 5):
        st, out = srv.request("POST", "/api/sessions")
        if st != 201:
            last = st
            break
        code = json.loads(out)["code"]
        last = srv.request("POST", f"/api/sessions/{code}/recording", body,
                           {"Content-Type": "text/csv"}, timeout=120)[0]
        if last != 201:
            break
        accepted += 1
    other = srv.request("POST", "/api/sessions", source="127.0.0.3")[0]
    teacher = srv.request("POST", "/api/sessions", headers={"X-Teacher-Token": TOKEN},
                          source="127.0.0.3")[0]
    print(f"store: one computer uploaded {accepted} x 4.9 MB (then {last}); another computer "
          f"{other}, the teacher {teacher}")


def inverse(srv: Server) -> None:
    n, m = 100, 97
    doc = {"type": "preisach", "thresholds": list(np.linspace(0.0, 2.5, n)),
           "weights": np.full((n, m), 0.011).tolist(),
           "knots": list(np.linspace(-2.0, 2.0, m - 1))}
    body = json.dumps({"model": doc, "signal": {"samples": 200_000},
                       "figures": ["inverse"]}).encode()
    t0 = time.monotonic()
    st, out = srv.request("POST", "/api/simulate", body, {"Content-Type": "application/json"},
                          timeout=300)
    print(f"inverse: {len(body) / 1e3:.1f} KB request -> {st or 'no answer'} in "
          f"{time.monotonic() - t0:.1f} s {out[:120]!r}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--slow", type=int, default=1500)
    ap.add_argument("--uploads", type=int, default=30)
    ap.add_argument("--store-mb", type=int, default=200)
    ap.add_argument("--only", default="slowloris,uploads,store,inverse")
    ap.add_argument("--tree", type=Path, default=ROOT)
    args = ap.parse_args()
    only = set(args.only.split(","))
    for name in ("slowloris", "uploads", "store", "inverse"):
        if name not in only:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            extra = ("--max-store-mb", str(args.store_mb)) if name == "store" else ()
            srv = Server(args.tree.resolve(), Path(tmp), *extra)
            try:
                if name == "slowloris":
                    slowloris(srv, args.slow)
                elif name == "uploads":
                    uploads(srv, args.uploads)
                elif name == "store":
                    store(srv, args.store_mb)
                else:
                    inverse(srv)
            finally:
                srv.stop()


if __name__ == "__main__":
    main()
