"""Diagnosis and fit at the size of real recordings: wall, CPU and peak memory against samples.

Run: ``.venv/bin/python benchmarks/bench_diagnose_scale.py [--huge] [--quick] [--contention]``

Each size is a tiled copy of the shipped piezo recording (``examples/data/piezo``, 10 s at
5 kHz): the file as shipped, then its last six 1 Hz input periods repeated (the input runs on
without a jump) until the size is reached, written as ``t,u,y`` CSV to a temporary folder.
``hyst fit FILE -o M.json`` and ``hyst diagnose FILE --json`` run on it as child processes
with their default settings (one numeric thread since issue 31), and ``os.wait4`` gives each
child's own CPU time (user + system) and peak resident memory (``ru_maxrss``). Every size is
measured in the same run and reported as a ratio to the 100k case, so the shape survives a
noisy shared machine; the load average is printed before and after.

Sizes: 25k, 100k, 200k, 400k, 1M samples; ``--huge`` adds 2M, 4M and 10M (a 306 MB CSV
for 10M, read in blocks by :mod:`core.csvio.stream`; about 10 minutes in all on a quiet
machine, up to 1.5 GB per run); ``--quick``: 25k and 100k. ``--sizes`` takes a comma list
(``25k,1M,10M``). The files are written to a temporary folder, or kept in ``--keep DIR``
(reused when there: a 10M file takes about 15 s to write). Nothing here runs in the test
suite.

``--baseline DIR`` also runs the code of another checkout (the code before a change) on the
same files, each of its runs just before the current one, and prints a before/after table.

Targets (issue 31): peak memory <= 400 MB + 0.3 kB per sample, CPU <= 1.5 s per 100,000
samples beyond the first 100,000, for both commands.

``--contention`` measures the README's piezo diagnosis (``hyst diagnose
examples/data/piezo/piezo_150V_1Hz.csv``) on a quiet machine and with two busy processes on
the two cores (pure-Python loops started by this script and stopped after), with the default
(one thread) and ``--threads 2`` (what ``hyst`` did before issue 31: OpenBLAS's default of
one thread per CPU), interleaved, median of ``--repeat`` runs. Target: busy <= 2x quiet.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
PIEZO = ROOT / "examples" / "data" / "piezo" / "piezo_150V_1Hz.csv"
PERIOD = 5000  # samples of one 1 Hz input period at 5 kHz
TAIL_PERIODS = 6  # the cycling part of the shipped file holds 6.7 periods
SIZES = {"25k": 25_000, "100k": 100_000, "200k": 200_000, "400k": 400_000, "1M": 1_000_000}
HUGE = {"2M": 2_000_000, "4M": 4_000_000, "10M": 10_000_000}
MB = 1e6
#: issue 31's targets
MEM_BASE, MEM_PER_SAMPLE = 400e6, 300.0  # bytes
CPU_PER_100K = 1.5  # s per 100,000 samples beyond the first 100,000


@dataclass(frozen=True)
class Run:
    """One child process: wall and CPU seconds, peak resident bytes, exit code."""

    wall_s: float
    cpu_s: float
    peak_bytes: float
    rc: int
    tail: str = ""


def child_env() -> dict[str, str]:
    """The environment of a user's shell: no thread variables of ours or of the tests."""
    drop = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")
    return {k: v for k, v in os.environ.items() if k not in drop}


