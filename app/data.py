"""Recordings, fits and diagnoses of the explorer (no viser / fastapi imports).

CSV uploads are read by :mod:`core.csvio` (its :class:`~core.csvio.CSVError` names the line
and the column; the server maps it to a 422 ``{message, line, column}``), fits use the
estimators of :mod:`core.fitting` and the diagnosis is :func:`core.diagnosis.diagnose`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from core.base import Model, model_from_dict
from core.csvio import CSVError, inspect_csv_text, read_csv_text
from core.fitting import fit_recordings
from core.models import fit_kinds
from core.recordings import Recording

from .compute import pi_part
from .services.columns import column_spec
from .services.sessions import Session

__all__ = [
    "Upload",
    "csv_preview",
    "diagnose_session",
    "diagnosis_html",
    "fit_kinds",
    "fit_recording",
    "fit_session",
    "read_upload",
    "recording_from_csv",
    "run_diagnosis",
    "store_recording",
]


@dataclass(frozen=True, eq=False)
class Upload:
    """An uploaded recording and what the file held.

    Attributes
    ----------
    recording : Recording
        The recording kept (its ``cleaning`` notes say what was removed or chosen).
    runs : tuple of str
        Run ids of the file's run column in file order (empty without one).
    """

    recording: Recording
    runs: tuple[str, ...] = ()


def read_upload(
    content: str | bytes,
    *,
    t_col: str | int | None = None,
    u_col: str | int | None = None,
    y_col: str | int | None = None,
    run: str | None = None,
    dt: float = 1e-3,
    max_samples: int = 200_000,
    name: str = "upload.csv",
) -> Upload:
    """Read uploaded CSV *content* (never a path) with an optional column mapping.

    The content goes through :func:`core.csvio.read_csv_text`, so bytes are decoded as the
    command line decodes a file (UTF-8 with or without BOM, UTF-16 with BOM, else Latin-1).
    Columns are names or 0-based indices (digit strings count as indices); unmapped roles
    are chosen by the core reader. A file without a time column gets ``t = k * dt``. A file
    with a run column holds several recordings: ``run`` chooses one by its id, ``"all"``
    reads every row as one recording in file order; without ``run`` the first run is kept.
    Either way a cleaning note says which run was kept and how to choose another.

    Raises
    ------
    core.csvio.CSVError
        With the 1-based ``line`` and the 0-based ``column_index`` of the problem, or when
        ``run`` names no run of the file.
    """
    recs = read_csv_text(content, time=column_spec(t_col), input=column_spec(u_col),
                         output=column_spec(y_col), run=False if run == "all" else None,
                         name=name, max_rows=max_samples)
    runs = tuple(str(r.run) for r in recs) if len(recs) > 1 or recs[0].run is not None else ()
    if run not in (None, "all"):
        if str(run) not in runs:
            raise CSVError(
                f"run={run!r} is not in this file; its runs are {', '.join(runs) or 'none'}"
                " (or pass run=all to read every row as one recording)"
            )
        rec = recs[runs.index(str(run))]
    else:
        rec = recs[0]
    if run == "all":
        rec = replace(rec, cleaning=(*rec.cleaning, "read every row as one recording "
                                     "(run=all): a run column, if any, was not used"))
    elif len(runs) > 1:
        col = rec.columns.get("run", "run")
        rec = replace(rec, name=f"{name} (run {rec.run}; {runs.index(str(rec.run)) + 1} of "
                                f"{len(runs)})",
                      cleaning=(*rec.cleaning, f"the file holds {len(runs)} runs (column "
                                f"{col!r}: {', '.join(runs)}); kept run {rec.run}; pass "
                                "run=<id> to choose another or run=all to read every row"))
    if not rec.has_time:
        rec = replace(rec, t=rec.t * dt, has_time=True, units={**rec.units, "time": "s"})
    return Upload(rec, runs)


def recording_from_csv(content: str | bytes, **kwargs: Any) -> Recording:
    """The recording of :func:`read_upload` ``(content, **kwargs)``."""
    return read_upload(content, **kwargs).recording


def store_recording(session: Session, rec: Recording) -> None:
    """Give ``session`` the recording ``rec``; its fit and diagnosis are dropped."""
    session.set_recording(rec)


def csv_preview(content: str | bytes, max_samples: int, rows: int = 5) -> dict[str, Any]:
    """Columns, the first ``rows`` data rows (as text), row count and notes of CSV content.

    Raises
    ------
    core.csvio.CSVError
        If :func:`core.csvio.inspect_csv_text` cannot work out the layout.
    """
    lay = inspect_csv_text(content, max_rows=max_samples)
    if isinstance(content, bytes):
        enc = {"utf-8": "utf-8-sig"}.get(lay.encoding, lay.encoding)
        content = content.decode(enc)
    lines = content.splitlines()[lay.first_data_line - 1: lay.first_data_line - 1 + rows]
    d = None if lay.delimiter == "whitespace" else lay.delimiter
    return {"columns": [c.raw for c in lay.columns],
            "rows": [[c.strip() for c in (ln.split(d) if d else ln.split())] for ln in lines],
            "n_rows": int(lay.n_rows), "encoding": lay.encoding, "notes": list(lay.notes)}


def _finite(x: Any) -> Any:
    """``x`` with non-finite floats replaced by ``None`` (JSON has no NaN/inf)."""
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_finite(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def fit_recording(rec: Recording, n: int, kind: str = "pi") -> tuple[Model, dict[str, Any]]:
    """Fit a model of ``kind`` with ``n`` operators to ``rec``; returns ``(model, report)``.

    The fit is :func:`core.fitting.fit_recordings` (the one entry point ``hyst fit`` and
    ``hyst batch fit`` use; every training row fitted from the relaxed state, the last 20 %
    held out). The model is its ``model`` (the fitted output offset included, as a chain);
    the report is its ``report`` plus the errors on the whole recording.

    Raises
    ------
    ParameterError
        If ``kind`` is not one of :func:`fit_kinds` (those of ``hyst fit --model``, declared
        by the model registry).
    """
    out = fit_recordings([rec], kind, n_operators=n, initial_memory="keep")
    model = out.model
    res = rec.y - model(rec.u)
    rms = float(np.sqrt(np.mean(res**2)))
    report = {
        **_finite(out.report.to_dict()),
        "rms_error": rms,
        "max_error": float(np.max(np.abs(res))),
        "nrmse_percent": float(100 * rms / (float(np.ptp(rec.y)) or 1.0)),
        "n_operators": int(n),
        "kind": kind,
    }
    return model, report


def fit_session(session: Session, n: int, kind: str = "pi",
                apply: bool = True) -> tuple[Model, dict[str, Any]]:
    """Fit ``session``'s recording (see :func:`fit_recording`) and store the fit.

    The diagnosis is dropped; with ``apply`` the fitted model becomes the session's model.
    The caller checks that the session has a recording.
    """
    model, report = fit_recording(session.recording, n, kind)
    session.set_fit(model.to_dict(), report, apply=apply)
    return model, report


def _diagnosis_summary(d: dict[str, Any]) -> dict[str, Any]:
    """Findings (accepted effects, ambiguities, untestable effects) of a diagnosis document."""
    findings: list[str] = []
    for e in d.get("effects", []):
        params = ", ".join(f"{k} = {v:.4g}" for k, v in (e.get("parameters") or {}).items()
                           if isinstance(v, int | float))
        where = (e.get("where") or {}).get("summary", "")
        findings.append(f"{e.get('name')} ({e.get('family', '')}): {params}. {where}".strip())
    base_doc = d.get("baseline", {})
    if not findings:
        findings.append("no missing physics detected: the "
                        + ("Preisach" if base_doc.get("model") == "preisach" else "PI")
                        + " model explains the data")
    choice = base_doc.get("base_choice") or {}
    if choice.get("kind") == "preisach":
        findings.append(f"base: {choice.get('text', '')}")
    for r in d.get("recording_specific", []):
        findings.append(f"recording-specific, not claimed: {r.get('text', '')}")
    for a in d.get("ambiguous", []):
        findings.append(f"ambiguous {' vs '.join(a.get('effects', []))}: {a.get('experiment', '')}")
    for u in d.get("untestable", []):
        findings.append(f"untestable {u.get('name')}: {u.get('reason', '')}")
    base, final = d.get("baseline", {}), d.get("final", {})
    return {
        "findings": findings,
        "baseline_rmse_pct": base.get("heldout_rmse_pct"),
        "final_rmse_pct": final.get("heldout_rmse_pct"),
        "effects": final.get("effects", []),
    }


def run_diagnosis(rec: Recording, model: Model,
                  progress: Callable[..., None] | None = None) -> tuple[dict[str, Any], Any]:
    """:func:`core.diagnosis.diagnose` of ``rec``: ``(report, result)``.

    The baseline has as many operators as the PI part of ``model`` (4 to 25, else 10).
    ``result`` is the core's ``DiagnosisResult``; the report holds the findings, the
    held-out RMSE before and after, and the core's JSON document. ``progress`` is passed
    on to :func:`~core.diagnosis.diagnose` (it may raise to stop the diagnosis: that is how
    a job is cancelled).
    """
    from core.diagnosis import diagnose

    pi = pi_part(model)
    n = int(min(25, max(4, pi.n if pi is not None else 10)))
    result = diagnose((rec.t, rec.u, rec.y), "pi", n_operators=n, progress=progress)
    d = result.to_dict()
    return {"engine": "core.diagnosis", **_diagnosis_summary(d), "document": d}, result


def diagnose_session(session: Session,
                     progress: Callable[..., None] | None = None) -> dict[str, Any]:
    """Diagnose the fitted model (else the current model) against ``session``'s recording.

    Stores and returns the report (see :func:`run_diagnosis`); the caller checks that the
    session has a recording.
    """
    doc = session.fitted or session.snapshot()[0].model
    report, result = run_diagnosis(session.recording, model_from_dict(doc), progress)
    if progress is not None:
        # the last point where a cancelled job stops: a cancel that came while the report
        # was being built must not leave the result in the session
        progress(1.0, "storing the diagnosis")
    session.set_diagnosis(report, result)
    return report


def diagnosis_html(result: Any) -> str:
    """The self-contained HTML report (:mod:`app.diagnosis_report`) of a diagnosis result."""
    import tempfile
    from pathlib import Path

    from .diagnosis_report import write_report

    with tempfile.TemporaryDirectory() as tmp:
        return write_report(result, Path(tmp) / "report.html").read_text(encoding="utf-8")
