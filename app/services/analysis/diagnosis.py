"""Diagnoses of recordings: the explorer's session diagnosis and the steps ``hyst diagnose``
and the batch worker share (reading the files, the documents written), no web imports.

Every diagnosis is :func:`core.diagnosis.diagnose`.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from app.services.analysis.recordings import say_read
from app.services.runs.inputs import existing_file
from app.services.words import field_words, in_words, unit_words

if TYPE_CHECKING:  # core.diagnosis is imported when a diagnosis runs
    from app.services.runs.progress import Progress
    from core.base import Model
    from core.csvio import CsvOptions
    from core.diagnosis.results import DiagnosisResult
    from core.paramset import ParameterSet
    from core.recordings import Recording

__all__ = [
    "DiagnosisSummary",
    "SessionDiagnosis",
    "base_name",
    "diagnose_files",
    "diagnosis_html",
    "diagnosis_json",
    "diagnosis_source",
    "diagnosis_summary",
    "model_document",
    "run_diagnosis",
    "save_model",
    "session_diagnosis",
]


#: Effect names of the diagnosis -> words.
_EFFECT_WORDS = {"rate": "rate dependence", "offset": "a sensor offset",
                 "initial-memory": "initial memory", "asymmetry": "asymmetry"}


def _unit(units: Mapping[str, str] | None, role: str) -> str:
    return unit_words((units or {}).get(role))


def _qty(v: float, unit: str) -> str:
    return f"{v:.3g} {unit}".strip()


def _effect_words(name: object) -> str:
    text = str(name or "an effect")
    return _EFFECT_WORDS.get(text, text.replace("-", " ").replace("_", " "))


def _with_units(text: str, unit: str) -> str:
    """``"RMS 0.1023"`` -> ``"RMS 0.102 µm"``: the core's numbers of the output (an RMS,
    the noise floor) with the output's unit, where the text gives none."""
    if not unit:
        return text
    return re.sub(r"\b(RMS|floor) (-?\d+(?:\.\d+)?(?:e-?\d+)?)(?![\d.]| ?%| ?[^\W\d_])",
                  lambda m: f"{m.group(1)} {float(m.group(2)):.3g} {unit}", text)


def _cap(text: str) -> str:
    return text[:1].upper() + text[1:]


def _param_text(params: dict[str, Any], u_unit: str, effect: str = "", y_unit: str = "") -> str:
    """The fitted parameters of ``effect`` in words: each named by the words its effect
    declared (:func:`core.diagnosis.registry.parameter_words`: asymmetry's ``a2`` -> "output
    added at both ends of the loop (its bend)") or else by its stage's field title
    (``history`` of initial memory -> "Input history u_k"), with its unit."""
    from core.diagnosis.registry import parameter_words

    units = {"output": y_unit, "input": u_unit, "1/input": f"1/{u_unit}" if u_unit else "",
             "s": "s", "Hz": "Hz"}
    parts = []
    for k, v in (params or {}).items():
        declared = parameter_words(effect, k)
        if declared is not None:
            key, unit = declared[0], units.get(declared[1], declared[1])
        else:
            key = field_words(effect, k)
            unit = ("s" if k.endswith("_s") else "Hz" if k.endswith("_hz")
                    else u_unit if k == "history" else "")
        unit = f" {unit}" if unit else ""
        if isinstance(v, int | float) and not isinstance(v, bool):
            parts.append(f"{key} = {v:.3g}{unit}")
        elif isinstance(v, list | tuple):
            flat = [x for x in np.ravel(np.asarray(v, dtype=float))][:6]
            parts.append(f"{key} = " + ", ".join(f"{x:.3g}" for x in flat) + unit)
    return "; ".join(parts)


def base_name(kind: object, default: str = "PI") -> str:
    """The words for a diagnosis's base kind (:attr:`~core.diagnosis.structure.Structure.base_kind`,
    the JSON document's ``baseline.model``), as in "the PI model": its short name as core
    declares it (:data:`core.diagnosis.bases.BASE_KINDS`); ``default`` for an unknown kind."""
    from core.diagnosis.bases import BASE_KINDS

    k = BASE_KINDS.get(kind) if isinstance(kind, str) else None
    return default if k is None else k.short


def _where_text(where: dict[str, Any], u_unit: str, timed: bool = True,
                named: bool = False) -> str:
    """Where an effect's error reduction lies, from its fields (times in s, or sample
    numbers where the recordings have no time axis (``timed`` false); the recording's name
    before each stretch when there are several (``named``); input range with its unit)."""
    out = []
    wins = where.get("time_windows") or []
    if wins:
        shown = ", ".join((f"{w[0]} " if named else "")
                          + (f"{w[1]:.3g}–{w[2]:.3g} s" if timed
                             else f"samples {w[1]:.0f}–{w[2]:.0f}") for w in wins[:3])
        k = len(wins) - 3
        more = f" and {k} more stretch{'es' if k > 1 else ''}" if k > 0 else ""
        out.append(f"half of the improvement lies in {shown}{more} of the "
                   f"recording{'s' if named else ''}")
    rng = where.get("input_range")
    if rng and len(rng) == 2:
        out.append(f"at inputs from {_qty(rng[0], u_unit)} to {_qty(rng[1], u_unit)}")
    since = where.get("median_since_reversal_s")
    if isinstance(since, int | float):
        out.append(f"typically {since:.3g} {'s' if timed else 'samples'} after the input "
                   "turned")
    return "; ".join(out)


