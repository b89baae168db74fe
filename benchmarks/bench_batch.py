"""Batch speed-up on Dask: ``hyst batch fit`` on 200 generated recordings, 1 vs 2 workers.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_batch.py [--count 200]
[--quick] [--workers 1,2]``

Recordings: the concealed-effect scenarios of ``benchmarks/diagnosis/generator.py`` (the
B-PI truth plant with one hidden effect or none, three signals per scenario: decaying sine,
multisine, staircase; 15 500 to 24 500 samples), written as CSV files into a temporary
folder. Each case fits them all with ``hyst batch fit --model pi`` (n chosen by
cross-validation per recording) on a fresh LocalCluster (processes, one thread each) and a
fresh output folder (no resume). The baseline measured in the same run is the serial
loop over the same single-file function in this process (no Dask at all).

Printed: wall time per case (cluster start-up included, and without it), recordings per
second, speed-up against 1 worker and against the serial loop. Target: 2 workers >= 1.6x
faster than 1 worker on an idle 2-core machine (the cores are shared: check ``uptime``).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from app.batch import FitOptions, run_batch  # noqa: E402
from app.batch.single import run_recording  # noqa: E402
from benchmarks.diagnosis.generator import EFFECTS, make_scenario  # noqa: E402

TARGET = 1.6


def make_recordings(folder: Path, count: int) -> list[Path]:
    """``count`` CSV recordings of the diagnosis benchmark's scenarios in ``folder``."""
    files: list[Path] = []
    kinds = (None, *EFFECTS)
    seed = 0
    while len(files) < count:
        effect = kinds[seed % len(kinds)]
        sc = make_scenario(effect, "white1", 500 + seed)
        for rec in sc.records:
            if len(files) == count:
                break
            p = folder / f"{effect or 'null'}_{seed:03d}_{rec.name}.csv"
            np.savetxt(p, np.column_stack((rec.t, rec.u, rec.y)), delimiter=",",
                       header="t_s,u_V,y_um", comments="", fmt="%.10g")
            files.append(p)
        seed += 1
    return files


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=200, help="recordings (default 200)")
    ap.add_argument("--workers", default="1,2", help="comma-separated worker counts")
    ap.add_argument("--quick", action="store_true", help="20 recordings (smoke run)")
    a = ap.parse_args(argv)
    count = 20 if a.quick else a.count
    opts = FitOptions(model="pi")
    print(f"machine: {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory(prefix="bench-batch-") as tmp:
        t0 = time.perf_counter()
        (Path(tmp) / "in").mkdir()
        files = make_recordings(Path(tmp) / "in", count)
        print(f"generated {len(files)} recordings in {time.perf_counter() - t0:.1f} s")
        # baseline: the serial loop over the same single-file function, in this process
        run_recording("fit", files[0].name, files[0].read_bytes(), opts.argv())  # warm-up
        t0 = time.perf_counter()
        for f in files:
            out = run_recording("fit", f.name, f.read_bytes(), opts.argv())
            assert out.ok, out.error
        serial = time.perf_counter() - t0
        print(f"{'serial loop (no Dask)':<24} {serial:7.1f} s  {len(files) / serial:6.2f} rec/s")
        times: dict[int, float] = {}
        for w in (int(x) for x in a.workers.split(",")):
            t0 = time.perf_counter()
            res = run_batch([str(Path(tmp) / "in")], Path(tmp) / f"out{w}", opts, workers=w,
                            resume=False, quiet=True)
            wall = time.perf_counter() - t0
            assert not res.failed, res.failed[0].error
            times[w] = wall
            print(f"{f'batch, {w} worker(s)':<24} {wall:7.1f} s  {len(files) / wall:6.2f} rec/s"
                  f"  x{serial / wall:.2f} vs serial")
        if 1 in times and 2 in times:
            sp = times[1] / times[2]
            print(f"speed-up 1 -> 2 workers: x{sp:.2f} (target >= {TARGET}: "
                  f"{'met' if sp >= TARGET else 'missed'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
