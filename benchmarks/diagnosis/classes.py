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

The ``non-PI base`` class (:mod:`benchmarks.diagnosis.families`: Bouc-Wen, Preisach with a
bias-dependent density, Duhem, Maxwell-slip, each with one hidden effect or none) runs only
when asked for (``--families`` or ``--classes "non-PI base"``), not in the plain ``--quick``
run. There a wrong name is an accepted dynamic/time effect that is not hidden (delay, lag,
resonance, rate, creep, drift, offset, initial-memory); a loop-shape or memory name is the
base-class difference. Every run also scores the **parameter recovery** of the hidden
effects it found (``row["recovery"]``: found vs truth, reported 1-sigma, relative error).

The ``three effects`` class hides three effects at once (:data:`TRIPLES`, each at its L2 /
"large" size) on the B-PI plant (``creep+resonance+asymmetry``) and on non-PI bases
(``bouc-wen-1/creep+resonance+asymmetry``); the ``eighth`` class hides a delay, lag or
resonance at an eighth of the non-PI "large" size (``bouc-wen-1/delay/eighth``). Both are
scored per hidden effect (:func:`lookalike_verdict`): **named**, **flagged** (not named, but
a look-alike named and reported ambiguous with it), **missed**; a run with a **wrong** name
(not hidden, not flagged ambiguous with a hidden effect; on a non-PI base only
dynamic/time names count) is the failure. Parameter recovery there: delay and lag within
25 %, resonance frequency within 10 % of the truth (:data:`RECOVERY_TOLERANCE`).