def _because(head: str, reason: object, lead: str, experiment: object) -> str:
    """``head: reason. lead experiment.`` (the parts that are given)."""
    text = head + (f": {reason}" if reason else "")
    return text + (f". {lead} {experiment}" if experiment else "") + "."


@dataclass(frozen=True)
class DiagnosisSummary:
    """The findings of a diagnosis in sentences for people (:func:`diagnosis_summary`).

    Attributes
    ----------
    findings : tuple of str
        One sentence (or a few) per finding, units in words.
    baseline_rmse_pct, final_rmse_pct : float or None
        Held-out RMSE of the base model and of the final one, % of the output range.
    effects : tuple of str
        The effects of the final model (registry names).
    """

    findings: tuple[str, ...]
    baseline_rmse_pct: float | None
    final_rmse_pct: float | None
    effects: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class SessionDiagnosis:
    """A session's diagnosis as the pages show it (the diagnosis job's result, shared by the
    REST API and the viser GUI; its JSON is made by the routers,
    ``routers/schemas.py::diagnosis_json``).

    Attributes
    ----------
    result : DiagnosisResult
        The core's result (its report document is ``result.to_dict()``).
    summary : DiagnosisSummary
        Its findings in words, in the recording's units.
    """

    result: DiagnosisResult
    summary: DiagnosisSummary


def session_diagnosis(result: DiagnosisResult, units: Mapping[str, str] | None = None
                      ) -> SessionDiagnosis:
    """The :class:`SessionDiagnosis` of ``result``, its findings in ``units`` (the
    recording's)."""
    return SessionDiagnosis(result, diagnosis_summary(result.to_dict(), units))


def diagnosis_summary(d: dict[str, Any], units: Mapping[str, str] | None = None
                      ) -> DiagnosisSummary:
    """The findings of a diagnosis document in sentences for people (accepted effects with
    their held-out error before and after in the output's unit, where they act, ambiguities,
    untestable effects), and the held-out RMSE before and after.

    Parameters
    ----------
    d : dict
        ``DiagnosisResult.to_dict()``.
    units : dict, optional
        The recording's units (``input``, ``output``), as read from the CSV.
    """
    u_unit, y_unit = _unit(units, "input"), _unit(units, "output")
    recs = d.get("recordings") or []
    timed = all(r.get("time_axis", True) for r in recs)
    findings: list[str] = []
    base_doc, final = d.get("baseline", {}), d.get("final", {})
    base_words = base_name(base_doc.get("model"))
    b, f = base_doc.get("heldout_rmse"), final.get("heldout_rmse")
    bp, fp = base_doc.get("heldout_rmse_pct"), final.get("heldout_rmse_pct")
    if isinstance(b, int | float) and isinstance(bp, int | float):
        text = (f"On the rows the fit never saw, the {base_words} model is off by "
                f"{_qty(b, y_unit)} RMS ({bp:.3g} % of the output range)")
        if final.get("effects") and isinstance(f, int | float) and isinstance(fp, int | float):
            text += (f"; with {', '.join(_effect_words(e) for e in final['effects'])} added, "
                     f"by {_qty(f, y_unit)} ({fp:.3g} %)")
        findings.append(text + ".")
    effects = d.get("effects", [])
    for e in effects:
        text = f"Found {_effect_words(e.get('name'))}"
        before, after = e.get("heldout_rmse_before"), e.get("heldout_rmse_after")
        if len(effects) == 1 and isinstance(before, int | float) and isinstance(f, int | float):
            # one "after" everywhere: the final model is the base with this effect
            text += (f": modelling it lowers the held-out error from {_qty(before, y_unit)} "
                     f"to {_qty(f, y_unit)} RMS")
        elif isinstance(before, int | float) and isinstance(after, int | float) and before > 0:
            text += (f": added to the effects before it, it lowers the held-out error by "
                     f"{100 * (before - after) / before:.0f} %")
        text += "."
        where = _where_text(e.get("where") or {}, u_unit, timed, len(recs) > 1)
        if where:
            text += f" {_cap(where)}."
        if e.get("explanation"):
            text += f" {in_words(e['explanation'].strip())}"
        params = _param_text(e.get("parameters") or {}, u_unit, str(e.get("name") or ""), y_unit)
        if params:
            text += f" Fitted: {params}."
        findings.append(text)
    # (the residual against the noise floor: "explains the data" only when it is at it)
    adequacy = d.get("adequacy") or {}
    if not d.get("effects"):
        findings.append(f"No missing physics detected: the {base_words} model explains "
                        "the data" if adequacy.get("adequate") is True else
                        "No effect of the list improved the held-out fit significantly.")
    if adequacy.get("adequate") is False and adequacy.get("text"):
        findings.append(f"Not explained: {_with_units(in_words(adequacy['text']), y_unit)}")
    choice = base_doc.get("base_choice") or {}
    if choice.get("kind") not in (None, "pi"):  # a base other than the PI was chosen
        findings.append(f"Base model: {in_words(str(choice.get('text', '')))}")
    for r in d.get("recording_specific", []):
        findings.append("Seen in this recording only, so not claimed: "
                        f"{in_words(str(r.get('text', '')))}")
    for a in d.get("ambiguous", []):
        words = " or ".join(_effect_words(x) for x in a.get("effects", []))
        findings.append(in_words(_because(f"Cannot tell {words} apart", a.get("reason"),
                                          "To decide, record", a.get("experiment"))))
    findings.extend(_untestable_words(d.get("untestable", [])))
    return DiagnosisSummary(tuple(findings), bp, fp, tuple(final.get("effects", [])))


