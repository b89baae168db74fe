"""How fast does a cancel free the job slot? (issue 18, item 4)

Starts a real ``hyst serve`` with one job slot (``HYST_MAX_JOBS=1``), loads a long recording
(160k samples) into one session and a short one into another, and measures, for

(a) a dead-zone GPI fit (``gpi-deadzone``, n = 100) cancelled with ``DELETE .../jobs/{id}``,
(b) a diagnosis of the shipped piezo recording, repeated three times (150k samples),
    cancelled the same way (its longest step between two progress reports, "judging the base
    model against the noise", takes about 5 s on an idle machine),
(c) a synchronous ``POST .../fit`` whose client hangs up,

the seconds from the cancel (the DELETE answered, or the socket closed) until a small fit of
the other session, queued behind it, starts running (the slot is free), and until the
cancelled job ends (its state is printed). The fits run ``--run`` seconds (2 by default)
before they are cancelled; the diagnosis is run and cancelled once for each of
``--diagnose-at`` (1, 3, 5 and 7 s). A case that has not freed the slot after ``--cap``
seconds is reported as ``> cap``. Run from the repository root::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_cancel.py [--samples 160000]
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path
from urllib.parse import urlsplit

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _serve(state: str) -> tuple[subprocess.Popen, str]:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1",
           "HYST_MAX_JOBS": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "serve", "--no-browser", "--no-viser", "--port", "0",
         "--state-dir", state], cwd=ROOT, env=env, stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    while True:
        line = proc.stdout.readline()
        if "web page:" in line:
            return proc, line.split("web page:")[1].split()[0]
        if not line and proc.poll() is not None:
            raise SystemExit("hyst serve did not start")


def _call(url: str, method: str = "GET", body: bytes | None = None,
          ctype: str = "application/json") -> dict:
    req = urllib.request.Request(url, data=body, method=method, headers={"Content-Type": ctype})
    with urllib.request.urlopen(req, timeout=600) as r:
        return json.load(r)


def _csv(n: int) -> bytes:
    """A random-walk input through a PI model plus noise: a slow fit (about 12 s for the
    dead-zone GPI at n = 100 on 160k samples, single-threaded)."""
    from core.pi import PIModel

    rng = np.random.default_rng(1)
    t = np.arange(n) * 1e-4
    u = np.cumsum(rng.standard_normal(n))
    u = 3 * (u - u.mean()) / (np.ptp(u) or 1.0)
    y = PIModel(0.5, np.linspace(0.05, 2, 8), np.full(8, 0.1))(u)
    y = y + 0.01 * rng.standard_normal(n)
    rows = "\n".join(f"{a:.5f},{b:.5f},{c:.5f}" for a, b, c in zip(t, u, y, strict=True))
    return f"t,u,y\n{rows}\n".encode()


_FINAL = ("done", "failed", "cancelled")
PIEZO = ROOT.parent / "shared" / "data" / "piezo" / "piezo_150V_1Hz.csv"


def _piezo(path: Path, times: int = 3) -> bytes:
    d = np.loadtxt(path, delimiter=",", skiprows=1)
    u, y = np.tile(d[:, 1], times), np.tile(d[:, 2], times)
    dt = float(d[1, 0] - d[0, 0])
    rows = "\n".join(f"{k * dt:.4f},{a:.3f},{b:.4f}"
                     for k, (a, b) in enumerate(zip(u, y, strict=True)))
    return f"t,u,y\n{rows}\n".encode()


def _state(web: str, code: str, job: str) -> str:
    return _call(web + f"api/sessions/{code}/jobs/{job}")["state"]


def _until(cond, cap: float) -> float | None:  # noqa: ANN001
    t0 = time.monotonic()
    while time.monotonic() - t0 < cap:
        if cond():
            return time.monotonic() - t0
        time.sleep(0.02)
    return None


def _measure(web: str, small: str, cancel, long_state, cap: float) -> tuple:  # noqa: ANN001
    """Queue the small fit, cancel, time until it runs and until the long job ends; the
    long job's last state."""
    other = _call(web + f"api/sessions/{small}/jobs", "POST",
                  b'{"kind": "fit", "params": {"n": 3, "apply": false}}')["id"]
    t0 = time.monotonic()
    cancel()
    t_cancel = time.monotonic() - t0
    free = _until(lambda: _state(web, small, other) != "queued", cap)
    ended = _until(lambda: long_state() in _FINAL, cap)
    _until(lambda: _state(web, small, other) in _FINAL, 600)
    return t_cancel, free, ended, long_state()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--samples", type=int, default=160_000)
    ap.add_argument("--run", type=float, default=2.0)
    ap.add_argument("--cap", type=float, default=240.0)
    ap.add_argument("--diagnose-at", type=lambda t: [float(x) for x in t.split(",")],
                    default=[1.0, 3.0, 5.0, 7.0],
                    help="seconds into the diagnosis at which it is cancelled (one run each)")
    ap.add_argument("--piezo", type=Path, default=PIEZO, help="the recording to diagnose")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        proc, web = _serve(tmp)
        try:
            big = _call(web + "api/sessions", "POST")["code"]
            small = _call(web + "api/sessions", "POST")["code"]
            piezo = _call(web + "api/sessions", "POST")["code"]
            _call(web + f"api/sessions/{big}/recording", "POST", _csv(args.samples), "text/csv")
            _call(web + f"api/sessions/{small}/recording", "POST", _csv(400), "text/csv")
            _call(web + f"api/sessions/{piezo}/recording", "POST", _piezo(args.piezo), "text/csv")
            rows = []
            cases = [("a", args.run, big, {"kind": "fit", "params": {
                "kind": "gpi-deadzone", "n": 100, "apply": False}})]
            cases += [("b", at, piezo, {"kind": "diagnose"}) for at in args.diagnose_at]
            for name, at, code, body in cases:
                job = _call(web + f"api/sessions/{code}/jobs", "POST",
                            json.dumps(body).encode())["id"]
                _until(lambda c=code, j=job: _state(web, c, j) == "running", 60)
                time.sleep(at)
                res = _measure(
                    web, small,
                    lambda c=code, j=job: _call(web + f"api/sessions/{c}/jobs/{j}", "DELETE"),
                    lambda c=code, j=job: _state(web, c, j), args.cap)
                rows.append((name, at, *res))
            # (c) a synchronous fit whose client hangs up
            host = urlsplit(web)
            s = socket.create_connection((host.hostname, host.port))
            body = json.dumps({"kind": "gpi-deadzone", "n": 100, "apply": False}).encode()
            s.sendall(f"POST /api/sessions/{big}/fit HTTP/1.1\r\nHost: {host.netloc}\r\n"
                      f"Content-Type: application/json\r\nContent-Length: {len(body)}\r\n"
                      "\r\n".encode() + body)
            listed = lambda: _call(web + f"api/sessions/{big}/jobs?limit=1")["jobs"]  # noqa: E731
            _until(lambda: bool(listed()) and listed()[0]["state"] == "running", 60)
            time.sleep(args.run)
            res = _measure(web, small, s.close, lambda: listed()[0]["state"], args.cap)
            rows.append(("c", args.run, *res))
        finally:
            proc.terminate()
            proc.wait(30)
    names = {"a": "gpi-deadzone n=100 job, DELETE", "b": "piezo x3 diagnosis job, DELETE",
             "c": "synchronous fit, client hangs up"}
    print(f"samples: {args.samples}; 'ran': seconds the long job ran before the cancel")
    print(f"{'case':36s} {'ran s':>5s} {'cancel call s':>13s} {'slot free s':>12s} "
          f"{'job ended s':>12s}  state")
    for name, at, t_cancel, free, ended, state in rows:
        fmt = lambda x: f"> {args.cap:g}" if x is None else f"{x:.2f}"  # noqa: E731
        print(f"{names[name]:36s} {at:5g} {t_cancel:13.2f} {fmt(free):>12s} "
              f"{fmt(ended):>12s}  {state}")


if __name__ == "__main__":
    main()
