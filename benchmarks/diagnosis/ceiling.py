"""How much of a miss is the evidence's: each effect run diagnosed again, told the name.

A run of the benchmark that misses its hidden effect can miss for two reasons: the search
did not find or prefer it among the other candidates, or the recordings do not hold enough
evidence for the acceptance rules to accept it at all (one input step is one event; a mode
where the input has no energy cannot be told from vibration; a base misfit larger than the
effect). This script separates the two. It diagnoses every effect run of a set again with
the candidate list cut to the hidden effect and the names the run's null gets (a measured
recording names its own physics first, the piezo's initial memory: without it the base
misfit stays): ``diagnose(..., effects=[hidden, *null's names])``, an oracle of the name,
not of the parameters. It records what the engine then says of the hidden effect:

``named``
    accepted: the name was within reach of the rules; the miss is the search's.
``suggested``
    found but below the acceptance rule (its held-out gain, z): the evidence the
    recordings hold is short of what the rules ask, even for the right name.
``untestable``
    the engine says why the recordings cannot show it.
``silent``
    not even suggested.

Information only: no rule of the diagnosis reads it, and it is run on development sets
(``--set dev-measured`` by default); it says nothing a rule may be tuned on that the set's
own table does not.

Usage::

    python benchmarks/diagnosis/ceiling.py --set dev-measured --json F
    python benchmarks/diagnosis/ceiling.py --rescore F [--against RESULTS.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # run as a script from anywhere
    sys.path.insert(0, str(ROOT))

from benchmarks.diagnosis.sets import SETS, build, case_class, score_rows  # noqa: E402

__all__ = ["told_the_name", "verdict"]

#: The sets this script runs on (the sealed ones are run once by the lead, with their rules
#: fixed, and are not re-diagnosed here).
DEV_SETS = ("dev", "dev-measured")


_NULL_NAMES: dict[str, list[str]] = {}


def null_names(case: str) -> list[str]:
    """The names the null of ``case`` gets (measured bases: ``<set>/measured/<base>/null``;
    the synthetic sets' nulls are clean by their own tables, so none)."""
    parts = case.split("/")
    if "measured" not in parts[:2]:
        return []
    null = "/".join(parts[: parts.index("measured") + 2]) + "/null"
    if null not in _NULL_NAMES:
        from core.diagnosis import diagnose

        _NULL_NAMES[null] = [e.name for e in diagnose(build(null).records).effects]
    return _NULL_NAMES[null]


def effect_runs(set_name: str, pattern: str = "") -> list[str]:
    """The case ids of ``set_name`` containing ``pattern`` that hide an effect: not the
    nulls, nor the single-recording classes (nulls all), which have nothing to be told."""
    return [c for c in SETS[set_name]() if pattern in c and "/null" not in c
            and "null" not in case_class(c)]


def told_the_name(case: str) -> dict[str, Any]:
    """Diagnose the effect run ``case`` with its hidden effect and its null's names
    (:func:`null_names`) as the only candidates.

    Returns
    -------
    dict
        ``id``, ``hidden``, ``verdict`` (:func:`verdict`), ``gain`` and ``z`` of the
        suggestion or claim (``None`` otherwise), ``reason`` (the untestable reason, or
        ``""``) and ``elapsed_s``.
    """
    from core.diagnosis import diagnose
    from core.diagnosis.results import suggestive_rows

    sc = build(case)
    hidden = list(sc.extras.get("hidden", {}))
    if len(hidden) != 1:
        raise ValueError(f"{case}: one hidden effect is needed, not {hidden}")
    name = hidden[0]
    t0 = time.perf_counter()
    res = diagnose(sc.records, effects=list(dict.fromkeys([name, *null_names(case)])))
    el = time.perf_counter() - t0
    claim = next((e for e in res.effects if e.name == name), None)
    sugg = next((g for g in suggestive_rows(res.rounds) if g.effect == name), None)
    unt = next((u for u in res.untestable if u.name == name), None)
    row: dict[str, Any] = {"id": case, "hidden": name, "gain": None, "z": None,
                           "reason": "" if unt is None else str(unt.reason),
                           "elapsed_s": el}
    if claim is not None:
        row.update(verdict="named", gain=float(claim.heldout.gain), z=float(claim.heldout.z))
    elif name in res.suggested_names:
        row["verdict"] = "suggested"
        if sugg is not None:
            row.update(gain=float(sugg.heldout_mse_reduction), z=float(sugg.dm_z),
                       reason="; ".join(sugg.reasons or ()))
    elif unt is not None:
        row["verdict"] = "untestable"
    else:
        row["verdict"] = "silent"
    return row


def _num(x: Any) -> float | None:
    return None if x is None else float(x)


def verdict(row: dict[str, Any]) -> str:
    """The row's verdict in words, with its gain and z where it has them."""
    v = row["verdict"]
    if row.get("gain") is not None:
        v += f" (held-out MSE {-100 * row['gain']:+.0f} %, z {row['z']:.2f})"
    if row.get("reason"):
        v += f": {row['reason'][:90]}"
    return v


def table(rows: list[dict[str, Any]], against: list[dict[str, Any]] | None) -> str:
    """Markdown: one line per run (the set's own verdict from ``against`` where given) and
    the counts of the runs the set missed."""
    own = {v["id"]: v for v in score_rows(against)} if against else {}
    lines = ["| run | hidden | the set's verdict | told the name |", "|---|---|---|---|"]
    missed: dict[str, int] = {}
    for r in rows:
        o = own.get(r["id"])
        said = "-" if o is None else ("top-1" if o["top1"] else "named" if o["named"] else
                                      "flagged" if o["flagged"] else "missed")
        if said == "missed":
            missed[r["verdict"]] = missed.get(r["verdict"], 0) + 1
        lines.append(f"| {r['id']} | {r['hidden']} | {said} | {verdict(r)} |")
    if missed:
        n = sum(missed.values())
        lines += ["", f"Of the {n} runs the set missed, told the name: " + ", ".join(
            f"{k} {v}" for k, v in sorted(missed.items(), key=lambda kv: -kv[1]))]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=DEV_SETS, default="dev-measured")
    ap.add_argument("--cases", metavar="PATTERN", help="only case ids containing PATTERN")
    ap.add_argument("--json", type=Path, help="write the rows here")
    ap.add_argument("--rescore", type=Path, help="print the table of an earlier --json file")
    ap.add_argument("--against", type=Path, help="the set's own results (run_benchmark --json)")
    a = ap.parse_args(argv)
    against = json.loads(a.against.read_text()) if a.against else None
    if a.rescore:
        print(table(json.loads(a.rescore.read_text())["rows"], against))
        return 0
    cases = effect_runs(a.set, a.cases or "")
    rows = []
    for c in cases:
        rows.append(told_the_name(c))
        print(f"{c}: {verdict(rows[-1])}", flush=True)
    if a.json:
        a.json.write_text(json.dumps({"set": a.set, "rows": rows}, indent=1))
    print(table(rows, against))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
