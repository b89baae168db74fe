"""Concealed-effect benchmark of ``core.diagnosis`` (notes §7): prints the confusion matrix,
top-1 accuracy, null false-positive rate and held-out gap closure.

Usage::

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/diagnosis/run_benchmark.py \
        [--seeds 3] [--nulls 12] [--noise white1,white2,coloured] [--workers 2] [--json out.json]

Scoring (notes §7.2, §7.6):

* top-1: the first accepted effect equals the hidden one (the name, not just the family);
* a scenario whose *oracle* (the true effect structure with its true nonlinear parameters,
  fitted on the training rows) improves the held-out MSE by < 5 % is "not detectable": there,
  abstaining is correct and is counted as such;
* false positive: any effect claimed on a null scenario;
* gap closure ``GC = (RMSE_base - RMSE_final) / (RMSE_base - RMSE_oracle)`` on held-out rows.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import numpy as np  # noqa: E402

from benchmarks.diagnosis.generator import EFFECTS, LEVELS, make_scenario  # noqa: E402
from core.diagnosis import diagnose  # noqa: E402
from core.diagnosis.data import split_masks  # noqa: E402
from core.diagnosis.structure import Structure, fit_structure, place_thresholds  # noqa: E402


def oracle_rmse(records, effect: str | None, n_ops: int) -> tuple[float, float]:
    """Held-out RMSE of the baseline structure and of the true-effect structure."""
    tr, te, _ = split_masks(records)
    r = place_thresholds(records, tr, n_ops)
    base = Structure(tuple(float(x) for x in r), tuple(() for _ in records))
    lv = LEVELS.get(effect or "", {})
    s = base
    if effect in ("delay", "lag"):
        s = base.with_(dynamics=(effect, next(iter(lv.values()))))
    elif effect == "resonance":
        s = base.with_(dynamics=("resonance", lv["freq_hz"], lv["damping"]))
    elif effect == "rate":
        s = base.with_(beta_s=lv["beta_s"])
    elif effect == "creep":
        s = base.with_(creep_taus=(0.01, 0.1, 1.0, 10.0, 100.0))
    elif effect == "drift":
        s = base.with_(drift_degree=4)
    elif effect == "asymmetry":
        s = base.with_(asymmetry=True)
    elif effect == "offset":
        s = base.with_(offsets=True)
    elif effect == "initial-memory":
        s = base.with_(history=(tuple(lv["history"]),) + tuple(() for _ in records[1:]))

    def rmse(st):
        f = fit_structure(st, records, tr)
        e = np.concatenate([(rec.y - p)[m] for rec, p, m in zip(records, f.pred, te,
                                                                strict=True)])
        return float(np.sqrt(np.mean(e * e)))

    b = rmse(base)
    return b, (rmse(s) if effect else b)


def run_one(args: tuple[str | None, str, int]) -> dict:
    effect, noise, seed = args
    sc = make_scenario(effect, noise, seed)
    t0 = time.perf_counter()
    res = diagnose(sc.records)
    el = time.perf_counter() - t0
    base, oracle = oracle_rmse(sc.records, effect, len(res.final.structure.thresholds))
    b = res.heldout_rmse(res.baseline)
    f = res.heldout_rmse(res.final)
    found = [e.name for e in res.effects]
    return {
        "effect": effect or "null",
        "noise": noise,
        "seed": seed,
        "found": found,
        "top1": found[0] if found else "none",
        "ambiguous": [a["effects"] for a in res.ambiguous],
        "rmse_base": b,
        "rmse_final": f,
        "rmse_oracle": oracle,
        "oracle_gain": 1 - oracle**2 / base**2 if effect else 0.0,
        "concealment_pct": sc.concealment_pct,
        "elapsed_s": el,
    }


def _stat(f, x) -> float:
    return float(f(x)) if len(x) else float("nan")


def summarise(rows: list[dict]) -> str:
    labels = list(EFFECTS) + ["null"]
    cols = list(EFFECTS) + ["none"]
    conf = {a: dict.fromkeys(cols, 0) for a in labels}
    for r in rows:
        conf[r["effect"]][r["top1"] if r["top1"] in cols else "none"] += 1
    w = 15
    lines = ["Confusion matrix (rows: hidden effect, columns: first effect named)",
             " " * w + "".join(f"{c[:6]:>7}" for c in cols)]
    for a in labels:
        lines.append(f"{a:<{w}}" + "".join(f"{conf[a][c]:>7}" for c in cols))
    eff = [r for r in rows if r["effect"] != "null"]
    det = [r for r in eff if r["oracle_gain"] >= 0.05]
    ok = [r for r in det if r["top1"] == r["effect"]]
    abst = [r for r in eff if r["oracle_gain"] < 0.05]
    abst_ok = [r for r in abst if r["top1"] == "none"]
    nulls = [r for r in rows if r["effect"] == "null"]
    fp = [r for r in nulls if r["found"]]
    gcs = []
    for r in det:
        den = r["rmse_base"] - r["rmse_oracle"]
        if den > 0:
            gcs.append((r["rmse_base"] - r["rmse_final"]) / den)
    lines += [
        "",
        f"runs: {len(rows)} ({len(eff)} with a hidden effect, {len(nulls)} null)",
        f"detectable (oracle held-out gain >= 5 %): {len(det)}; not detectable: {len(abst)} "
        f"(correct abstentions {len(abst_ok)}/{len(abst)})",
        f"top-1 accuracy on detectable concealed single effects: {len(ok)}/{len(det)} = "
        f"{100 * len(ok) / max(len(det), 1):.1f} %",
        f"false-positive rate on null scenarios: {len(fp)}/{len(nulls)} = "
        f"{100 * len(fp) / max(len(nulls), 1):.1f} %",
        f"held-out gap closure (detectable runs): median {_stat(np.median, gcs):.3f}, "
        f"mean {_stat(np.mean, gcs):.3f}, min {_stat(np.min, gcs):.3f}",
        f"concealment (max |effect| on the 1-10 Hz loops, % of stroke): median "
        f"{np.median([r['concealment_pct'] for r in eff]):.3f}, max "
        f"{np.max([r['concealment_pct'] for r in eff]):.3f}",
        f"diagnosis time per scenario: median {np.median([r['elapsed_s'] for r in rows]):.1f} s",
    ]
    per = {}
    for r in eff:
        per.setdefault(r["effect"], []).append(r)
    lines.append("")
    lines.append(f"{'effect':<15}{'runs':>5}{'top1 ok':>8}{'oracle gain':>12}{'GC':>8}"
                 f"{'conceal %':>10}")
    for e, rs in per.items():
        g = [(x["rmse_base"] - x["rmse_final"]) / (x["rmse_base"] - x["rmse_oracle"])
             for x in rs if x["rmse_base"] > x["rmse_oracle"]]
        lines.append(f"{e:<15}{len(rs):>5}{sum(x['top1'] == e for x in rs):>8}"
                     f"{np.mean([x['oracle_gain'] for x in rs]):>12.3f}"
                     f"{np.mean(g) if g else float('nan'):>8.2f}"
                     f"{np.mean([x['concealment_pct'] for x in rs]):>10.3f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--nulls", type=int, default=12, help="null scenarios per noise model")
    ap.add_argument("--noise", default="white1,coloured")
    ap.add_argument("--effects", default=",".join(EFFECTS))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", type=Path)
    a = ap.parse_args(argv)
    jobs = []
    for noise in a.noise.split(","):
        for e in a.effects.split(","):
            for s in range(a.seeds):
                jobs.append((e, noise, 100 + s))
        for s in range(a.nulls):
            jobs.append((None, noise, 1000 + s))
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=a.workers) as ex:
        rows = list(ex.map(run_one, jobs))
    for r in rows:
        found = ",".join(r["found"]) or "-"
        print(f"{r['effect']:<15}{r['noise']:<10}{r['seed']:>5}  found={found:<30}"
              f" base={r['rmse_base']:.4f} final={r['rmse_final']:.4f}"
              f" oracle={r['rmse_oracle']:.4f} conceal={r['concealment_pct']:.3f}%")
    print()
    print(summarise(rows))
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
