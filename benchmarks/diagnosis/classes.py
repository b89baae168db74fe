"""Issue-8 benchmark classes of the diagnosis: two effects at once, weak effects,
single-recording users (a staircase with holds, a single closed loop), short periodic
recordings at several frequencies and at several amplitudes, loop shapes.

Each run is one scenario of :mod:`benchmarks.diagnosis.generator` diagnosed with the default
settings (``diagnose(records)``: interleaved train/test blocks). Scores per class
(:func:`summarise_classes`):

* **top-1**: the first accepted effect is one of the hidden ones;
* **all**: every hidden effect is accepted (the two-effect class);
* **abstain**: nothing accepted; **suggestive**: a hidden effect listed as suggestive
  (improved the held-out fit, failed the significance rule; not claimed);
* **wrong name**: an accepted effect that is not hidden and is not reported ambiguous with a
  hidden one (the failure of the weak class: abstaining is right there, a wrong name is not);
* **spurious**: any accepted effect that is not hidden (ambiguous or not);
* **GC**: held-out gap closure against the oracle (true structure, true nonlinear
  parameters) where the oracle can be built (not for the loop-shape maps).

Loop-shape scenarios expect the names ``saturation`` / ``dead-zone`` (effect candidates added
on another branch): until those exist the class scores misses, and the adequacy verdict
(``adequate`` False: the residual stays above the noise floor) is the other thing checked.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from benchmarks.diagnosis.generator import (
    COMBOS,
    SHAPES,
    Scenario,
    make_amplitude_set,
    make_closed_loop,
    make_combo,
    make_periodic_set,
    make_shape,
    make_single_staircase,
    make_weak,
)
from benchmarks.diagnosis.run_benchmark import PERIODIC_CLASSES

__all__ = ["CLASSES", "jobs", "run_class_job", "summarise_classes"]

#: Short periodic recordings: case -> (beta_s, frequencies); 3 cycles x 40 samples each.
PERIODIC_CASES = PERIODIC_CLASSES

#: Class -> cases (the quick subset is the first entries of each, see :func:`jobs`).
CLASSES: dict[str, tuple[str, ...]] = {
    "two effects": tuple("+".join(c) for c in COMBOS),
    "weak": ("rate", "delay", "creep", "asymmetry", "lag", "resonance", "drift",
             "initial-memory"),
    "single recording": ("null", "creep", "closed loop"),
    "periodic": tuple(PERIODIC_CASES),
    "amplitudes": ("null, 4 amplitudes", "asymmetry, 4 amplitudes"),
    "loop shape": tuple(SHAPES),
}

#: Cases of the ``--quick`` subset (a few minutes on 2 cores).
QUICK: dict[str, tuple[str, ...]] = {
    "two effects": CLASSES["two effects"],
    "weak": ("rate", "delay", "creep", "asymmetry"),
    "single recording": ("null", "creep"),
    "periodic": ("null (PI, 4 frequencies)", "weaker rate (loop area +3 %)",
                 "rate (loop area +2/3)"),
    "amplitudes": ("asymmetry, 4 amplitudes",),
    "loop shape": tuple(SHAPES),
}


def jobs(quick: bool, seeds: int = 1, noises: tuple[str, ...] = ("white1",),
         classes: tuple[str, ...] | None = None) -> list[tuple[str, str, str, int]]:
    """``(class, case, noise, seed)`` of every run; periodic noise ``white1`` is 0.02 um,
    ``white2`` and ``coloured`` 0.1 um (its generator has white noise only)."""
    table = QUICK if quick else CLASSES
    out = []
    for s in range(seeds):
        for cls, cases in table.items():
            if classes and cls not in classes:
                continue
            for case in cases:
                for nz in noises:
                    out.append((cls, case, nz, (200 if cls == "periodic" else
                                                300 if cls == "amplitudes" else
                                                0 if cls == "single recording" else 100) + s))
    return out


def _scenario(cls: str, case: str, noise: str, seed: int) -> Scenario:
    if cls == "two effects":
        return make_combo(tuple(case.split("+")), noise, seed)
    if cls == "weak":
        return make_weak(case, noise, seed)
    if cls == "single recording" and case == "closed loop":
        return make_closed_loop(noise, seed)
    if cls == "single recording":
        return make_single_staircase(None if case == "null" else case, noise, seed)
    if cls == "amplitudes":
        return make_amplitude_set(None if case.startswith("null") else 0.9,
                                  noise=0.02 if noise == "white1" else 0.1, seed=seed)
    if cls == "periodic":
        beta, freqs = PERIODIC_CASES[case]
        return make_periodic_set(beta, freqs=freqs, noise=0.02 if noise == "white1" else 0.1,
                                 seed=seed)
    if cls == "loop shape":
        return make_shape(case, noise, seed)
    raise ValueError(f"unknown class {cls!r}")


def _hidden(cls: str, case: str, sc: Scenario) -> dict[str, dict[str, Any]]:
    if cls == "periodic":
        return {"rate": dict(sc.params)} if sc.params else {}
    if cls == "amplitudes":
        return {"asymmetry": dict(sc.params)} if sc.params else {}
    return dict(sc.extras.get("hidden", {}))


def run_class_job(job: tuple[str, str, str, int]) -> dict[str, Any]:
    """Diagnose one class scenario and return its JSON row."""
    from benchmarks.diagnosis.run_benchmark import oracle_rmse
    from core.diagnosis import diagnose

    cls, case, noise, seed = job
    sc = _scenario(cls, case, noise, seed)
    hidden = _hidden(cls, case, sc)
    t0 = time.perf_counter()
    res = diagnose(sc.records)
    el = time.perf_counter() - t0
    n_ops = len(res.final.structure.thresholds)
    base, oracle = oracle_rmse(sc.records, None, n_ops, hidden=hidden)
    b, f = res.heldout_rmse(res.baseline), res.heldout_rmse(res.final)
    found = [e.name for e in res.effects]
    return {
        "class": cls, "case": case, "noise": noise, "seed": seed,
        "id": f"{cls}/{case}/{noise}/{seed}",
        "hidden": list(hidden),
        "found": found,
        "claims": [{"name": e.name, "gain": float(e.heldout.gain), "z": float(e.heldout.z),
                    "sign_p": float(e.heldout.sign_p), "ambiguous_with": list(e.ambiguous_with)}
                   for e in res.effects],
        "suggestive": [g["effect"] for g in res.suggestive],
        "ambiguous": [list(a["effects"]) for a in res.ambiguous],
        "untestable": [u["name"] for u in res.untestable],
        "adequate": None if res.adequacy is None else bool(res.adequacy.adequate),
        "residual_pct": None if res.adequacy is None else float(res.adequacy.pct),
        "rmse_base": b, "rmse_final": f,
        "rmse_oracle": oracle if oracle != base else None,
        "oracle_gain": (1 - oracle**2 / base**2) if oracle != base else None,
        "extras": {k: v for k, v in sc.extras.items() if k != "hidden"},
        "elapsed_s": el,
    }


# ----------------------------------------------------------------------------- scoring
def _amb_with_hidden(r: dict[str, Any], name: str) -> bool:
    hid = set(r["hidden"])
    cl = next((c for c in r["claims"] if c["name"] == name), {})
    return bool(hid & set(cl.get("ambiguous_with", []))) or any(
        name in a and hid & set(a) for a in r["ambiguous"])


def wrong_names(r: dict[str, Any]) -> list[str]:
    """Accepted effects that are not hidden and not reported ambiguous with a hidden one."""
    return [n for n in r["found"] if n not in r["hidden"] and not _amb_with_hidden(r, n)]


def spurious(r: dict[str, Any]) -> list[str]:
    """Accepted effects that are not hidden."""
    return [n for n in r["found"] if n not in r["hidden"]]


def gap_closure(r: dict[str, Any]) -> float | None:
    if r.get("rmse_oracle") is None or not r["hidden"]:
        return None
    den = r["rmse_base"] - r["rmse_oracle"]
    return (r["rmse_base"] - r["rmse_final"]) / den if den > 0 else None


def summarise_classes(rows: list[dict[str, Any]]) -> str:
    """Markdown table per (class, case, noise) plus a line per run that is not clean."""
    lines = ["| class | case | noise | runs | top-1 | all hidden | abstain | suggestive | "
             "wrong name | spurious | GC median | inadequate | median s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    order = {c: k for k, c in enumerate(CLASSES)}
    keys = sorted({(r["class"], r["case"], r["noise"]) for r in rows},
                  key=lambda k: (order.get(k[0], 99), CLASSES.get(k[0], ()).index(k[1])
                                 if k[1] in CLASSES.get(k[0], ()) else 99, k[2]))
    for cls, case, nz in keys:
        rs = [r for r in rows if (r["class"], r["case"], r["noise"]) == (cls, case, nz)]
        n = len(rs)
        hid = bool(rs[0]["hidden"])
        gcs = [g for g in map(gap_closure, rs) if g is not None]

        def frac(k: int, n: int = n) -> str:
            return f"{k}/{n}"

        lines.append(
            f"| {cls} | {case} | {nz} | {n} | "
            + (frac(sum(bool(r["found"]) and r["found"][0] in r["hidden"] for r in rs))
               if hid else "-") + " | "
            + (frac(sum(set(r["hidden"]) <= set(r["found"]) for r in rs)) if hid else "-")
            + f" | {frac(sum(not r['found'] for r in rs))} | "
            + (frac(sum(bool(set(r["suggestive"]) & set(r["hidden"])) for r in rs)) if hid
               else "-") + " | "
            + f"{frac(sum(bool(wrong_names(r)) for r in rs))} | "
            + f"{frac(sum(bool(spurious(r)) for r in rs))} | "
            + (f"{np.median(gcs):.2f}" if gcs else "-") + " | "
            + frac(sum(r["adequate"] is False for r in rs))
            + f" | {np.median([r['elapsed_s'] for r in rs]):.1f} |")
    bad = [r for r in rows if spurious(r) or (r["hidden"] and r["class"] not in ("weak",) and
                                              not set(r["hidden"]) <= set(r["found"]))]
    if bad:
        lines += ["", "Runs that are not clean (id: hidden -> found; wrong names)"]
        for r in sorted(bad, key=lambda r: r["id"]):
            cl = ", ".join(f"{c['name']}({c['gain']:.3f}, z {c['z']:.1f}"
                           + (f", amb {'/'.join(c['ambiguous_with'])}" if c["ambiguous_with"]
                              else "") + ")" for c in r["claims"]) or "none"
            lines.append(f"  {r['id']}: {'+'.join(r['hidden']) or 'none'} -> {cl}"
                         + (f"; wrong: {', '.join(wrong_names(r))}" if wrong_names(r) else "")
                         + (f"; suggestive: {', '.join(r['suggestive'])}" if r["suggestive"]
                            else ""))
    return "\n".join(lines)