def _untestable_words(untestable: list[dict[str, Any]]) -> list[str]:
    """The untestable effects in sentences: those that cannot be tested for one reason
    (every time effect of a file without a time axis) in one sentence that names them all,
    in the order of their first mention."""
    groups: dict[tuple[str, str], list[str]] = {}
    for u in untestable:
        key = (str(u.get("reason") or ""), str(u.get("experiment") or ""))
        groups.setdefault(key, []).append(_effect_words(u.get("name")))
    out = []
    for (reason, experiment), names in groups.items():
        listed = names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"
        out.append(in_words(_because(f"{_cap(listed)} cannot be tested with this recording",
                                     reason, "It would need", experiment)))
    return out


def run_diagnosis(rec: Recording, model: Model,
                  progress: Callable[..., None] | None = None) -> SessionDiagnosis:
    """:func:`core.diagnosis.diagnose` of ``rec``: the core's ``DiagnosisResult`` with its
    findings in words, in the recording's units (:class:`SessionDiagnosis`).

    The baseline has as many operators as the PI part of ``model`` (4 to 25, else 10). An
    upload of every run of a file (:mod:`.loops`) is diagnosed run by run, each its own
    recording, as ``hyst diagnose FILE`` reads the file (:func:`.loops.file_recordings`).
    ``progress`` is passed
    on to :func:`~core.diagnosis.diagnose` (a job's worker passes it to the server; a cancel
    kills the worker, :mod:`.worker`).
    """
    from app.services.analysis.loops import file_recordings
    from app.services.explore.simulation import pi_part
    from core.diagnosis import diagnose

    pi = pi_part(model)
    n = int(min(25, max(4, pi.n if pi is not None else 10)))
    result = diagnose(file_recordings(rec), "pi", n_operators=n, progress=progress)
    return session_diagnosis(result, rec.units)


def diagnosis_html(result: Any, units: dict[str, str] | None = None) -> str:
    """The self-contained HTML report (:mod:`.diagnosis_report`) of a diagnosis result,
    its axes in ``units`` (the recording's: ``time``, ``input``, ``output``)."""
    import tempfile
    from pathlib import Path

    from app.services.analysis.diagnosis_report import write_report

    with tempfile.TemporaryDirectory() as tmp:
        return write_report(result, Path(tmp) / "report.html", units).read_text(
            encoding="utf-8")


def model_document(result: Any, source: str) -> ParameterSet:
    """The final model of ``result`` as a parameter set (units from the first recording when
    the parameter-set validator knows them): what ``--save-model`` writes."""
    from core.paramset import ParameterSet, clean_unit

    first = result.records[0]
    # a header's unit that is not a unit (see core.paramset.unit_problem) becomes unknown
    units = {k: clean_unit(first.units.get(k) or d)
             for k, d in (("input", "V"), ("output", "um"), ("time", "s"))}
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
    return ParameterSet.from_model(result.model, units=units, source=source, fit=summary,
                                   notes=notes)


def save_model(result: Any, path: str | Path, source: str) -> Path:
    """Write :func:`model_document` of ``result`` to ``path``."""
    return model_document(result, source).save(path)


def diagnosis_source(files: Sequence[str | Path]) -> str:
    """The provenance ``source`` of a diagnosis of ``files``."""
    return "hyst diagnose " + " ".join(Path(f).name for f in files)


def diagnosis_json(result: Any) -> str:
    """The ``--json`` document of ``result`` (one JSON object, one line)."""
    return json.dumps(result.to_dict(), allow_nan=False)


def diagnose_files(files: Sequence[str | Path], options: CsvOptions, progress: Progress, *,
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
    recs = as_records([Path(f) for f in files], options)
    say_read(progress, recs)
    return diagnose(recs, model=model, train=train, test=test, n_operators=operators,
                    effects=chosen, base=base, auto_resolution=not fixed_grid,
                    crossfit=False if no_crossfit else None,
                    progress=lambda frac, msg: progress(f"{100 * frac:3.0f} % {msg}"))