Loop-shape scenarios expect the names ``saturation`` / ``dead-zone`` (effect candidates added
on another branch): until those exist the class scores misses, and the adequacy verdict
(``adequate`` False: the residual stays above the noise floor) is the other thing checked.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from benchmarks.diagnosis.families import (
    BASES,
    FAMILY_EFFECTS,
    RATE_BASES,
    jsonable,
    make_family,
    parameter_recovery,
    within_sigmas,
    wrong_names_base,
)
from benchmarks.diagnosis.generator import (
    COMBOS,
    PERIODIC_CLASSES,
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

__all__ = ["CLASSES", "EIGHTH_CASES", "FAMILY_CASES", "FAMILY_CLASS", "RECOVERY_TOLERANCE",
           "TRIPLES", "TRIPLE_CASES", "family_matrix", "honesty_table", "jobs", "lookalike_verdict",
           "recovery_table", "run_class_job", "summarise_classes", "summarise_families",
           "summarise_lookalikes"]

#: Short periodic recordings: case -> (beta_s, frequencies); 3 cycles x 40 samples each.
PERIODIC_CASES = PERIODIC_CLASSES

#: Non-PI base families (``families.py``): ``base/effect/size`` (nulls ``base/null``).
FAMILY_CASES: tuple[str, ...] = tuple(
    f"{b}/null" for b in BASES) + tuple(
    f"{b}/{e}/{sz}" for sz in ("large", "small") for b in BASES for e in FAMILY_EFFECTS
    if e != "rate" or b in RATE_BASES)
#: White noise of the family scenarios per noise name (fraction of the 100 um stroke).
FAMILY_NOISE = {"white1": 0.002, "white2": 0.003, "coloured": 0.002}
#: Class of the non-PI bases: nulls there may name a loop shape or memory, not a time effect.
FAMILY_CLASS = "non-PI base"

#: Three hidden effects at once (issue 16 item 5: a look-alike under a third effect).
TRIPLES: tuple[tuple[str, str, str], ...] = (
    ("creep", "resonance", "asymmetry"), ("delay", "creep", "drift"),
    ("lag", "resonance", "offset"),
)
#: Non-PI bases of the three-effect class (besides the B-PI plant).
TRIPLE_BASES = ("bouc-wen-1", "maxwell-slip")
TRIPLE_CASES: tuple[str, ...] = tuple("+".join(c) for c in TRIPLES) + tuple(
    f"{b}/{'+'.join(c)}" for b in TRIPLE_BASES for c in TRIPLES)
#: An eighth of the "large" delay, lag and resonance on every non-PI base.
EIGHTH_CASES: tuple[str, ...] = tuple(
    f"{b}/{e}/eighth" for e in ("delay", "lag", "resonance") for b in BASES)
#: Largest relative error of a recovered parameter that counts as recovered (issue 16).
RECOVERY_TOLERANCE = {"delay_s": 0.25, "tau_s": 0.25, "freq_hz": 0.10}
#: Classes scored by :func:`lookalike_verdict` (named / flagged / missed / wrong).
LOOKALIKE_CLASSES = ("three effects", "eighth")

#: Class -> cases (the quick subset is the first entries of each, see :func:`jobs`).
CLASSES: dict[str, tuple[str, ...]] = {
    "two effects": tuple("+".join(c) for c in COMBOS),
    "weak": ("rate", "delay", "creep", "asymmetry", "lag", "resonance", "drift",
             "initial-memory"),
    "single recording": ("null", "creep", "closed loop"),
    "periodic": tuple(PERIODIC_CASES),
    "amplitudes": ("null, 4 amplitudes", "asymmetry, 4 amplitudes"),
    "loop shape": tuple(SHAPES),
    FAMILY_CLASS: FAMILY_CASES,
    "three effects": TRIPLE_CASES,
    "eighth": EIGHTH_CASES,
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
    # only with --families / --classes "non-PI base" (not part of the plain --quick run)
    FAMILY_CLASS: tuple(f"{b}/null" for b in BASES) + (
        "preisach/creep/large", "preisach/delay/large", "preisach/resonance/large",
        "preisach/rate/large", "bouc-wen-1/creep/large", "bouc-wen-1/delay/large",
        "bouc-wen-1/resonance/large", "bouc-wen-2/creep/large", "bouc-wen-3/lag/large",
        "duhem/creep/large", "duhem/resonance/large", "duhem/lag/large", "duhem/drift/large",
        "maxwell-slip/creep/large", "maxwell-slip/delay/large", "maxwell-slip/resonance/large",
        "maxwell-slip/drift/large", "preisach/lag/large", "preisach/drift/large",
        "bouc-wen-1/creep/small", "bouc-wen-1/delay/small", "preisach/delay/small"),
    # only with --classes "three effects" / "eighth" (each a few minutes per run when loaded)
    "three effects": TRIPLE_CASES,
    "eighth": EIGHTH_CASES,
}

#: Classes that run only when named in ``--classes`` (not in the plain ``--quick`` run).
ON_REQUEST = (FAMILY_CLASS, "three effects", "eighth")


def jobs(quick: bool, seeds: int = 1, noises: tuple[str, ...] = ("white1",),
         classes: tuple[str, ...] | None = None, first: int = 0
         ) -> list[tuple[str, str, str, int]]:
    """``(class, case, noise, seed)`` of every run; periodic noise ``white1`` is 0.02 um,
    ``white2`` and ``coloured`` 0.1 um (its generator has white noise only). Seed rounds
    ``first`` to ``seeds - 1`` (a round adds its number to each class's base seed), so a later
    run can add seeds to an earlier one."""
    table = QUICK if quick else CLASSES
    out = []
    for s in range(first, seeds):
        for cls, cases in table.items():
            if classes and cls not in classes:
                continue
            if cls in ON_REQUEST and not classes:
                continue  # the non-PI classes run only when asked for
            for case in cases:
                for nz in noises:
                    out.append((cls, case, nz, (200 if cls == "periodic" else
                                                300 if cls == "amplitudes" else
                                                0 if cls == "single recording" else
                                                500 if cls in (FAMILY_CLASS, "eighth")
                                                or "/" in case else 100) + s))
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
    if cls in (FAMILY_CLASS, "eighth") or (cls == "three effects" and "/" in case):
        base, effect, size = (*case.split("/"), "large")[:3]
        return make_family(base, effect, size, FAMILY_NOISE[noise], seed)
    if cls == "three effects":
        return make_combo(tuple(case.split("+")), noise, seed)
    raise ValueError(f"unknown class {cls!r}")


def _hidden(cls: str, case: str, sc: Scenario) -> dict[str, dict[str, Any]]:
    if cls == "periodic":
        return {"rate": dict(sc.params)} if sc.params else {}
    if cls == "amplitudes":
        return {"asymmetry": dict(sc.params)} if sc.params else {}
    return dict(sc.extras.get("hidden", {}))


def run_class_job(job: tuple[str, str, str, int]) -> dict[str, Any]:
    """Diagnose one class scenario and return its JSON row."""
    from benchmarks.diagnosis.oracle import oracle_rmse
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
    claims = [{"name": e.name, "gain": float(e.heldout.gain), "z": float(e.heldout.z),
               "sign_p": float(e.heldout.sign_p), "ambiguous_with": list(e.ambiguous_with),
               "parameters": jsonable(e.parameters), "uncertainty": jsonable(e.uncertainty),
               "ambiguous_parameters": list(e.ambiguous_parameters)}
              for e in res.effects]
    return {
        "class": cls, "case": case, "noise": noise, "seed": seed,
        "id": f"{cls}/{case}/{noise}/{seed}",
        "hidden": list(hidden),
        "found": found,
        "claims": claims,
        "recovery": parameter_recovery(claims, hidden),
        "suggestive": res.suggested_names,
        "recording_specific": [
            {"name": r.name, "loro_mse_reduction": r.loro_mse_reduction,
             "per_recording": jsonable(list(r.per_recording))}
            for r in res.recording_specific],
        "ambiguous": [list(a["effects"]) for a in res.ambiguous],
        "untestable": [u.name for u in res.untestable],
        "adequate": None if res.adequacy is None else bool(res.adequacy.adequate),
        "residual_pct": None if res.adequacy is None else float(res.adequacy.pct),
        "rmse_base": b, "rmse_final": f,
        "rmse_oracle": oracle if oracle != base else None,
        "oracle_gain": (1 - oracle**2 / base**2) if oracle != base else None,
        "extras": jsonable({k: v for k, v in sc.extras.items() if k != "hidden"}),
        "truth": jsonable(hidden),
        "elapsed_s": el,
    }


# ----------------------------------------------------------------------------- scoring
def _amb_with_hidden(r: dict[str, Any], name: str) -> bool:
    hid = set(r["hidden"])
    cl = next((c for c in r["claims"] if c["name"] == name), {})
    return bool(hid & set(cl.get("ambiguous_with", []))) or any(
        name in a and hid & set(a) for a in r["ambiguous"])


def named_first(r: dict[str, Any]) -> bool:
    """Whether the first effect the run names is a hidden one (top-1)."""
    return bool(r["found"]) and r["found"][0] in r["hidden"]


def wrong_names(r: dict[str, Any]) -> list[str]:
    """Accepted effects that are not hidden and not reported ambiguous with a hidden one; on
    a non-PI base only dynamic/time effects count (a loop-shape or memory name is the base
    difference, :func:`~benchmarks.diagnosis.families.wrong_names_base`)."""
    if r["class"] == FAMILY_CLASS or (r.get("extras") or {}).get("base"):
        return wrong_names_base(r["found"], r["hidden"], lambda n: _amb_with_hidden(r, n))
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
            + (frac(sum(named_first(r) for r in rs))
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
    fam = [r for r in rows if r["class"] == FAMILY_CLASS]
    if fam:
        lines += ["", summarise_families(fam), "", family_matrix(fam), "",
                  "How the reported sigmas cover the truth (non-PI bases)", "",
                  honesty_table(fam)]
    look = [r for r in rows if r["class"] in LOOKALIKE_CLASSES]
    if look:
        lines += ["", summarise_lookalikes(look)]
    rec = recovery_table(rows)
    if rec:
        lines += ["", rec]
    return "\n".join(lines)


def lookalike_verdict(r: dict[str, Any]) -> tuple[str, dict[str, str]]:
    """``(run verdict, {hidden effect: verdict})`` of a run of the look-alike classes.

    Per hidden effect: ``named`` (accepted), ``flagged`` (not accepted, but an accepted
    effect is reported ambiguous with it, in its claim or in the ambiguity groups),
    ``missed``. The run: ``wrong`` if any accepted name is wrong (:func:`wrong_names`),
    else the worst of its effects (named < flagged < missed).
    """
    found = set(r["found"])
    per = {}
    for h in r["hidden"]:
        if h in found:
            per[h] = "named"
        elif any(h in c["ambiguous_with"] for c in r["claims"]) or any(
                h in a and found & set(a) for a in r["ambiguous"]):
            per[h] = "flagged"
        else:
            per[h] = "missed"
    if wrong_names(r):
        return "wrong", per
    rank = ("named", "flagged", "missed")
    return (max(per.values(), key=rank.index) if per else "named"), per


def summarise_lookalikes(rows: list[dict[str, Any]]) -> str:
    """Per-run table of the three-effect and eighth classes: named effects (first to last,
    with their ambiguity flags), the verdict per hidden effect, the recovered delay / lag /
    resonance frequency against :data:`RECOVERY_TOLERANCE`, and the totals."""
    lines = ["| class | case | noise | named (first to last) | verdict | per effect | "
             "params found vs truth | s |", "|---|---|---|---|---|---|---|---|"]
    tally: dict[str, int] = {}
    rec_ok = rec_n = 0
    order = {c: k for k, c in enumerate(CLASSES)}
    for r in sorted(rows, key=lambda r: (order.get(r["class"], 99),
                                         CLASSES[r["class"]].index(r["case"])
                                         if r["case"] in CLASSES.get(r["class"], ()) else 999,
                                         r["noise"])):
        verdict, per = lookalike_verdict(r)
        tally[verdict] = tally.get(verdict, 0) + 1
        named = ", ".join(c["name"] + (f" (amb. {'/'.join(c['ambiguous_with'])})"
                                       if c["ambiguous_with"] else "") for c in r["claims"])
        if r["suggestive"]:
            named += ("; " if named else "") + "sugg. " + ", ".join(r["suggestive"])
        if r.get("recording_specific"):
            named += "; rec.-specific " + ", ".join(x["name"] for x in r["recording_specific"])
        pars = []
        for q in r.get("recovery", []):
            tol = RECOVERY_TOLERANCE.get(q["quantity"])
            if tol is None or q["rel_err"] is None:
                continue
            ok = abs(q["rel_err"]) <= tol
            rec_n += 1
            rec_ok += ok
            pars.append(f"{q['quantity']} {_g(q['found'])} vs {_g(q['truth'])} "
                        f"({100 * q['rel_err']:+.1f} %{'' if ok else ', OFF'})"
                        + (" said amb." if q.get("ambiguous") else ""))
        lines.append(f"| {r['class']} | {r['case']} | {r['noise']} | {named or 'none'} | "
                     f"**{verdict}** | "
                     + ", ".join(f"{h} {v}" for h, v in per.items())
                     + f" | {'; '.join(pars) or '-'} | {r['elapsed_s']:.0f} |")
    lines += ["", "runs: " + ", ".join(f"{k} {tally.get(k, 0)}" for k in
                                       ("named", "flagged", "missed", "wrong"))
              + f" (of {len(rows)}); parameters within tolerance {rec_ok}/{rec_n}"]
    return "\n".join(lines)


def _g(x: float | None) -> str:
    return "-" if x is None else f"{x:.3g}"


def recovery_table(rows: list[dict[str, Any]]) -> str:
    """Markdown table of the parameter recovery (found vs truth) of every run that found a
    hidden effect with a comparable parameter (``row["recovery"]``)."""
    out = []
    for r in sorted(rows, key=lambda r: r["id"]):
        for q in r.get("recovery", []):
            out.append(f"| {r['id']} | {q['effect']} | {q['quantity']} | {_g(q['truth'])} | "
                       f"{_g(q['found'])} | {_g(q['sigma'])} | "
                       + (f"{100 * q['rel_err']:+.1f} %" if q["rel_err"] is not None else "-")
                       + " | " + ({None: "-", True: "yes", False: "no"}[q["within"]])
                       + " | " + ("yes" if q.get("ambiguous") else "no") + " |")
    if not out:
        return ""
    return "\n".join(["Parameter recovery (found effects that are hidden; sigma: reported "
                      "1-sigma uncertainty)", "",
                      "| run | effect | quantity | truth | found | sigma | rel. error | "
                      "within sigma | said ambiguous |",
                      "|---|---|---|---|---|---|---|---|---|"] + out)


def honesty_table(rows: list[dict[str, Any]]) -> str:
    """Markdown table of how the reported uncertainties cover the truth, per recovered
    quantity: found values within the reported 1-sigma (a calibrated sigma: 68 % of them),
    within 2 sigmas (95 %), said ambiguous, and honest (within 1-sigma or said ambiguous, the
    issue's rule); the last row pools every quantity. Rows without a sigma count as not
    within."""
    qs = [q for r in rows for q in r.get("recovery", [])]
    if not qs:
        return ""
    lines = ["| quantity | found | within 1 sigma | within 2 sigma | said ambiguous | "
             "honest (1 sigma or ambiguous) |", "|---|---|---|---|---|---|"]
    names = list(dict.fromkeys(q["quantity"] for q in qs))
    for name, sel in [*((n, [q for q in qs if q["quantity"] == n]) for n in names),
                      ("all", qs)]:
        n = len(sel)
        w1 = sum(bool(within_sigmas(q, 1.0)) for q in sel)
        w2 = sum(bool(within_sigmas(q, 2.0)) for q in sel)
        amb = sum(bool(q.get("ambiguous")) for q in sel)
        hon = sum(bool(q.get("ambiguous") or within_sigmas(q, 1.0)) for q in sel)
        lines.append(f"| {name} | {n} | {w1} ({100 * w1 / n:.0f} %) | {w2} ({100 * w2 / n:.0f} %)"
                     f" | {amb} | {hon} ({100 * hon / n:.0f} %) |")
    return "\n".join(lines)


def family_matrix(rows: list[dict[str, Any]]) -> str:
    """Markdown table base x effect of the non-PI base class over every seed, noise and size:
    per effect, runs whose first name is a hidden effect / runs; per null, runs without a
    wrong (dynamic or time) name / runs; and the seeds it pools."""
    bases = list(dict.fromkeys(r["case"].split("/")[0] for r in sorted(
        rows, key=lambda r: FAMILY_CASES.index(r["case"]) if r["case"] in FAMILY_CASES
        else 999)))
    effects = [e for e in FAMILY_EFFECTS if any(r["case"].split("/")[1] == e for r in rows)]
    lines = ["| base | null (clean) | " + " | ".join(effects) + " | all effects |",
             "|---" * (len(effects) + 3) + "|"]
    tot = [0, 0]
    for b in bases:
        cells, base_tot = [], [0, 0]
        for e in ["null", *effects]:
            rs = [r for r in rows if r["case"].split("/")[:2] == [b, e]]
            ok = sum((not wrong_names(r)) if e == "null" else named_first(r) for r in rs)
            cells.append(f"{ok}/{len(rs)}" if rs else "-")
            if e != "null":
                base_tot[0] += ok
                base_tot[1] += len(rs)
        tot = [tot[0] + base_tot[0], tot[1] + base_tot[1]]
        lines.append(f"| {b} | " + " | ".join(cells) + f" | {base_tot[0]}/{base_tot[1]} |")
    seeds = sorted({r["seed"] for r in rows})
    lines += ["", f"top-1 {tot[0]}/{tot[1]} effect runs over seeds "
              f"{', '.join(map(str, seeds))}, noises "
              f"{', '.join(sorted({r['noise'] for r in rows}))}, both sizes"]
    return "\n".join(lines)


def summarise_families(rows: list[dict[str, Any]]) -> str:
    """Per-run table of the non-PI base class: named effects, top-1, wrong names (dynamic or
    time effects that are not hidden) and the found vs true parameters."""
    lines = ["| base | effect | size | named (first to last) | top-1 | wrong name | "
             "params found vs truth | adequate | s |", "|---|---|---|---|---|---|---|---|---|"]
    n_eff = n_top = n_null = n_null_wrong = 0
    for r in sorted(rows, key=lambda r: FAMILY_CASES.index(r["case"])
                    if r["case"] in FAMILY_CASES else 999):
        base, effect, size = (*r["case"].split("/"), "-")[:3]
        top = named_first(r)
        wrong = wrong_names(r)
        if r["hidden"]:
            n_eff += 1
            n_top += top
        else:
            n_null += 1
            n_null_wrong += bool(wrong)
        named = ", ".join(c["name"] + (f" (amb. {'/'.join(c['ambiguous_with'])})"
                                       if c["ambiguous_with"] else "") for c in r["claims"])
        if r["suggestive"]:
            named += ("; " if named else "") + "suggestive: " + ", ".join(r["suggestive"])
        pars = "; ".join(f"{q['quantity']} {_g(q['found'])}"
                         + (f" ± {_g(q['sigma'])}" if q["sigma"] is not None else "")
                         + (" (said ambiguous)" if q.get("ambiguous") else "")
                         + f" vs {_g(q['truth'])} ({100 * q['rel_err']:+.0f} %)"
                         for q in r.get("recovery", []) if q["rel_err"] is not None)
        lines.append(f"| {base} | {effect} | {size} | {named or 'none'} | "
                     + ("yes" if top else "no" if r["hidden"] else "-")
                     + f" | {', '.join(wrong) or '-'} | {pars or '-'} | "
                     + {None: "-", True: "yes", False: "no"}[r["adequate"]]
                     + f" | {r['elapsed_s']:.0f} |")
    lines += ["", f"non-PI bases: top-1 {n_top}/{n_eff} effect runs; nulls with a wrong "
              f"(dynamic/time) name {n_null_wrong}/{n_null}"]
    return "\n".join(lines)

