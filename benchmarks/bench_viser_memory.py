"""Resident memory of ``hyst serve`` while viser tabs open and close (issue 18 item 1).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_viser_memory.py
[--cycles 200] [--burst 30] [--hold 0.7] [--quick]``

Starts ``python -m app serve --no-browser`` on free loopback ports with a fresh
``--state-dir`` in a subprocess and drives its viser port with a raw websocket client, as
a browser tab does (viser's subprotocol, one ``ViewerCameraMessage`` in msgpack, which
makes viser count the tab as connected and the explorer build its view):

* **cycles**: ``--cycles`` times, open a tab, read what the server sends for ``--hold``
  seconds, close it (every 4th tab closes at once, while its view is still being built).
  The server's resident size (``VmRSS``) is read every 10 cycles.
* **burst**: ``--burst`` tabs open at once, read for 8 s, all close.

Printed: RSS every 10 cycles; RSS 3 s after cycle 100 and 3 s after cycle 200 (nothing
open) and its growth between the two (the bar: at most :data:`FLAT_MB`, "flat"); the mean
RSS while tabs come and go over cycles 50..100 and 150..200; RSS with the burst open and 5 s
after it closed (the bar: back within :data:`BURST_BACK_MB` of the RSS before the burst).
Numbers before and after the fix: benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import msgspec
import viser
from websockets.sync.client import connect

ROOT = Path(__file__).resolve().parent.parent
PROTOCOL = f"viser-v{viser.__version__}"
CAMERA = msgspec.msgpack.encode({
    "type": "ViewerCameraMessage", "wxyz": [1.0, 0.0, 0.0, 0.0], "position": [0.0, 0.0, 5.0],
    "fov": 1.0, "near": 0.01, "far": 100.0, "image_height": 900, "image_width": 1500,
    "look_at": [0.0, 0.0, 0.0], "up_direction": [0.0, 0.0, 1.0]})
#: Largest growth of the resident size over cycles 100..200 called flat, MB.
FLAT_MB = 25.0
#: How close to the RSS before the burst the server must come back after it closed, MB.
BURST_BACK_MB = 60.0


def free_port() -> int:
    """A free loopback port."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def rss_mb(pid: int) -> float:
    """Resident size of process ``pid``, MB."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


def start(root: Path, state_dir: str) -> tuple[subprocess.Popen, int]:
    """``hyst serve`` of the code in ``root``; returns it and its viser port once it answers."""
    port, vport = free_port(), free_port()
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": str(root),
           "HYST_MAX_TABS_PER_CLIENT": "100"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "serve", "--no-browser", "--port", str(port),
         "--viser-port", str(vport), "--state-dir", state_dir],
        cwd=root, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError("the server exited at start-up")
        try:
            socket.create_connection(("127.0.0.1", vport), 0.5).close()
            time.sleep(1.0)
            return proc, vport
        except OSError:
            time.sleep(0.2)
    proc.kill()
    raise RuntimeError("the server did not start within 60 s")


def open_tab(vport: int):  # noqa: ANN201 - a websockets ClientConnection
    """A raw viser tab: handshake plus the first camera message."""
    ws = connect(f"ws://127.0.0.1:{vport}/", subprotocols=[PROTOCOL], open_timeout=30,
                 max_size=None)
    ws.send(CAMERA)
    return ws


def read_for(tabs: list, seconds: float) -> None:
    """Read what the server sends to ``tabs`` for ``seconds``."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for ws in tabs:
            try:
                while True:
                    ws.recv(timeout=0.005)
            except TimeoutError:
                pass


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=200)
    ap.add_argument("--burst", type=int, default=30)
    ap.add_argument("--hold", type=float, default=0.7, help="seconds a tab stays open")
    ap.add_argument("--root", type=Path, default=ROOT, help="the code to serve")
    ap.add_argument("--quick", action="store_true", help="40 cycles, a burst of 10")
    args = ap.parse_args(argv)
    if args.quick:
        args.cycles, args.burst = 40, 10
    args.cycles = max(20, min(args.cycles, 2000))
    with tempfile.TemporaryDirectory() as state:
        proc, vport = start(args.root, state)
        try:
            at: dict[int, float] = {0: rss_mb(proc.pid)}
            print(f"start: RSS {at[0]:.0f} MB", flush=True)
            for i in range(1, args.cycles + 1):
                ws = open_tab(vport)
                if i % 4:
                    read_for([ws], args.hold)
                ws.close()
                if i % 10 == 0:
                    at[i] = rss_mb(proc.pid)
                    print(f"cycle {i}: RSS {at[i]:.0f} MB", flush=True)
                if i == args.cycles // 2:
                    time.sleep(3.0)
                    mid = rss_mb(proc.pid)
                    print(f"after {i} cycles and 3 s quiet: RSS {mid:.0f} MB", flush=True)
            time.sleep(3.0)
            end = rss_mb(proc.pid)
            n = args.cycles
            growth = end - mid
            print(f"after {n} cycles and 3 s quiet: RSS {end:.0f} MB; growth over cycles "
                  f"{n // 2}..{n}: {growth:+.0f} MB (bar <= {FLAT_MB:.0f}): "
                  f"{'met' if growth <= FLAT_MB else 'MISSED'}")
            # while tabs come and go, samples move by +-30 MB with what is being built
            early = [v for k, v in at.items() if n / 4 < k <= n / 2]
            late = [v for k, v in at.items() if 3 * n / 4 < k <= n]
            print(f"while tabs come and go: RSS mean over cycles {n // 4}..{n // 2} "
                  f"{sum(early) / len(early):.0f} MB, over cycles {3 * n // 4}..{n} "
                  f"{sum(late) / len(late):.0f} MB")
            tabs = [open_tab(vport) for _ in range(max(1, args.burst))]
            read_for(tabs, 8.0)
            peak = rss_mb(proc.pid)
            for ws in tabs:
                ws.close()
            time.sleep(5.0)
            back = rss_mb(proc.pid)
            print(f"burst of {len(tabs)} tabs: RSS {end:.0f} -> {peak:.0f} MB open "
                  f"({(peak - end) / len(tabs):.1f} MB per open tab), {back:.0f} MB 5 s "
                  f"after they closed (bar <= {end + BURST_BACK_MB:.0f}): "
                  f"{'met' if back <= end + BURST_BACK_MB else 'MISSED'}")
        finally:
            proc.terminate()
            proc.wait(timeout=30)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
