"""Diagnoses of recordings: the explorer's session diagnosis and the steps ``hyst diagnose``
and the batch worker share (reading the files, the documents written), no web imports.

Every diagnosis is :func:`core.diagnosis.diagnose`.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .inputs import existing_file
from .recordings import say_read

if TYPE_CHECKING:  # core.diagnosis is imported when a diagnosis runs
    from core.base import Model
    from core.paramset import ParameterSet
    from core.recordings import Recording

    from .progress import Progress
    from .sessions import Session

__all__ = [
    "diagnose_files",
    "diagnose_session",
    "diagnosis_html",
    "diagnosis_json",
    "diagnosis_source",
    "diagnosis_summary",
    "model_document",
    "run_diagnosis",
    "save_model",
]


def diagnosis_summary(d: dict[str, Any]) -> dict[str, Any]:
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

    from .simulation import pi_part

    pi = pi_part(model)
    n = int(min(25, max(4, pi.n if pi is not None else 10)))
    result = diagnose((rec.t, rec.u, rec.y), "pi", n_operators=n, progress=progress)
    d = result.to_dict()
    return {"engine": "core.diagnosis", **diagnosis_summary(d), "document": d}, result


def diagnose_session(session: Session,
                     progress: Callable[..., None] | None = None) -> dict[str, Any]:
    """Diagnose the fitted model (else the current model) against ``session``'s recording.

    Stores and returns the report (see :func:`run_diagnosis`); the caller checks that the
    session has a recording.
    """
    from core.base import model_from_dict

    doc = session.fitted or session.snapshot()[0].model
    report, result = run_diagnosis(session.recording, model_from_dict(doc), progress)
    if progress is not None:
        # the last point where a cancelled job stops: a cancel that came while the report
        # was being built must not leave the result in the session
        progress(1.0, "storing the diagnosis")
    session.set_diagnosis(report, result)
    return report


def diagnosis_html(result: Any) -> str:
    """The self-contained HTML report (:mod:`.diagnosis_report`) of a diagnosis result."""
    import tempfile
    from pathlib import Path

    from .diagnosis_report import write_report

    with tempfile.TemporaryDirectory() as tmp:
        return write_report(result, Path(tmp) / "report.html").read_text(encoding="utf-8")


def model_document(result: Any, source: str) -> ParameterSet:
    """The final model of ``result`` as a parameter set (units from the first recording when
    the parameter-set validator knows them): what ``--save-model`` writes."""
    from core.paramset import ParameterSet

    first = result.records[0]
    units = {"input": first.units.get("input") or "V", "output": first.units.get("output")
             or "um", "time": first.units.get("time") or "s"}
    summary = {
        "kind": "diagnosis",
        "effects": [e.name for e in result.effects],
        "heldout_rmse_baseline": result.heldout_rmse(result.baseline),
        "heldout_rmse_final": result.heldout_rmse(result.final),
        "split": result.split,
    }
    notes = "model fitted to the first recording; effects: " + (
        ", ".join(e.name for e in result.effects) or "none"
    )
    try:
        return ParameterSet.from_model(result.model, units=units, source=source, fit=summary,
                                       notes=notes)
    except ValueError:  # units the parameter-set validator does not know
        return ParameterSet.from_model(result.model, source=source, fit=summary, notes=notes)


def save_model(result: Any, path: str | Path, source: str) -> Path:
    """Write :func:`model_document` of ``result`` to ``path``."""
    return model_document(result, source).save(path)


def diagnosis_source(files: Sequence[str | Path]) -> str:
    """The provenance ``source`` of a diagnosis of ``files``."""
    return "hyst diagnose " + " ".join(Path(f).name for f in files)


def diagnosis_json(result: Any) -> str:
    """The ``--json`` document of ``result`` (one JSON object, one line)."""
    return json.dumps(result.to_dict(), allow_nan=False)


def diagnose_files(files: Sequence[str | Path], read_kw: dict[str, Any], progress: Progress, *,
                   model: str = "pi", base: str = "auto",
                   train: tuple[float, float] | None = None,
                   test: tuple[float, float] | None = None, operators: int = 25,
                   fixed_grid: bool = False, no_crossfit: bool = False,
                   effects: str | None = None) -> Any:
    """Read ``files`` and run :func:`core.diagnosis.diagnose` with the options of
    ``hyst diagnose`` (``effects``: the comma-separated ``--effects`` text); progress and the
    read notes go to ``progress``. Returns the ``DiagnosisResult``."""
    from core.diagnosis import as_records, diagnose

    for f in files:
        existing_file(f, "recording")
    chosen = [e.strip() for e in effects.split(",")] if effects else None
    recs = as_records([Path(f) for f in files], **read_kw)
    say_read(progress, recs)
    return diagnose(recs, model=model, train=train, test=test, n_operators=operators,
                    effects=chosen, base=base, auto_resolution=not fixed_grid,
                    crossfit=False if no_crossfit else None,
                    progress=lambda frac, msg: progress(f"{100 * frac:3.0f} % {msg}"))
