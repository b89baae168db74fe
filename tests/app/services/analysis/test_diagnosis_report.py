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
