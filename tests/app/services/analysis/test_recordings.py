"""A session's recordings and fits (``app.services.analysis.recordings``,
``app.services.analysis.fitting``):
CSV via ``core.csvio``, store, fit, clear."""

from __future__ import annotations

import json

import numpy as np
import pytest

from app.services.analysis import recordings as D
from app.services.explore import config as S
from app.services.jobs.tasks import fit_task
from app.services.session import exports as E
from app.services.session import sessions as SS
from core.csvio import CSVError
from core.pi import PIModel
from tests.app.job_work import run_here


def test_csv_recordings_come_from_core_csvio() -> None:
    rows = "".join(f"{k},{(-1) ** (k // 4) * k},{k / 2}\n" for k in range(12))
    two = "".join(f"{(-1) ** (k // 4) * k},{k / 2}\n" for k in range(12))
    rec = D.recording_from_csv("a,b\n" + two, dt=0.5)
    np.testing.assert_allclose(rec.t, 0.5 * np.arange(12))  # no time column: t = k dt
    assert rec.n_samples == 12 and rec.units["time"] == "s"
    prev = D.csv_preview("t,u,y\n" + rows, 100, rows=2)
    assert prev.columns == ("t", "u", "y") and prev.n_rows == 12 and len(prev.rows) == 2
    with pytest.raises(CSVError) as e:
        D.recording_from_csv("t,u,y\n" + rows + "12,x,1\n")
    assert e.value.line == 14 and e.value.column_index == 1
    with pytest.raises(CSVError, match="zz"):
        D.recording_from_csv("t,u,y\n" + rows, u_col="zz")


def test_session_services_store_fit_export_and_clear() -> None:
    from core.recordings import Recording

    s = SS.Session(code="abc")
    t = np.arange(600) * 1e-3
    u = 3 * np.sin(2 * np.pi * 3 * t)
    rec = Recording(t, u, PIModel.from_dict(S.EXAMPLE1)(u))
    D.store_recording(s, rec)
    out = run_here(fit_task(s, 6, "pi", apply=True))  # the session's one fit path
    report = out.outcome.report.to_dict()
    assert s.fitted is not None and s.fit is out.outcome  # typed: core's Model and FitOutcome
    assert s.fitted.to_dict() == s.config.model and out.nrmse_percent < 2
    assert out.outcome.kind == "pi" and "wipe-out" in report["extra"]["initial_memory"]["summary"]
    _, payload = E.export_session(s, "json")
    # the fit travels along, with the provenance hyst fit writes
    fit = json.loads(payload)["provenance"]["fit"]
    assert fit["model"] == "pi" and fit["report"]["train"] == report["train"]
    D.store_recording(s, rec)
    assert s.fit is s.fitted is s.diagnosis is s.diagnosis_result is None
