"""Development / sealed split of the concealed-effect benchmark (issue 30): one runner, one
score, one table for both sets, so their numbers can stand side by side.

``dev``
    a fixed subset of the development set, the same classes as the sealed set: the B-PI
    plant with each L2 effect (``generator.make_scenario``, white1, seed 100) and two nulls
    (seeds 1000, 1001); the non-PI bases ``bouc-wen-1``, ``preisach``, ``maxwell-slip``
    (``families.make_family``, 0.2 % noise) with a delay, resonance, creep and drift at size
    ``large`` (seed 500) and two nulls each (seeds 500, 501), and each of their four
    recordings alone as a single-recording null (seed 500); the same cases on the non-Masing
    ``menegotto-pinto`` steel (round 4) and on the pinched ``bouc-wen-baber-noori`` element
    (round 5); (round 6) the measured-base class at sizes the sealed class does not use
    (:data:`benchmarks.diagnosis.measured.DEV_MEASURED_CASES`); and (session 21) the
    ``menegotto-pinto``, ``bouc-wen-baber-noori`` and ``bouc-wen-1`` plants driven by the
    bipolar recordings of :mod:`benchmarks.diagnosis.bipolar` (inputs through 0 V, growing
    amplitude: classes ``bipolar non-PI base`` and ``single-recording bipolar null``), with
    the same effects, nulls and single-recording nulls; and (session 23) a growing triangle
    at one input rate alone (:mod:`benchmarks.diagnosis.triangle`) on four bases, two nulls
    and a drift each (class ``growing-triangle non-PI base``); and (session 25) plants from an
    independent implementation, the three OpenSees laws of the sealed set with other
    parameters (:data:`benchmarks.diagnosis.opensees_plants.DEV_MATERIALS`), driven by the
    bipolar recordings, with the same effects, nulls (seeds 1700, 1701) and single-recording
    nulls (classes ``OpenSees non-PI base`` and ``single-recording OpenSees null``)
    (:data:`DEV_CASES`).
``sealed``
    :data:`benchmarks.diagnosis.sealed.SEALED_CASES`: other seeds, ranges, excitations,
    OpenSees plants, and the measured-base class.

Scores per class (:func:`summarise_set`), for every effect run:

* **top-1**: the first name the diagnosis gives is the hidden effect. On a measured base the
  first *new* name (not in the null's own diagnosis of the same recordings); if the null
  already names the hidden effect, naming it again counts;
* **named or flagged**: the hidden effect is named, or a name is reported ambiguous with it
  (its look-alike);
* **wrong names**: names that are not hidden and not ambiguous with it. On a measured base:
  new names relative to the null (anything invented); on a non-PI base only dynamic/time
  names (a loop-shape or memory name is the base-class difference, as in ``families.py``);
* **parameters**: delay, lag time constant (within 25 %) and mode frequency (within 10 %)
  of every named hidden effect, against the truth; on a measured base against the truth
  plus the null's own estimate of the same quantity (a dead time added to a recording that
  already has one).

Null runs: **wrong** when they carry a wrong name (B-PI: any name; non-PI: a dynamic/time
name). The measured nulls are references, not scored; their names are listed.

Information only (no count above reads it): the hidden effect's parameter where the
diagnosis gives one for it without naming it, said untestable (a mode seen in the residual's
spectrum) or suggested (a last-round improvement that failed the significance rules, or the
kind too few input steps show), against the truth, in the per-run table
(:func:`said_parameters`); and, per class, the **located, not named** count: effect runs
neither named nor flagged where such a parameter is within the tolerance above. A miss that
is located is one the evidence rules held back (one input step, no input energy at a mode),
not one the diagnosis did not see.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from benchmarks.diagnosis.bipolar import BIPOLAR_RECORDINGS
from benchmarks.diagnosis.classes import RECOVERY_TOLERANCE
from benchmarks.diagnosis.families import OPENSEES_DEV_BASES, TIME_EFFECTS, jsonable
from benchmarks.diagnosis.measured import DEV_MEASURED_CASES
from benchmarks.diagnosis.triangle import TRIANGLE_BASES

__all__ = ["DEV_CASES", "RECOVERY_TOLERANCE", "SETS", "build", "case_class", "run_case",
           "said_parameters", "score_rows", "side_by_side", "summarise_set"]

_DEV_FAMILY_BASES = ("bouc-wen-1", "preisach", "maxwell-slip")
_DEV_FAMILY_EFFECTS = ("delay", "resonance", "creep", "drift")
#: Bases whose loops the PI family cannot represent at all (non-Masing; round 4 of issue 30).
_DEV_NON_MASING_BASES = ("menegotto-pinto",)
#: A pinched law (round 5 of issue 30).
_DEV_PINCHED_BASES = ("bouc-wen-baber-noori",)
#: Bases driven by the bipolar recordings of ``bipolar.py`` (session 21 of issue 30): the
#: non-Masing and pinched plants, and a Masing control.
_DEV_BIPOLAR_BASES = ("menegotto-pinto", "bouc-wen-baber-noori", "bouc-wen-1")
_DEV_PI_EFFECTS = ("delay", "lag", "resonance", "rate", "creep", "drift", "asymmetry",
                   "offset", "initial-memory")

#: The development subset (ids ``dev/...``).
DEV_CASES: tuple[str, ...] = (
    "dev/pi/null/1000", "dev/pi/null/1001",
    *(f"dev/pi/{e}/L2/100" for e in _DEV_PI_EFFECTS),
    *(f"dev/family/{b}/null/{s}" for b in _DEV_FAMILY_BASES for s in (500, 501)),
    *(f"dev/family/{b}/{e}/large/500" for b in _DEV_FAMILY_BASES for e in _DEV_FAMILY_EFFECTS),
    *(f"dev/family-single/{b}/{r}/500" for b in _DEV_FAMILY_BASES
      for r in ("slow", "fast", "decaying", "staircase")),
    # round 4: a non-Masing steel (the PI family cannot represent it), the same cases
    *(f"dev/family/{b}/null/{s}" for b in _DEV_NON_MASING_BASES for s in (500, 501)),
    *(f"dev/family/{b}/{e}/large/500" for b in _DEV_NON_MASING_BASES
      for e in _DEV_FAMILY_EFFECTS),
    *(f"dev/family-single/{b}/{r}/500" for b in _DEV_NON_MASING_BASES
      for r in ("slow", "fast", "decaying", "staircase")),
    # round 5: a pinched structural element (Bouc-Wen-Baber-Noori), the same cases
    *(f"dev/family/{b}/null/{s}" for b in _DEV_PINCHED_BASES for s in (500, 501)),
    *(f"dev/family/{b}/{e}/large/500" for b in _DEV_PINCHED_BASES
      for e in _DEV_FAMILY_EFFECTS),
    *(f"dev/family-single/{b}/{r}/500" for b in _DEV_PINCHED_BASES
      for r in ("slow", "fast", "decaying", "staircase")),
    # round 6: the shipped measured recordings with effects at other sizes than the sealed
    *DEV_MEASURED_CASES,
    # session 21: bipolar inputs of growing amplitude (bipolar.py) on the non-Masing and
    # pinched plants and a Masing control
    *(f"dev/family-bipolar/{b}/null/{s}" for b in _DEV_BIPOLAR_BASES for s in (500, 501)),
    *(f"dev/family-bipolar/{b}/{e}/large/500" for b in _DEV_BIPOLAR_BASES
      for e in _DEV_FAMILY_EFFECTS),
    *(f"dev/family-bipolar-single/{b}/{r}/500" for b in _DEV_BIPOLAR_BASES
      for r in BIPOLAR_RECORDINGS),
    # session 23: one growing triangle at one input rate alone (triangle.py), a drift
    *(f"dev/family-triangle/{b}/null/{s}" for b in TRIANGLE_BASES for s in (500, 501)),
    *(f"dev/family-triangle/{b}/drift/large/500" for b in TRIANGLE_BASES),
    # session 25: OpenSees laws with other parameters than the sealed set's, bipolar inputs
    *(f"dev/opensees/{b}/null/{s}" for b in OPENSEES_DEV_BASES for s in (1700, 1701)),
    *(f"dev/opensees/{b}/{e}/large/1700" for b in OPENSEES_DEV_BASES
      for e in _DEV_FAMILY_EFFECTS),
    *(f"dev/opensees-single/{b}/{r}/1700" for b in OPENSEES_DEV_BASES
      for r in BIPOLAR_RECORDINGS),
)

_QUANTITY = {"delay": "delay_s", "lag": "tau_s", "resonance": "freq_hz"}
CLASSES = ("PI plant", "non-PI base", "single-recording non-PI null", "bipolar non-PI base",
           "single-recording bipolar null", "growing-triangle non-PI base",
           "OpenSees non-PI base", "single-recording OpenSees null", "measured base")
_NON_PI = ("non-PI base", "single-recording non-PI null", "bipolar non-PI base",
           "single-recording bipolar null", "growing-triangle non-PI base",
           "OpenSees non-PI base", "single-recording OpenSees null")


def _sealed_cases() -> tuple[str, ...]:
    from benchmarks.diagnosis.sealed import SEALED_CASES

    return SEALED_CASES


#: Set name -> its case ids (the sealed ids are read from ``sealed.py`` when asked for);
#: ``all`` runs both sets in one go (the class table then has their rows side by side).
SETS = {"dev": lambda: DEV_CASES, "sealed": _sealed_cases,
        "measured": lambda: tuple(c for c in _sealed_cases() if c.startswith("measured/")),
        "dev-measured": lambda: DEV_MEASURED_CASES,
        "all": lambda: DEV_CASES + _sealed_cases()}


def case_class(case: str) -> str:
    """The class of a case id (one of :data:`CLASSES`)."""
    if case.startswith(("measured/", "dev/measured/")):
        return "measured base"
    if case.startswith(("dev/pi/", "sealed/pi/")):
        return "PI plant"
    if case.startswith("dev/family-bipolar-single/"):
        return "single-recording bipolar null"
    if case.startswith("dev/family-bipolar/"):
        return "bipolar non-PI base"
    if case.startswith("dev/family-triangle/"):
        return "growing-triangle non-PI base"
    if case.startswith("dev/opensees-single/"):
        return "single-recording OpenSees null"
    if case.startswith("dev/opensees/"):
        return "OpenSees non-PI base"
    if case.startswith(("dev/family-single/", "sealed/opensees-single/")):
        return "single-recording non-PI null"
    return "non-PI base"


#: Case-id kinds of the non-PI family cases -> (recordings: ``families.py``, ``bipolar.py``
#: or ``triangle.py``, one recording alone).
_FAMILY_KINDS = {"family": ("family", False), "family-single": ("family", True),
                 "family-bipolar": ("bipolar", False),
                 "family-bipolar-single": ("bipolar", True),
                 "family-triangle": ("triangle", False),
                 # the OpenSees development laws on the bipolar recordings
                 "opensees": ("bipolar", False), "opensees-single": ("bipolar", True)}


def _family_case(case: str) -> Any:
    """A ``dev/family...`` case: ``<kind>/<base>/<effect>/<size>/<seed>``,
    ``<kind>/<base>/null/<seed>`` or (single) ``<kind>/<base>/<recording>/<seed>``, on the
    recordings of ``families.py``, ``bipolar.py`` or ``triangle.py``."""
    from benchmarks.diagnosis.bipolar import make_bipolar
    from benchmarks.diagnosis.families import make_family
    from benchmarks.diagnosis.triangle import make_triangle

    parts = case.split("/")
    signals, single = _FAMILY_KINDS[parts[1]]
    make = {"family": make_family, "bipolar": make_bipolar, "triangle": make_triangle}[signals]
    if single or parts[3] == "null":
        sc = make(parts[2], None, noise=0.002, seed=int(parts[4]))
    else:
        sc = make(parts[2], parts[3], parts[4], noise=0.002, seed=int(parts[5]))
    if single:
        sc.records = [r for r in sc.records if r.name == parts[3]]
        if len(sc.records) != 1:
            raise ValueError(f"unknown recording {parts[3]!r} in case {case!r}")
    return sc


def build(case: str) -> Any:
    """The :class:`~benchmarks.diagnosis.generator.Scenario` of a case id of either set."""
    parts = case.split("/")
    if parts[0] == "dev" and parts[1] == "measured":
        from benchmarks.diagnosis.measured import make_measured

        return make_measured(case)
    if parts[0] == "dev" and parts[1] == "pi":
        from benchmarks.diagnosis.generator import make_scenario

        if parts[2] == "null":
            return make_scenario(None, "white1", int(parts[3]))
        return make_scenario(parts[2], "white1", int(parts[4]), level=parts[3])
    if parts[0] == "dev" and parts[1] in _FAMILY_KINDS:
        return _family_case(case)
    from benchmarks.diagnosis.sealed import make_sealed

    return make_sealed(case)


def run_case(case: str) -> dict[str, Any]:
    """Diagnose one case with ``core.diagnosis.diagnose`` (default settings) and return its
    JSON row."""
    from core.diagnosis import diagnose
    from core.diagnosis.results import suggestive_rows

    sc = build(case)
    hidden = dict(sc.extras.get("hidden", {}))
    t0 = time.perf_counter()
    res = diagnose(sc.records)
    el = time.perf_counter() - t0
    return {
        "id": case, "set": case.split("/")[0] if not case.startswith("measured/") else "sealed",
        "class": case_class(case), "base": sc.extras.get("base", "B-PI"),
        "hidden": jsonable(hidden),
        "found": [e.name for e in res.effects],
        "claims": [{"name": e.name, "gain": float(e.heldout.gain), "z": float(e.heldout.z),
                    "ambiguous_with": list(e.ambiguous_with),
                    "parameters": jsonable(e.parameters), "uncertainty": jsonable(e.uncertainty)}
                   for e in res.effects],
        "ambiguous": [list(a["effects"]) for a in res.ambiguous],
        "suggestive": res.suggested_names,
        "after_steps": None if res.after_steps is None else {
            "effect": res.after_steps.kind, "parameters": res.after_steps.parameters},
        "untestable": [u.name for u in res.untestable],
        "untestable_parameters": {u.name: jsonable(u.parameters) for u in res.untestable
                                  if u.parameters},
        "suggestive_parameters": {g.effect: jsonable(g.parameters)
                                  for g in suggestive_rows(res.rounds)},
        "adequate": None if res.adequacy is None else bool(res.adequacy.adequate),
        "residual_pct": None if res.adequacy is None else float(res.adequacy.pct),
        "n_samples": int(sum(r.t.size for r in sc.records)),
        "concealment_pct": float(sc.concealment_pct),
        "elapsed_s": el,
    }


# ----------------------------------------------------------------------------- scoring
def _ambiguous_with(r: dict[str, Any], name: str, hidden: str) -> bool:
    cl = next((c for c in r["claims"] if c["name"] == name), {})
    return hidden in cl.get("ambiguous_with", []) or any(
        name in a and hidden in a for a in r["ambiguous"])


def _counts(r: dict[str, Any], name: str) -> bool:
    """Whether naming ``name`` wrongly counts in this row's class."""
    return r["class"] not in _NON_PI or name in TIME_EFFECTS


