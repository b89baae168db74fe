"""The told-the-name ceiling of the diagnosis benchmark (benchmarks/diagnosis/ceiling.py):
its table counts what the engine says, told the name, of the runs the set itself missed."""

from __future__ import annotations

import json
from pathlib import Path

from benchmarks.diagnosis import ceiling

RESULTS = Path(__file__).resolve().parent.parent / "benchmarks" / "diagnosis" / "results"


def _row(case: str, hidden: str | None, found: list[str]) -> dict:
    return {"id": case, "set": "dev", "class": "measured base", "base": "piezo",
            "hidden": {hidden: {}} if hidden else {}, "found": found, "claims": [],
            "ambiguous": [], "suggestive": [], "untestable": []}


def test_the_table_counts_only_the_runs_the_set_missed() -> None:
    against = [_row("dev/measured/piezo/null", None, ["initial-memory"]),
               _row("dev/measured/piezo/drift/large", "drift", ["initial-memory", "drift"]),
               _row("dev/measured/piezo/lag/small", "lag", ["initial-memory"]),
               _row("dev/measured/piezo/creep/small", "creep", ["initial-memory"])]
    told = [{"id": "dev/measured/piezo/drift/large", "hidden": "drift", "verdict": "named",
             "gain": 0.5, "z": 9.0, "reason": ""},
            {"id": "dev/measured/piezo/lag/small", "hidden": "lag", "verdict": "suggested",
             "gain": 0.15, "z": 7.3, "reason": "removes less than 20 % of the excess"},
            {"id": "dev/measured/piezo/creep/small", "hidden": "creep",
             "verdict": "untestable", "gain": None, "z": None, "reason": "no hold"}]
    text = ceiling.table(told, against)
    assert "| dev/measured/piezo/drift/large | drift | top-1 | named (held-out MSE -50 %" in text
    assert "| lag | missed | suggested (held-out MSE -15 %, z 7.30): removes less" in text
    assert text.endswith("Of the 2 runs the set missed, told the name: suggested 1, "
                         "untestable 1")


def test_the_committed_ceiling_covers_every_effect_run_of_the_set() -> None:
    from benchmarks.diagnosis.sets import SETS

    got = json.loads((RESULTS / "ceiling-devmeasured-979ef26.json").read_text())
    want = [c for c in SETS["dev-measured"]() if "/null" not in c]
    assert [r["id"] for r in got["rows"]] == want
    assert {r["verdict"] for r in got["rows"]} <= {"named", "suggested", "untestable",
                                                   "silent"}


def test_a_measured_run_is_told_its_null_s_names() -> None:
    ceiling._NULL_NAMES["dev/measured/piezo/null"] = ["initial-memory"]
    try:
        assert ceiling.null_names("dev/measured/piezo/lag/small") == ["initial-memory"]
        assert ceiling.null_names("dev/family/preisach/drift/large/500") == []
    finally:
        ceiling._NULL_NAMES.pop("dev/measured/piezo/null")


def test_the_runs_told_their_name_are_effect_runs_with_one_hidden_effect() -> None:
    """On the whole development set the ceiling takes only runs that hide one effect: its
    single-recording nulls (ids without '/null') made told_the_name raise on the first
    one. Each run kept is checked on what the set builds for it (one of each class)."""
    from benchmarks.diagnosis.sets import SETS, build, case_class

    runs = ceiling.effect_runs("dev")
    left = [c for c in SETS["dev"]() if c not in runs]
    assert any(case_class(c).startswith("single-recording") for c in left)
    firsts = {case_class(c): c for c in reversed(runs)}
    for case in firsts.values():
        assert len(build(case).extras.get("hidden", {})) == 1, case