def measure(argv: list[str], timeout: float = 3600.0, root: Path = ROOT) -> Run:
    """Run ``python -m app ARGV`` (= ``hyst ARGV``) of the checkout ``root`` and read its
    rusage from ``wait4``."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as err:
        proc = subprocess.Popen([sys.executable, "-m", "app", *argv], cwd=root, env=child_env(),
                                stdout=subprocess.DEVNULL, stderr=err)
        deadline = t0 + timeout
        while True:
            pid, status, ru = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() > deadline:
                proc.kill()
                pid, status, ru = os.wait4(proc.pid, 0)
                break
            time.sleep(0.05)
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        tail = err.read().decode("utf-8", "replace").strip().splitlines()[-1:] or [""]
    return Run(wall, ru.ru_utime + ru.ru_stime, ru.ru_maxrss * 1024.0, proc.returncode,
               tail[0][-300:])


def tiled_csv(n: int, folder: Path) -> Path:
    """The shipped piezo recording tiled to ``n`` samples (module docstring), as CSV."""
    path = folder / f"piezo_tiled_{n}.csv"
    if path.exists():
        return path
    d = np.loadtxt(PIEZO, delimiter=",", skiprows=1)
    dt = float(np.median(np.diff(d[:, 0])))
    tail = d[-TAIL_PERIODS * PERIOD:, 1:]  # starts one period-multiple before the end
    with path.open("w", encoding="ascii") as fh:
        fh.write("t_s,u_V,y_um\n")
        done = 0
        block = d[: min(n, len(d)), 1:]
        while done < n:
            k = np.arange(done, done + len(block))
            rows = np.column_stack([k * dt, block])
            np.savetxt(fh, rows, fmt=("%.4f", "%.6f", "%.6f"), delimiter=",")
            done += len(block)
            block = tail[: min(len(tail), n - done)]
    return path


def fmt_n(n: int) -> str:
    return f"{n / 1e6:g}M" if n >= 1_000_000 else f"{n // 1000}k"


def scale(sizes: dict[str, int], folder: Path, skip_fit: bool, baseline: Path | None = None
          ) -> dict[str, dict[str, Run]]:
    """Fit and diagnose every size; returns ``{label: {"fit": Run, "diagnose": Run}}``, with
    ``baseline`` (another checkout) also ``"fit (before)"`` and ``"diagnose (before)"``, each
    run just before the current one."""
    out: dict[str, dict[str, Run]] = {}
    # the first run of a checkout compiles its numba kernels (seconds of CPU): not measured
    for root in (ROOT,) if baseline is None else (baseline, ROOT):
        measure(["diagnose", str(PIEZO), "--json", "-q"], root=root)
    for label, n in sizes.items():
        t0 = time.perf_counter()
        src = tiled_csv(n, folder)
        print(f"  {label}: wrote {src.stat().st_size / MB:.1f} MB CSV in "
              f"{time.perf_counter() - t0:.1f} s", flush=True)
        row: dict[str, Run] = {}
        fit = ["fit", str(src), "-o", str(folder / "m.json"), "-q"]
        diag = ["diagnose", str(src), "--json", "-q"]
        for cmd, argv in ((("fit", fit),) if not skip_fit else ()) + (("diagnose", diag),):
            if baseline is not None:
                row[f"{cmd} (before)"] = measure(argv, root=baseline)
            row[cmd] = measure(argv)
        for k, r in row.items():
            print(f"    {k:8s} wall {r.wall_s:7.1f} s  CPU {r.cpu_s:7.1f} s  peak "
                  f"{r.peak_bytes / MB:7.0f} MB  exit {r.rc}"
                  + (f"  ({r.tail})" if r.rc else ""), flush=True)
        out[label] = row
    return out


def table(res: dict[str, dict[str, Run]], sizes: dict[str, int]) -> str:
    """The Markdown table of the docs: absolute values and ratios to the 100k case."""
    head = ("| samples | command | wall s | CPU s | peak MB | kB/sample | wall / 100k | "
            "CPU / 100k | peak / 100k |\n|---|---|---|---|---|---|---|---|---|")
    lines = [head]
    for cmd in ("fit (before)", "fit", "diagnose (before)", "diagnose"):
        ref = res.get("100k", {}).get(cmd)
        for label, row in res.items():
            r = row.get(cmd)
            if r is None:
                continue
            n = sizes[label]
            if r.rc:
                lines.append(f"| {n:,} | {cmd} | {r.wall_s:.1f} | {r.cpu_s:.1f} | "
                             f"{r.peak_bytes / MB:.0f} | | exit {r.rc}: {r.tail[:80]} | | |")
                continue
            ratio = (lambda a, b: f"{a / b:.2f}") if ref and not ref.rc else (lambda a, b: "")
            lines.append(
                f"| {n:,} | {cmd} | {r.wall_s:.1f} | {r.cpu_s:.1f} | {r.peak_bytes / MB:.0f} | "
                f"{r.peak_bytes / n / 1e3:.2f} | {ratio(r.wall_s, ref.wall_s if ref else 1)} | "
                f"{ratio(r.cpu_s, ref.cpu_s if ref else 1)} | "
                f"{ratio(r.peak_bytes, ref.peak_bytes if ref else 1)} |")
    return "\n".join(lines)


def before_after(res: dict[str, dict[str, Run]], sizes: dict[str, int]) -> str:
    """The Markdown table of ``--baseline``: peak memory and CPU before and after, and their
    ratios (after / before), measured in the same run."""
    lines = ["| samples | command | peak MB before | peak MB after | peak after / before | "
             "CPU s before | CPU s after | CPU after / before |",
             "|---|---|---|---|---|---|---|---|"]
    for cmd in ("fit", "diagnose"):
        for label, row in res.items():
            a, b = row.get(f"{cmd} (before)"), row.get(cmd)
            if a is None or b is None:
                continue
            ok = not a.rc and not b.rc
            cells = [f"{sizes[label]:,}", cmd]
            for va, vb, f in ((a.peak_bytes / MB, b.peak_bytes / MB, "{:.0f}"),
                              (a.cpu_s, b.cpu_s, "{:.1f}")):
                cells += [f.format(va) if not a.rc else f"exit {a.rc}",
                          f.format(vb) if not b.rc else f"exit {b.rc}",
                          f"{vb / va:.2f}" if ok else ""]
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def memory_model(res: dict[str, dict[str, Run]], sizes: dict[str, int], cmd: str
                 ) -> tuple[float, float] | None:
    """Least-squares ``peak = a + b * samples`` (bytes) over the sizes from 100k up."""
    pts = [(sizes[k], r[cmd].peak_bytes) for k, r in res.items()
           if cmd in r and not r[cmd].rc and sizes[k] >= 100_000]
    if len(pts) < 2:
        return None
    n, p = np.array(pts, dtype=float).T
    b, a = np.polyfit(n, p, 1)
    return float(a), float(b)


def targets(res: dict[str, dict[str, Run]], sizes: dict[str, int]) -> list[str]:
    out = []
    for cmd in ("fit", "diagnose"):
        ref = res.get("100k", {}).get(cmd)
        for label, row in res.items():
            r = row.get(cmd)
            if r is None or r.rc:
                continue
            n = sizes[label]
            cap = MEM_BASE + MEM_PER_SAMPLE * n
            ok = r.peak_bytes <= cap
            out.append(f"target {cmd} {label} peak <= 400 MB + 0.3 kB/sample "
                       f"({cap / MB:.0f} MB): {r.peak_bytes / MB:.0f} MB "
                       f"{'met' if ok else 'MISSED'}")
            if ref and not ref.rc and n > 100_000:
                per = (r.cpu_s - ref.cpu_s) / ((n - 100_000) / 1e5)
                out.append(f"target {cmd} {label} CPU <= {CPU_PER_100K} s per 100k beyond "
                           f"100k: {per:.2f} s {'met' if per <= CPU_PER_100K else 'MISSED'}")
    return out


def _busy(k: int) -> list[subprocess.Popen]:
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(k)]


def contention(repeat: int) -> dict[str, list[float]]:
    """The README's piezo diagnosis quiet / with two busy processes, 1 and 2 threads."""
    cases = {"quiet, 1 thread (default)": (0, []), "quiet, --threads 2": (0, ["--threads", "2"]),
             "2 busy, 1 thread (default)": (2, []), "2 busy, --threads 2": (2, ["--threads", "2"])}
    walls: dict[str, list[float]] = {k: [] for k in cases}
    measure(["diagnose", str(PIEZO), "--json", "-q"])  # warm the numba cache and the page cache
    for _ in range(repeat):
        for name, (busy, extra) in cases.items():
            hogs = _busy(busy)
            try:
                time.sleep(0.5 if busy else 0.0)
                r = measure(["diagnose", str(PIEZO), "--json", "-q", *extra])
            finally:
                for h in hogs:
                    h.kill()
                    h.wait()
            walls[name].append(r.wall_s)
            print(f"  {name:28s} wall {r.wall_s:6.1f} s  CPU {r.cpu_s:5.1f} s  exit {r.rc}",
                  flush=True)
    return walls


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="25k and 100k only")
    ap.add_argument("--sizes", help="comma list of sizes (25k,100k,1M,...)")
    ap.add_argument("--skip-fit", action="store_true", help="hyst diagnose only")
    ap.add_argument("--contention", action="store_true",
                    help="also: piezo diagnosis quiet vs two busy processes")
    ap.add_argument("--only-contention", action="store_true", help="the contention part only")
    ap.add_argument("--repeat", type=int, default=3, help="runs per contention case")
    ap.add_argument("--json", metavar="PATH", help="write the measurements as JSON")
    ap.add_argument("--keep", metavar="DIR", type=Path,
                    help="write (or reuse) the tiled CSV files in DIR instead of a temporary "
                         "folder")
    ap.add_argument("--huge", action="store_true", help="add 2M, 4M and 10M samples")
    ap.add_argument("--baseline", metavar="DIR", type=Path,
                    help="another checkout (the code before a change, e.g. from `git archive "
                         "REV | tar -x -C DIR`): its fit and diagnosis run too, each just "
                         "before the current one, and a before/after table is printed")
    args = ap.parse_args()
    every = {**SIZES, **HUGE}
    if args.sizes:
        sizes = {s: every.get(s) or int(float(s)) for s in args.sizes.split(",")}
    elif args.quick:
        sizes = {k: SIZES[k] for k in ("25k", "100k")}
    else:
        sizes = {**SIZES, **(HUGE if args.huge else {})}
    load0 = os.getloadavg()
    print(f"machine: {os.cpu_count()} CPUs, load average {load0[0]:.2f} / {load0[1]:.2f} / "
          f"{load0[2]:.2f} (1 / 5 / 15 min) at start", flush=True)
    doc: dict = {"load_start": load0}
    if not args.only_contention:
        if args.keep is not None:
            args.keep.mkdir(parents=True, exist_ok=True)
            res = scale(sizes, args.keep, args.skip_fit, args.baseline)
        else:
            with tempfile.TemporaryDirectory(prefix="hyst-scale-") as tmp:
                res = scale(sizes, Path(tmp), args.skip_fit, args.baseline)
        print("\n" + table(res, sizes) + "\n")
        if args.baseline is not None:
            print(before_after(res, sizes) + "\n")
        for cmd in ("fit", "diagnose"):
            m = memory_model(res, sizes, cmd)
            if m:
                print(f"memory model {cmd}: peak = {m[0] / MB:.0f} MB + {m[1] / 1e3:.3f} kB "
                      "per sample (least squares over the sizes from 100k)")
        for line in targets(res, sizes):
            print(line)
        doc["scale"] = {k: {c: asdict(r) for c, r in row.items()} for k, row in res.items()}
        doc["sizes"] = sizes
    if args.contention or args.only_contention:
        print("\nREADME piezo diagnosis (50,001 samples), median wall of "
              f"{args.repeat} interleaved runs:")
        walls = contention(args.repeat)
        med = {k: statistics.median(v) for k, v in walls.items()}
        quiet = med["quiet, 1 thread (default)"]
        for k, v in med.items():
            print(f"  {k:28s} {v:6.1f} s  = {v / quiet:.2f}x quiet default")
        ratio = med["2 busy, 1 thread (default)"] / quiet
        print(f"target busy <= 2x quiet (default threads): {ratio:.2f}x "
              f"{'met' if ratio <= 2.0 else 'MISSED'}")
        doc["contention"] = walls
    load1 = os.getloadavg()
    print(f"load average at end {load1[0]:.2f} / {load1[1]:.2f} / {load1[2]:.2f}")
    doc["load_end"] = load1
    if args.json:
        Path(args.json).write_text(json.dumps(doc, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