def _estimate(r: dict[str, Any] | None, quantity: str) -> float:
    if r is None:
        return 0.0
    for c in r["claims"]:
        v = c["parameters"].get(quantity)
        if isinstance(v, (int, float)):
            return float(v)
    return 0.0


def score_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One verdict per row: ``id``, ``set``, ``class``, ``hidden`` (name or None), ``top1``,
    ``named``, ``flagged``, ``located`` (:func:`_located`), ``wrong`` (names), ``params``
    (quantity, truth reference, found, relative error, within tolerance), ``null_names``
    (measured: the null's own names) and ``missing_null`` (a measured effect run whose null
    is not in ``rows``)."""
    nulls = {(r["set"], r["base"]): r for r in rows
             if r["class"] == "measured base" and not r["hidden"]}
    out = []
    for r in rows:
        hid = next(iter(r["hidden"]), None)
        ref = nulls.get((r["set"], r["base"])) if r["class"] == "measured base" else None
        base_names = set(ref["found"]) if ref else set()
        new = [n for n in r["found"] if n not in base_names]
        v: dict[str, Any] = {"id": r["id"], "set": r["set"], "class": r["class"], "hidden": hid,
                             "null_names": sorted(base_names), "params": [],
                             "missing_null": r["class"] == "measured base" and hid is not None
                             and ref is None}
        if hid is None:
            v.update(top1=None, named=None, flagged=None, located=None,
                     wrong=[] if r["class"] == "measured base" else
                     [n for n in r["found"] if _counts(r, n)])
            out.append(v)
            continue
        named = hid in r["found"]
        top = (hid in r["found"]) if hid in base_names else bool(new) and new[0] == hid
        flagged = not named and any(_ambiguous_with(r, n, hid) for n in r["found"])
        wrong = [n for n in new if n != hid and _counts(r, n) and not _ambiguous_with(r, n, hid)]
        q = _QUANTITY.get(hid)
        if q and named:
            truth = _reference(r, ref, hid, q)
            found = next(float(c["parameters"][q]) for c in r["claims"] if c["name"] == hid)
            err = (found - truth) / truth
            v["params"].append({"quantity": q, "truth": truth, "found": found, "rel_err": err,
                                "ok": abs(err) <= RECOVERY_TOLERANCE[q]})
        v.update(top1=top, named=named, flagged=flagged, wrong=wrong)
        v["located"] = _located(r, v, ref)
        v["said"] = said_parameters(r, ref)
        out.append(v)
    return out


def _reference(r: dict[str, Any], ref: dict[str, Any] | None, hid: str, q: str) -> float:
    """What run ``r``'s quantity ``q`` of its hidden effect ``hid`` is scored against: the
    truth, plus, for a delay or a lag on a measured base whose null ``ref`` names the same
    effect, the null's own estimate (a dead time added to a recording that already shows
    one). The one reference of the parameter column and of the located column."""
    truth = float(r["hidden"][hid][q])
    if hid in ("delay", "lag") and ref is not None and hid in ref["found"]:
        truth += _estimate(ref, q)
    return truth


def said_parameters(r: dict[str, Any], ref: dict[str, Any] | None = None) -> list[str]:
    """Each hidden effect's quantity (delay, lag time constant, mode frequency) where run
    ``r`` gives it without naming the effect: said untestable, suggested in the last round,
    or suggested by the input steps, each against the truth (``"untestable resonance
    freq_hz 45.56 vs 45 (+1.2 %)"``; on a measured base with its null ``ref``, against the
    reference of :func:`_reference`), in the order of the hidden effects. Information for
    the per-run table only; rows written before these keys were recorded give nothing."""
    return [f"{how} {hid} {q} {found:.4g} vs {truth:.4g} ({100 * (found - truth) / truth:+.1f} %)"
            for how, hid, q, found, truth in _said(r, ref)]


def _said(r: dict[str, Any], ref: dict[str, Any] | None = None
          ) -> list[tuple[str, str, str, float, float]]:
    """``(how, effect, quantity, found, reference)`` of every parameter run ``r`` gives for
    a hidden effect it does not name (see :func:`said_parameters`; ``reference``: that of
    :func:`_reference` with the null ``ref``)."""
    steps = r.get("after_steps") or {}
    out = []
    for hid, truths in r["hidden"].items():
        q = _QUANTITY.get(hid)
        if q is None or hid in r["found"]:
            continue
        said = [("untestable", (r.get("untestable_parameters") or {}).get(hid, {})),
                ("sugg.", (r.get("suggestive_parameters") or {}).get(hid, {})),
                ("steps", steps.get("parameters", {}) if steps.get("effect") == hid else {})]
        if q in truths:
            truth = _reference(r, ref, hid, q)
            out += [(how, hid, q, float(p[q]), truth)
                    for how, p in said if isinstance(p.get(q), (int, float))]
    return out


def _located(r: dict[str, Any], v: dict[str, Any], ref: dict[str, Any] | None = None) -> bool:
    """Whether effect run ``r`` (verdict ``v``) is neither named nor flagged but gives the
    hidden effect's parameter within :data:`RECOVERY_TOLERANCE` (said untestable or
    suggested) of the reference the parameter column uses (:func:`_reference`: on a measured
    base, the truth plus the null ``ref``'s own estimate of a delay or lag it names)."""
    return bool(v["hidden"]) and not (v["named"] or v["flagged"]) and any(
        abs(found - truth) <= RECOVERY_TOLERANCE[q] * abs(truth)
        for _, hid, q, found, truth in _said(r, ref) if hid == v["hidden"])


def _frac(k: int, n: int) -> str:
    return f"{k}/{n}" if n else "-"


def class_table(rows: list[dict[str, Any]]) -> list[str]:
    """Markdown rows ``| set | class | effect runs | top-1 | named or flagged | located, not
    named | wrong names | nulls with a wrong name | parameters within tolerance |`` of one
    set's rows."""
    vs = score_rows(rows)
    lines = []
    for st in dict.fromkeys(v["set"] for v in vs):
        for cls in CLASSES:
            sel = [v for v in vs if v["set"] == st and v["class"] == cls]
            if not sel:
                continue
            eff = [v for v in sel if v["hidden"]]
            nul = [v for v in sel if not v["hidden"]]
            ps = [p for v in eff for p in v["params"]]
            null_cell = ("reference" if cls == "measured base" else
                         _frac(sum(bool(v["wrong"]) for v in nul), len(nul)))
            top = _frac(sum(v["top1"] for v in eff), len(eff))
            lines.append(f"| {st} | {cls} | {len(eff)} | {top}"
                         f" | {_frac(sum(v['named'] or v['flagged'] for v in eff), len(eff))}"
                         f" | {_frac(sum(v['located'] for v in eff), len(eff))}"
                         f" | {_frac(sum(bool(v['wrong']) for v in eff), len(eff))}"
                         f" | {null_cell} | {_frac(sum(p['ok'] for p in ps), len(ps))} |")
    return lines


TABLE_HEAD = ["| set | class | effect runs | top-1 | named or flagged | located, not named "
              "| runs with a wrong name | nulls with a wrong name | parameters within tolerance |",
              "|---|---|---|---|---|---|---|---|---|"]


def summarise_set(rows: list[dict[str, Any]]) -> str:
    """The class table of ``rows`` and one line per run (hidden -> names, verdict)."""
    vs = {v["id"]: v for v in score_rows(rows)}
    lines = [*TABLE_HEAD, *class_table(rows), "",
             "| run | hidden | named (first to last) | verdict | parameter | s |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        v = vs[r["id"]]
        named = ", ".join(c["name"] + (f" (amb. {'/'.join(c['ambiguous_with'])})"
                                       if c["ambiguous_with"] else "") for c in r["claims"])
        extra = []
        if r["suggestive"]:
            extra.append("sugg. " + ", ".join(r["suggestive"]))
        if r["untestable"]:
            extra.append("untestable " + ", ".join(r["untestable"]))
        if v["hidden"] is None:
            verdict = ("reference" if r["class"] == "measured base" else
                       f"wrong: {', '.join(v['wrong'])}" if v["wrong"] else "clean")
        else:
            verdict = ("top-1" if v["top1"] else "named" if v["named"] else
                       "flagged" if v["flagged"] else
                       "missed, located" if v["located"] else "missed")
            if v["wrong"]:
                verdict += f"; wrong: {', '.join(v['wrong'])}"
            if v["missing_null"]:
                verdict += "; null not run"
        par = "; ".join([f"{p['quantity']} {p['found']:.4g} vs {p['truth']:.4g} "
                         f"({100 * p['rel_err']:+.0f} %{'' if p['ok'] else ', OFF'})"
                         for p in v["params"]] + v.get("said", []))
        lines.append(f"| {r['id']} | {v['hidden'] or '-'} | {named or 'none'}"
                     + (f"; {'; '.join(extra)}" if extra else "")
                     + f" | {verdict} | {par or '-'} | {r['elapsed_s']:.0f} |")
    engines = sorted({r.get("engine", "?") for r in rows})
    lines += ["", f"{len(rows)} runs, engine {', '.join(engines)}, diagnosis time median "
              f"{np.median([r['elapsed_s'] for r in rows]):.1f} s, total "
              f"{sum(r['elapsed_s'] for r in rows):.0f} s"]
    return "\n".join(lines)


def side_by_side(*row_sets: list[dict[str, Any]]) -> str:
    """The class tables of several runs (dev, sealed, ...) in one table, same format."""
    lines = list(TABLE_HEAD)
    for rows in row_sets:
        lines += class_table(rows)
    return "\n".join(lines)
