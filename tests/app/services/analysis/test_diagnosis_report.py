"""The HTML report of a diagnosis (app.services.analysis.diagnosis_report)."""

from __future__ import annotations

import html
from pathlib import Path

import pytest

from benchmarks.diagnosis.measured import load_base
from core.diagnosis import diagnose


@pytest.mark.slow
def test_a_kind_seen_after_the_one_step_is_reported_unclaimed(tmp_path: Path) -> None:
    """The shipped piezo recording (one input step) rings after its step at the device's
    own mode: no output stage is named, and the report says what the step shows and what
    would decide (more steps)."""
    from app.services.analysis.diagnosis_report import write_report

    res = diagnose(load_base("piezo")[0], effects=["initial-memory", "resonance"])
    assert not any(e.name == "resonance" for e in res.effects)
    assert res.after_steps is not None
    text = write_report(res, tmp_path / "report.html").read_text()
    # fails without the report's section for it
    assert "Seen after too few input steps, not claimed" in text
    assert "a mode (ringing at its frequency)" in text and "more input steps" in text
    assert html.escape(res.after_steps.text) in text  # read from the typed suggestion
    # the untestable section from the typed entries, the same words as the JSON's
    assert res.untestable and "Untestable with these recordings" in text
    for u in res.untestable:
        assert f"<b>{html.escape(u.name)}</b>: {html.escape(u.reason)}" in text


def test_the_suggestive_section_reads_the_typed_rows(tmp_path: Path) -> None:
    """Four recordings at different rates (three suggestive effects): the section lists each
    suggestive row (:func:`core.diagnosis.results.suggestive_rows`) with its statistics, and
    the cross-fitted z where the row carries one (given to the lag's row here)."""
    import dataclasses

    from app.services.analysis.diagnosis_report import write_report
    from benchmarks.diagnosis.generator import make_periodic_set
    from core.diagnosis.results import suggestive_rows

    res = diagnose(make_periodic_set(0.0006, seed=201).records)
    rows = suggestive_rows(res.rounds)
    assert [r.effect for r in rows] == ["delay", "lag", "rate"]
    res.rounds = [dataclasses.replace(r, extra=(*r.extra, ("dm_z_pooled", 1.234)))
                  if r is rows[1] else r for r in res.rounds]
    text = write_report(res, tmp_path / "report.html").read_text()
    assert "<h2>Suggestive, not claimed</h2>" in text
    for r in rows:
        assert (f"<li>{r.effect}: held-out MSE -{100 * r.heldout_mse_reduction:.0f} %, "
                f"DM z = {r.dm_z:.2f}, signed-rank p = {r.signed_rank_p:.2g}") in text
    assert text.count("; with the cross-fitted training blocks DM z = 1.23</li>") == 1


def test_the_base_is_named_as_core_declares_it() -> None:
    """The explorer's words for a base kind are core's declaration
    (:data:`core.diagnosis.bases.BASE_KINDS`), in the findings too."""
    from app.services.analysis.diagnosis import base_name, diagnosis_summary
    from core.diagnosis.bases import BASE_KINDS

    assert {k: base_name(k) for k in BASE_KINDS} == {k: v.short for k, v in BASE_KINDS.items()}
    assert base_name(None) == "PI" and base_name("no-such-base", "base") == "base"
    s = diagnosis_summary({"baseline": {"model": "stop-pi", "heldout_rmse": 0.1,
                                        "heldout_rmse_pct": 1.0}})
    assert s.findings[0].startswith("On the rows the fit never saw, the stop-operator model")
