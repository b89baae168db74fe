"""One student's slider step against a real ``hyst serve``, request by request.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_rest_step.py [--steps 300]
[--root PATH] [--py-spy PATH-TO-py-spy]``

Starts ``python -m app serve --no-viser`` of the code in ``--root`` (this checkout by
default) on a free loopback port with a fresh state directory, opens one session and
repeats the load test's slider step without thinking (``PATCH /api/sessions/{code}/config``
with a new weight and ``p0``, then ``GET /api/sessions/{code}/figures?name=loop``; every
10th step also ``PUT /api/sessions/{code}`` and ``POST /api/simulate``). Printed: the
server's CPU time per step (user + system, from ``/proc``: what a step costs whatever
else the machine runs), median and p95 per request kind and per step, ms. With
``--py-spy``, the server is sampled while
the steps run and the share of samples per function is printed (own time and inclusive
time of the server's request threads), the profile of where a step's time goes.
``--root`` lets two checkouts be compared in the same conditions (run them back to back).
"""

from __future__ import annotations

import argparse
import collections
import http.client
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from load_test import free_port, start_server  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def cpu_s(pid: int) -> float:
    """CPU time (user + system) process ``pid`` has used, s (Linux ``/proc``)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def profile_table(raw: Path, top: int = 60) -> str:
    """Own and inclusive sample shares per function from py-spy's ``raw`` output."""
    own: collections.Counter[str] = collections.Counter()
    incl: collections.Counter[str] = collections.Counter()
    total = 0
    for line in raw.read_text().splitlines():
        stack, _, n = line.rpartition(" ")
        if not n.isdigit():
            continue
        frames = [f.split(" (")[0] + " (" + f.split(" (")[-1].split(":")[0].rsplit("/", 1)[-1]
                  + ")" for f in stack.split(";")[1:]]
        if not frames or "idle" in stack:
            continue
        k = int(n)
        total += k
        own[frames[-1]] += k
        for f in set(frames):
            incl[f] += k
    lines = [f"{total} samples of busy server threads"]
    lines.append("inclusive:")
    lines += [f"  {100 * v / total:5.1f} %  {k}" for k, v in incl.most_common(top)]
    lines.append("own:")
    lines += [f"  {100 * v / total:5.1f} %  {k}" for k, v in own.most_common(top)]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--root", type=Path, default=ROOT)
    ap.add_argument("--py-spy", default=None, help="path of a py-spy binary")
    ap.add_argument("--profile-out", type=Path, default=None,
                    help="keep py-spy's raw samples (collapsed stacks) in this file")
    args = ap.parse_args(argv)
    steps = max(20, min(args.steps, 20_000))
    port = free_port()
    rng = random.Random(0)
    with tempfile.TemporaryDirectory() as state:
        proc = start_server(port, state, args.root)
        spy = None
        raw = args.profile_out or Path(state) / "profile.txt"
        try:
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=30)

            def req(method: str, path: str, body: dict | None = None) -> tuple[float, bytes]:
                data = None if body is None else json.dumps(body).encode()
                t0 = time.perf_counter()
                c.request(method, path, body=data,
                          headers={"Content-Type": "application/json"} if data else {})
                r = c.getresponse()
                payload = r.read()
                if r.status >= 300:
                    raise RuntimeError(f"{method} {path}: {r.status} {payload[:200]!r}")
                return 1e3 * (time.perf_counter() - t0), payload

            code = json.loads(req("POST", "/api/sessions")[1])["code"]
            base = json.loads(req("GET", f"/api/sessions/{code}")[1])["config"]["model"]
            times: dict[str, list[float]] = collections.defaultdict(list)
            for warm in range(10 + steps):
                if warm == 10:
                    cpu0 = cpu_s(proc.pid)
                if warm == 10 and args.py_spy:
                    spy = subprocess.Popen([args.py_spy, "record", "--pid", str(proc.pid),
                                            "--rate", "1000", "--gil", "--format", "raw",
                                            "--output", str(raw), "--nonblocking"],
                                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                    time.sleep(1.0)
                model = dict(base, p0=round(0.5 + rng.random(), 6))
                w = list(model["weights"])
                w[rng.randrange(len(w))] = round(rng.random(), 4)
                model["weights"] = w
                rec = warm >= 10
                t_patch, _ = req("PATCH", f"/api/sessions/{code}/config", {"model": model})
                t_fig, _ = req("GET", f"/api/sessions/{code}/figures?name=loop")
                step = t_patch + t_fig
                if warm % 10 == 9:
                    t_put, _ = req("PUT", f"/api/sessions/{code}")
                    t_sim, _ = req("POST", "/api/simulate", {"model": model, "figures": ["time"]})
                    step += t_put + t_sim
                    if rec:
                        times["PUT session"].append(t_put)
                        times["POST simulate"].append(t_sim)
                if rec:
                    times["PATCH config"].append(t_patch)
                    times["GET figures"].append(t_fig)
                    times["step"].append(step)
            cpu = cpu_s(proc.pid) - cpu0
        finally:
            if spy is not None:
                spy.send_signal(2)
                spy.wait(timeout=60)
            proc.terminate()
            proc.wait(timeout=30)
        print(f"one client, {steps} steps, server {args.root}: server CPU "
              f"{1e3 * cpu / steps:.2f} ms per step{' (py-spy attached)' if spy else ''}")
        for k, v in times.items():
            print(f"  {k:14s} median {statistics.median(v):6.2f} ms   p95 "
                  f"{np.percentile(v, 95):6.2f} ms   (n = {len(v)})")
        if spy is not None and raw.exists():
            print(profile_table(raw))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
