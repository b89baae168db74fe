"""Concealed-effect benchmark of ``core.diagnosis`` (notes §7): per magnitude level and noise
model, top-1 accuracy, abstention, wrong confident names, gap closure, spurious claims, null
false positives, a per-effect table and the confusion matrices.

Usage::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnosis/run_benchmark.py \
        [--levels L1,L2,L3] [--seeds 3] [--nulls 12] [--noise white1,white2,coloured] \
        [--workers 2] [--scheduler local|tcp://HOST:PORT] [--json out.json]
    .venv/bin/python benchmarks/diagnosis/run_benchmark.py --rescore out.json   # tables only
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnosis/run_benchmark.py --quick
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnosis/run_benchmark.py \
        --classes all --seeds 3 --noise white1,coloured --json classes.json
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnosis/run_benchmark.py \
        --families [quick|all] --json families.json        # non-PI truth plants
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnosis/run_benchmark.py \
        --set dev|sealed|measured|all --workers 1 --json out.json \
        [--compare benchmarks/diagnosis/results/sealed-dev-*.json]  # issue 30 (sets.py)

Scoring (notes §7.2, §7.6):

* top-1: the first accepted effect equals the hidden one (the name, not just the family);
* a scenario whose *oracle* (the true effect structure with its true nonlinear parameters,
  fitted on the training rows) improves the held-out MSE by < 5 % is "not detectable": there,
  abstaining is correct and is counted as such;
* wrong confident name: the first accepted effect is not the hidden one and the engine did
  not report it as ambiguous with the hidden one;
* spurious claim: an accepted effect other than the hidden one (on a null: any claim, the
  false positive);
* gap closure ``GC = (RMSE_base - RMSE_final) / (RMSE_base - RMSE_oracle)`` on held-out rows
  (detectable runs); "do no harm" is GC >= -0.05.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from concurrent.futures import as_completed
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import numpy as np  # noqa: E402

from benchmarks.diagnosis.dask_runner import executor  # noqa: E402
from benchmarks.diagnosis.families import (  # noqa: E402
    jsonable,
    parameter_recovery,
    within_sigmas,
)
from benchmarks.diagnosis.generator import (  # noqa: E402
    EFFECTS,
    LEVEL_NAMES,
    PERIODIC_CLASSES,
    magnitude,
    make_periodic_set,
    make_scenario,
    scenario_id,
)
from benchmarks.diagnosis.oracle import oracle_rmse  # noqa: E402
from core.diagnosis import diagnose  # noqa: E402

DETECTABLE = 0.05  # oracle held-out MSE reduction (notes §7.2)
HARM = -0.05  # "do no harm" floor of the gap closure (notes §7.6)


def _r(x: float, nd: int = 4) -> float:
    return float(f"{x:.{nd}g}")


def _engine_version() -> str:
    """Commit of the engine the run used (``+dirty`` if ``core/`` has uncommitted edits)."""
    root = Path(__file__).resolve().parents[2]
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, text=True,
                              capture_output=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "core"], cwd=root,
                               text=True, capture_output=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+dirty" if dirty else "")


def run_one(args: tuple) -> dict:
    effect, noise, seed, level = (*args, "L2")[:4]  # (effect, noise, seed[, level])
    sc = make_scenario(effect, noise, seed, level=level)
    t0 = time.perf_counter()
    res = diagnose(sc.records)
    el = time.perf_counter() - t0
    base, oracle = oracle_rmse(sc.records, effect, len(res.final.structure.thresholds),
                               sc.params)
    b = res.heldout_rmse(res.baseline)
    f = res.heldout_rmse(res.final)
    found = [e.name for e in res.effects]
    claims = [{"name": e.name, "gain": _r(e.heldout.gain), "z": _r(e.heldout.z),
               "sign_p": _r(e.heldout.sign_p, 3),
               "params": {k: (_r(v) if isinstance(v, float) else v)
                          for k, v in e.parameters.items()
                          if isinstance(v, (int, float, str))},
               "ambiguous_with": list(e.ambiguous_with)} for e in res.effects]
    recovery = parameter_recovery(
        [{"name": e.name, "parameters": jsonable(e.parameters),
          "uncertainty": jsonable(e.uncertainty),
          "ambiguous_parameters": list(e.ambiguous_parameters)} for e in res.effects],
        {effect: sc.params} if effect else {})
    hidden_r1 = next(({"gain": _r(r["heldout_mse_reduction"]), "z": _r(r["dm_z"]),
                       "sign_p": _r(r["signed_rank_p"], 3), "passes": bool(r["passes"])}
                      for r in res.rounds if r.get("round") == 1 and r.get("effect") == effect),
                     None)
    return {
        "id": scenario_id(effect, level, noise, seed),
        "effect": effect or "null",
        "level": level if effect else "-",
        "noise": noise,
        "seed": seed,
        "params": {k: (list(v) if isinstance(v, tuple) else v) for k, v in sc.params.items()},
        "found": found,
        "top1": found[0] if found else "none",
        "ambiguous": [a["effects"] for a in res.ambiguous],
        "claims": claims,
        "hidden_round1": hidden_r1,
        "recovery": recovery,
        "n_operators": len(res.final.structure.thresholds),
        "rmse_base": b,
        "rmse_final": f,
        "rmse_oracle": oracle,
        "oracle_gain": 1 - oracle**2 / base**2 if effect else 0.0,
        "concealment_pct": sc.concealment_pct,
        "elapsed_s": el,
    }


def _stat(f, x) -> float:
    return float(f(x)) if len(x) else float("nan")


def _gc(r: dict) -> float | None:
    den = r["rmse_base"] - r["rmse_oracle"]
    return (r["rmse_base"] - r["rmse_final"]) / den if den > 0 else None


def _spurious(r: dict) -> list[str]:
    return [n for n in r["found"] if n != r["effect"]]


def _wrong_confident(r: dict) -> bool:
    if r["top1"] in ("none", r["effect"]):
        return False
    amb = r.get("claims", [{}])[0].get("ambiguous_with", []) if r.get("claims") else []
    return r["effect"] not in amb and not any(
        r["effect"] in a and r["top1"] in a for a in r.get("ambiguous", []))


def _named_or_ambiguous(r: dict) -> bool:
    """The hidden effect is named first, or the first name is flagged ambiguous with it."""
    return r["top1"] == r["effect"] or (r["top1"] != "none" and not _wrong_confident(r))


def _cell(rs: list[dict]) -> dict:
    """Scores of one group of effect runs."""
    det = [r for r in rs if r["oracle_gain"] >= DETECTABLE]
    und = [r for r in rs if r["oracle_gain"] < DETECTABLE]
    gcs = [g for g in map(_gc, det) if g is not None]
    return {
        "runs": len(rs),
        "detectable": len(det),
        "top1_ok": sum(r["top1"] == r["effect"] for r in det),
        "named_or_ambiguous": sum(map(_named_or_ambiguous, det)),
        "undetectable": len(und),
        "abstained": sum(not r["found"] for r in und),
        "claimed_hidden_undetectable": sum(r["top1"] == r["effect"] for r in und),
        "wrong_confident": sum(map(_wrong_confident, rs)),
        "gc_median": _stat(np.median, gcs),
        "gc_min": _stat(np.min, gcs),
        "harm": sum(g < HARM for g in gcs),
        "spurious_runs": sum(bool(_spurious(r)) for r in rs),
        "spurious_second": sum(bool(_spurious(r)) and r["effect"] in r["found"] for r in rs),
        "oracle_gain_median": _stat(np.median, [r["oracle_gain"] for r in rs]),
        "conceal_median": _stat(np.median, [r["concealment_pct"] for r in rs]),
    }


def _frac(a: int, b: int) -> str:
    return f"{a}/{b}" if b else "-"


def summarise(rows: list[dict]) -> str:  # noqa: C901 - a report script: one branch per printed column
    for r in rows:
        r.setdefault("level", "L2" if r["effect"] != "null" else "-")
    eff = [r for r in rows if r["effect"] != "null"]
    nulls = [r for r in rows if r["effect"] == "null"]
    levels = [lv for lv in LEVEL_NAMES if any(r["level"] == lv for r in eff)]
    noises = list(dict.fromkeys(r["noise"] for r in rows))
    lines = []
    labels = list(EFFECTS) + ["null"]
    cols = list(EFFECTS) + ["none"]
    w = 15
    for lv in levels + (["-"] if nulls else []):
        sub = [r for r in rows if r["level"] == lv]
        conf = {a: dict.fromkeys(cols, 0) for a in labels}
        for r in sub:
            conf[r["effect"]][r["top1"] if r["top1"] in cols else "none"] += 1
        title = f"level {lv}" if lv != "-" else "null scenarios"
        lines += [f"Confusion matrix, {title} (rows: hidden effect, columns: first effect named)",
                  " " * w + "".join(f"{c[:6]:>7}" for c in cols)]
        for a in labels:
            if sum(conf[a].values()):
                lines.append(f"{a:<{w}}" + "".join(f"{conf[a][c]:>7}" for c in cols))
        lines.append("")
    hdr = (f"{'level':<6}{'noise':<10}{'runs':>5}{'top1/det':>10}{'+amb':>6}{'abstain/undet':>15}"
           f"{'wrong conf':>11}{'GC med':>8}{'GC min':>8}{'harm':>5}{'spurious':>9}"
           f"{'2nd':>5}")
    lines += ["Per level and noise model (effect runs; det = oracle held-out gain >= 5 %; +amb:",
              "detectable runs named first or with the first name flagged ambiguous with it)", hdr]
    for lv in levels:
        for nz in noises + ["all"]:
            rs = [r for r in eff if r["level"] == lv and (nz == "all" or r["noise"] == nz)]
            if not rs:
                continue
            c = _cell(rs)
            lines.append(
                f"{lv:<6}{nz:<10}{c['runs']:>5}{_frac(c['top1_ok'], c['detectable']):>10}"
                f"{c['named_or_ambiguous']:>6}{_frac(c['abstained'], c['undetectable']):>15}"
                f"{c['wrong_confident']:>11}"
                f"{c['gc_median']:>8.3f}{c['gc_min']:>8.3f}{c['harm']:>5}"
                f"{c['spurious_runs']:>9}{c['spurious_second']:>5}")
    if nulls:
        lines += ["", "Null scenarios (any claim = false positive)",
                  f"{'noise':<10}{'runs':>5}{'claims':>8}  claimed effects"]
        for nz in noises:
            rs = [r for r in nulls if r["noise"] == nz]
            if rs:
                names = [n for r in rs for n in r["found"]]
                lines.append(f"{nz:<10}{len(rs):>5}{sum(bool(r['found']) for r in rs):>8}  "
                             + (", ".join(f"{n} x{names.count(n)}" for n in dict.fromkeys(names))
                                or "-"))
    lines += ["", "Per effect and level (all noise models pooled)",
              f"{'effect':<15}{'level':<6}{'runs':>5}{'top1/det':>10}{'+amb':>6}"
              f"{'abstain/undet':>15}"
              f"{'wrong conf':>11}{'spurious':>9}{'oracle gain':>12}{'GC med':>8}"
              f"{'GC min':>8}{'conceal %':>10}"]
    for e in EFFECTS:
        for lv in levels:
            rs = [r for r in eff if r["effect"] == e and r["level"] == lv]
            if not rs:
                continue
            c = _cell(rs)
            lines.append(
                f"{e:<15}{lv:<6}{c['runs']:>5}{_frac(c['top1_ok'], c['detectable']):>10}"
                f"{c['named_or_ambiguous']:>6}{_frac(c['abstained'], c['undetectable']):>15}"
                f"{c['wrong_confident']:>11}"
                f"{c['spurious_runs']:>9}{c['oracle_gain_median']:>12.3f}"
                f"{c['gc_median']:>8.3f}{c['gc_min']:>8.3f}{c['conceal_median']:>10.3f}")
    bad = [r for r in rows if _spurious(r) or (r["effect"] != "null" and (
        (r["oracle_gain"] >= DETECTABLE and r["top1"] != r["effect"])
        or (r["oracle_gain"] < DETECTABLE and r["found"])
        or ((_gc(r) or 0.0) < HARM and r["oracle_gain"] >= DETECTABLE)))]
    if bad:
        lines += ["", "Runs that are not clean (id, oracle gain, claims as name(held-out gain, z))"]
        for r in sorted(bad, key=lambda r: r["id"]):
            cl = ", ".join(f"{c['name']}({c['gain']:.3f}, z {c['z']:.1f})"
                           for c in r.get("claims", [])) or "none"
            g = _gc(r)
            lines.append(f"  {r.get('id', r['effect'])}: oracle {r['oracle_gain']:.3f}"
                         + (f", GC {g:.2f}" if g is not None and r["effect"] != "null" else "")
                         + f"; {cl}")
    rec = [(r, q) for r in eff for q in r.get("recovery", [])]
    if rec:
        lines += ["", "Parameter recovery (runs that found the hidden effect; rel. error of the "
                  "found parameter; within: |found - truth| <= reported 1-sigma, which a "
                  "calibrated sigma meets in 68 % of runs; 2-sigma: <= twice it, 95 %; "
                  "honest: within or said ambiguous)",
                  f"{'effect':<15}{'level':<6}{'quantity':<13}{'found':>6}{'truth':>11}"
                  f"{'median found':>14}{'med |rel err|':>15}{'max |rel err|':>15}"
                  f"{'within/sigma':>14}{'2-sigma':>9}{'honest':>9}"]
        keys = dict.fromkeys((r["effect"], r["level"], q["quantity"]) for r, q in rec)
        for e, lv, qn in sorted(keys, key=lambda k: (list(EFFECTS).index(k[0]), k[1], k[2])):
            qs = [q for r, q in rec if (r["effect"], r["level"], q["quantity"]) == (e, lv, qn)]
            errs = [abs(q["rel_err"]) for q in qs if q["rel_err"] is not None]
            sig = [q for q in qs if q["within"] is not None]
            lines.append(
                f"{e:<15}{lv:<6}{qn:<13}{len(qs):>6}{qs[0]['truth']:>11.4g}"
                f"{np.median([q['found'] for q in qs]):>14.4g}"
                f"{_stat(np.median, errs):>15.3f}{_stat(np.max, errs):>15.3f}"
                f"{_frac(sum(q['within'] for q in sig), len(sig)):>14}"
                f"{_frac(sum(bool(within_sigmas(q, 2.0)) for q in sig), len(sig)):>9}"
                f"{_frac(sum(bool(q.get('honest')) for q in qs), len(qs)):>9}")
    lines += ["", f"diagnosis time per scenario: median "
              f"{np.median([r['elapsed_s'] for r in rows]):.1f} s"]
    return "\n".join(lines)


def run_periodic(seeds: int, noises: tuple[float, ...] = (0.02, 0.1)) -> list[dict]:
    """Short periodic recordings at several frequencies (3 cycles x 40 samples each)."""
    rows = []
    for cls, (beta, freqs) in PERIODIC_CLASSES.items():
        for noise in noises:
            for seed in range(seeds):
                sc = make_periodic_set(beta, freqs=freqs, noise=noise, seed=200 + seed)
                t0 = time.perf_counter()
                res = diagnose(sc.records)
                row = next((r for r in res.rounds if r["round"] == 1 and r["effect"] == "rate"),
                           None)
                area = sc.extras["loop_area"]
                rows.append({
                    "class": cls, "noise": noise, "seed": 200 + seed,
                    "area_growth": area[-1] / area[0] - 1.0,
                    "found": [f.name for f in res.effects],
                    "suggestive": res.suggested_names,
                    "untestable": [u.name for u in res.untestable],
                    "ambiguous_with_rate": [a["effects"][0] for a in res.ambiguous
                                            if "rate" in a["effects"][1:]],
                    "rate_per_recording": None if row is None else [
                        p["mse_reduction"] for p in row.get("per_recording", [])],
                    "rate_loro_gain": None if row is None else row["heldout_mse_reduction"],
                    "rate_loro_z": None if row is None else row["dm_z"],
                    "elapsed_s": time.perf_counter() - t0})
                r = rows[-1]
                print(f"{cls:<34} noise={noise:<5} seed={r['seed']} found="
                      f"{','.join(r['found']) or '-':<12} suggestive="
                      f"{','.join(r['suggestive']) or '-':<8} rate-untestable="
                      f"{'rate' in r['untestable']} {r['elapsed_s']:.1f}s", flush=True)
    return rows


def summarise_periodic(rows: list[dict]) -> str:
    """Per-class table of the periodic runs: rate claimed / suggestive / untestable, others."""
    lines = ["| class | noise | runs | rate claimed | rate suggestive | rate untestable | "
             "other names (ambiguous with rate) | median s |", "|---|---|---|---|---|---|---|---|"]
    keys = sorted({(r["class"], r["noise"]) for r in rows},
                  key=lambda k: (list(PERIODIC_CLASSES).index(k[0]), k[1]))
    for cls, noise in keys:
        rs = [r for r in rows if r["class"] == cls and r["noise"] == noise]
        n = len(rs)
        other = sorted({e + (" (ambiguous)" if all(e in r["ambiguous_with_rate"] for r in rs
                                                  if e in r["found"]) else "")
                        for r in rs for e in r["found"] if e != "rate"})
        lines.append(
            f"| {cls} | {noise:g} | {n} | {sum('rate' in r['found'] for r in rs)}/{n} | "
            f"{sum('rate' in r['suggestive'] for r in rs)}/{n} | "
            f"{sum('rate' in r['untestable'] for r in rs)}/{n} | {', '.join(other) or '-'} | "
            f"{np.median([r['elapsed_s'] for r in rs]):.1f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:  # noqa: C901 - a script's argv handling, one branch per option
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="L2", help="comma-separated magnitude levels (L1,L2,L3)")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--first-round", type=int, default=0, metavar="K",
                    help="with --classes / --families: skip the first K seed rounds (add "
                         "seeds to an earlier run: --seeds 2 --first-round 1 runs only the "
                         "second seed)")
    ap.add_argument("--nulls", type=int, default=12, help="null scenarios per noise model")
    ap.add_argument("--noise", default="white1,coloured")
    ap.add_argument("--effects", default=",".join(EFFECTS))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                    help="run the scenarios on Dask: a scheduler address, or 'local' for a "
                         "LocalCluster of --workers processes (default: a process pool)")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--rescore", type=Path, help="print the tables of an earlier --json file")
    ap.add_argument("--periodic", type=int, metavar="SEEDS",
                    help="run only the short periodic recordings at several frequencies "
                         "(evidence between recordings), SEEDS per class and noise")
    ap.add_argument("--quick", action="store_true",
                    help="the quick subset of the issue-8 classes (two effects, weak effects, "
                         "single recording, short periodic recordings, loop shapes): a few "
                         "minutes")
    ap.add_argument("--cases", metavar="PATTERN",
                    help="with --classes or --set: only the cases whose name contains one of these "
                         "comma-separated strings (e.g. 'bouc-wen-1/,preisach/')")
    ap.add_argument("--families", nargs="?", const="quick", choices=("quick", "all"),
                    help="the non-PI base families (families.py: Bouc-Wen, Preisach, Duhem, "
                         "Maxwell-slip x hidden effects): the quick subset (default, a few "
                         "minutes) or all cases; with --seeds and --noise for 'all'")
    ap.add_argument("--classes", metavar="NAMES",
                    help="run the issue-8 classes (comma-separated names of "
                         "benchmarks/diagnosis/classes.py CLASSES, or 'all'); with --seeds "
                         "and --noise")
    ap.add_argument("--set", choices=("dev", "sealed", "measured", "dev-measured", "all"),
                    help="issue 30: the development subset, the sealed set (sealed.py: other "
                         "seeds, ranges, excitations, OpenSees plants, measured bases), its "
                         "measured-base class alone, or dev and sealed in one run, their "
                         "class tables side by side (sets.py); with --cases, --json")
    ap.add_argument("--compare", type=Path, nargs="+", metavar="JSON",
                    help="with --set or --rescore: earlier --set runs whose class tables are "
                         "printed beside this one's (same format)")
    a = ap.parse_args(argv)
    for path in [a.rescore, *(a.compare or [])]:
        if path is not None and not path.is_file():
            ap.error(f"{path}: no such file; earlier runs are in benchmarks/diagnosis/results/")
    if a.set or (a.rescore and _is_set_file(a.rescore)):
        return _run_set(a)
    if a.families:
        a.classes, a.quick = "non-PI base", a.families == "quick"
    if a.quick or a.classes:
        return _run_classes(a)
    if a.periodic:
        rows = run_periodic(a.periodic)
        print()
        print(summarise_periodic(rows))
        if a.json:
            a.json.write_text(json.dumps(rows, indent=1))
        return 0
    if a.rescore:
        print(summarise(json.loads(a.rescore.read_text())))
        return 0
    levels = a.levels.split(",")
    for lv in levels:
        magnitude(None, lv)  # validates
    # seed-major order, nulls spread over the seed rounds: an interrupted run still covers
    # every cell and has some nulls of every noise model
    jobs = []
    rounds = max(a.seeds, 1)
    per = -(-a.nulls // rounds)
    for s in range(rounds):
        for noise in a.noise.split(","):
            if s < a.seeds:
                for lv in levels:
                    for e in a.effects.split(","):
                        jobs.append((e, noise, 100 + s, lv))
            for k in range(s * per, min((s + 1) * per, a.nulls)):
                jobs.append((None, noise, 1000 + k, "L2"))
    partial = a.json.with_suffix(".partial.jsonl") if a.json else None

    def line(r: dict, done: int, elapsed: float) -> str:
        if partial:
            with partial.open("a") as fh:
                fh.write(json.dumps(r) + "\n")
        return (f"{r['id']:<32} found={','.join(r['found']) or '-':<30} "
                f"base={r['rmse_base']:.4f} final={r['rmse_final']:.4f} "
                f"oracle={r['rmse_oracle']:.4f} gain={r['oracle_gain']:.3f} "
                f"conceal={r['concealment_pct']:.3f}% {r['elapsed_s']:.0f}s "
                f"[{done}/{len(jobs)} {elapsed:.0f}s]")

    t0 = time.perf_counter()
    rows = _execute(a, run_one, jobs, line)
    order = {j: k for k, j in enumerate(jobs)}
    rows.sort(key=lambda r: order[(None if r["effect"] == "null" else r["effect"], r["noise"],
                                   r["seed"], "L2" if r["effect"] == "null" else r["level"])])
    print()
    print(summarise(rows))
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))
        if partial and partial.exists():
            partial.unlink()
    return 0


def _execute(a: argparse.Namespace, fn, jobs: list, line) -> list[dict]:
    """Run ``fn`` over ``jobs`` on the executor of ``--workers`` / ``--scheduler``, printing
    ``line(row, done, elapsed)`` as each finishes; rows carry the engine commit."""
    engine = _engine_version()
    print(f"{len(jobs)} runs, engine {engine}", flush=True)
    t0 = time.perf_counter()
    rows: list[dict] = []
    with executor(a.workers, a.scheduler) as ex:
        for fut in as_completed([ex.submit(fn, j) for j in jobs]):
            r = fut.result()
            r["engine"] = engine
            rows.append(r)
            print(line(r, len(rows), time.perf_counter() - t0), flush=True)
    return rows


def _is_set_file(path: Path) -> bool:
    rows = json.loads(path.read_text())
    return bool(rows) and isinstance(rows, list) and "set" in rows[0]


def _run_set(a: argparse.Namespace) -> int:
    """``--set dev|sealed|measured``: run the cases, print the class table and every run,
    then (``--compare``) the class tables of earlier runs beside this one."""
    from benchmarks.diagnosis.sets import SETS, run_case, side_by_side, summarise_set

    if a.rescore:
        rows = json.loads(a.rescore.read_text())
    else:
        todo = list(SETS[a.set]())
        if a.cases:
            pats = a.cases.split(",")
            todo = [c for c in todo if any(p in c for p in pats)]
        partial = a.json.with_suffix(".partial.jsonl") if a.json else None

        def line(r: dict, done: int, el: float) -> str:
            if partial:
                with partial.open("a") as fh:
                    fh.write(json.dumps(r) + "\n")
            return (f"{r['id']:<44} found={','.join(r['found']) or '-':<30} "
                    f"{r['elapsed_s']:.0f}s [{done}/{len(todo)} {el:.0f}s]")

        t0 = time.perf_counter()
        rows = _execute(a, run_case, todo, line)
        order = {c: k for k, c in enumerate(todo)}
        rows.sort(key=lambda r: order[r["id"]])
        print(f"\ntotal {time.perf_counter() - t0:.0f} s wall")
        if a.json:
            a.json.write_text(json.dumps(rows, indent=1))
            if partial and partial.exists():
                partial.unlink()
    print()
    print(summarise_set(rows))
    if a.compare:
        print("\nSide by side (same scores, same format)\n")
        print(side_by_side(*(json.loads(p.read_text()) for p in a.compare), rows))
    return 0


def _run_classes(a: argparse.Namespace) -> int:
    from benchmarks.diagnosis.classes import CLASSES, jobs, run_class_job, summarise_classes

    if a.rescore:
        print(summarise_classes(json.loads(a.rescore.read_text())))
        return 0
    names = None if a.classes in (None, "all") else tuple(a.classes.split(","))
    for n in names or ():
        if n not in CLASSES:
            raise SystemExit(f"unknown class {n!r}; known: {', '.join(CLASSES)}")
    todo = jobs(a.quick, seeds=1 if a.quick else a.seeds,
                noises=("white1",) if a.quick else tuple(a.noise.split(",")), classes=names,
                first=a.first_round)
    if a.cases:
        pats = a.cases.split(",")
        todo = [j for j in todo if any(p in j[1] for p in pats)]
    t0 = time.perf_counter()
    partial = a.json.with_suffix(".partial.jsonl") if a.json else None

    def line(r: dict, done: int, el: float) -> str:
        if partial:  # an interrupted run keeps its rows (--rescore reads a JSON list)
            with partial.open("a") as fh:
                fh.write(json.dumps(r) + "\n")
        return (f"{r['id']:<48} found={','.join(r['found']) or '-':<28} suggestive="
                f"{','.join(r['suggestive']) or '-':<12} {r['elapsed_s']:.0f}s "
                f"[{done}/{len(todo)} {el:.0f}s]")

    rows = _execute(a, run_class_job, todo, line)
    print()
    print(summarise_classes(rows))
    print(f"\ntotal {time.perf_counter() - t0:.0f} s (target: a few minutes for --quick)")
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))
        if partial and partial.exists():
            partial.unlink()
    return 0


if __name__ == "__main__":
    sys.exit(main())
