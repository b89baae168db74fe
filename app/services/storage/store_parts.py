"""The parts of a stored session (config, recording, fit, diagnosis) as JSON and ``.npz``,
and their checked decoding: nothing stored is ever executed (no pickle).

Each part is decoded and validated on its own; a part that does not decode or validate
raises :class:`DamagedPartError` naming it (the store then resets the session, see
:mod:`app.services.storage.store`). A diagnosis part written by older versions (a pickle) is such a
damaged part: it is never unpickled.

A diagnosis is stored as its core result, :meth:`DiagnosisResult.to_json
<core.diagnosis.results.DiagnosisResult.to_json>` (zlib-compressed JSON in the diagnosis
blob), and rebuilt as an equal result. Sessions stored before 2026-12-05 hold the report
instead (the findings as the pages showed them, beside ``DiagnosisResult.to_dict()``) and
the diagnosed model's document: such a report cannot become a result (it holds derived
numbers only, none of the rows, fits and predictions a result is made of), so it is dropped
when it is read, and the session says so in words (:data:`OLD_DIAGNOSIS_NOTE`).
"""

from __future__ import annotations

import dataclasses
import io
import json
import zlib
from typing import TYPE_CHECKING, Any

import numpy as np

from app.services.analysis.fitting import fit_outcome
from app.services.explore.config import Config, config_from_dict
from core.base import Model
from core.paramset import ParameterSet
from core.recordings import Recording

if TYPE_CHECKING:  # core.fitting is imported when a stored fit is read (scipy: 0.5 s)
    from core.diagnosis.results import DiagnosisResult
    from core.fitting.entry import FitOutcome

__all__ = [
    "PARTS",
    "MAX_DIAGNOSIS_BYTES",
    "OLD_DIAGNOSIS_NOTE",
    "DamagedPartError",
    "StoredDiagnosis",
    "decode_config",
    "decode_diagnosis",
    "decode_document",
    "decode_fit",
    "decode_recording",
    "dump_json",
    "encode_diagnosis",
    "encode_fit",
    "recording_from_blob",
    "recording_to_blob",
]

#: The parts of a stored session, in the words a message uses.
PARTS = ("config", "recording", "fit", "diagnosis")


class DamagedPartError(ValueError):
    """A stored part of a session does not decode or validate.

    Parameters
    ----------
    part : str
        One of :data:`PARTS`.
    reason : str
        What is wrong with it.
    """

    def __init__(self, part: str, reason: str) -> None:
        super().__init__(f"the stored {part} of a session is damaged: {reason}")
        self.part = part
        self.reason = reason


def dump_json(x: Any) -> str | None:
    """``x`` as JSON text (numpy numbers and arrays as numbers and lists), ``None`` stays."""
    return None if x is None else json.dumps(x, allow_nan=False, default=_jsonable)


def _jsonable(x: Any) -> Any:
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"cannot store {type(x).__name__}")


def _why(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"[:200]


def decode_document(part: str, text: str | bytes | None) -> dict[str, Any] | None:
    """The JSON object ``text`` (``None`` stays ``None``).

    Raises
    ------
    DamagedPartError
        If ``text`` is no JSON object.
    """
    if text is None:
        return None
    try:
        doc = json.loads(text)
    except (ValueError, TypeError) as exc:  # JSONDecodeError and bad UTF-8 are ValueErrors
        raise DamagedPartError(part, f"it is no JSON ({_why(exc)})") from None
    if not isinstance(doc, dict):
        raise DamagedPartError(part, f"it is JSON {type(doc).__name__}, not an object")
    return doc


def _model(part: str, doc: Any) -> Model:
    from core.base import model_from_dict

    try:
        return model_from_dict(doc)
    except (ValueError, TypeError, KeyError) as exc:  # ParameterError is a ValueError
        raise DamagedPartError(part, f"its model is invalid ({_why(exc)})") from None


def decode_config(text: str) -> Config:
    """The stored config, its model checked (a model that does not build is damage)."""
    doc = decode_document("config", text)
    try:
        cfg = config_from_dict(doc or {})
    except (ValueError, TypeError, KeyError) as exc:
        raise DamagedPartError("config", _why(exc)) from None
    _model("config", cfg.model)
    return cfg


def encode_fit(fit: FitOutcome | None) -> tuple[str | None, str | None]:
    """The fit part's two columns: the fitted model's document and ``{"parameter_set":
    the document hyst fit writes}`` (its provenance holds the kind, the report and the
    warnings: everything :func:`decode_fit` rebuilds the outcome from)."""
    if fit is None:
        return None, None
    return (dump_json(fit.model.to_dict()),
            dump_json({"parameter_set": fit.parameter_set.to_dict()}))


def decode_fit(fitted: str | None, report: str | None) -> FitOutcome | None:
    """The stored fit as a :class:`~core.fitting.FitOutcome` (without its estimator).

    Two stored forms are read: ``{"parameter_set": ...}`` (:func:`encode_fit`), and the
    form of sessions stored before 2026-12-05, the fitted model's document beside the
    explorer's report (``FitReport.to_dict()`` plus ``kind``, ``n_operators`` and the
    errors on the whole recording).

    Raises
    ------
    DamagedPartError
        The model does not build, or the report is not a fit report.
    """
    doc = decode_document("fit", fitted)
    rep = decode_document("fit", report)
    if doc is None and rep is None:
        return None
    try:
        if rep is not None and set(rep) == {"parameter_set"}:
            if doc is not None:  # the fitted model's column: it must build too
                _model("fit", doc)
            ps = ParameterSet.from_dict(rep["parameter_set"])
        else:  # the form stored before 2026-12-05
            if doc is None or rep is None:
                raise ValueError("the fitted model or its report is missing")
            ps = _old_fit(doc, rep)
        return fit_outcome(ps)
    except (ValueError, TypeError, KeyError) as exc:  # ParameterError is a ValueError
        raise DamagedPartError("fit", _why(exc)) from None


def _old_fit(doc: dict[str, Any], rep: dict[str, Any]) -> ParameterSet:
    """The parameter set of a fit stored in the explorer's old form (model and report)."""
    from core.base import model_from_dict
    from core.fitting.metrics import FitReport

    model = model_from_dict(doc)
    names = {f.name for f in dataclasses.fields(FitReport)}
    return ParameterSet.from_model(model, source="hysteresis explorer", fit={
        "model": str(rep.get("kind") or model.type_name),
        "n_operators": rep.get("n_operators"),
        "report": {k: v for k, v in rep.items() if k in names},
        "warnings": list(rep.get("warnings") or []),
    })


#: The most bytes a stored diagnosis blob may inflate to (a result of the largest recording
#: a server takes is far below it; more is damage, not a result).
MAX_DIAGNOSIS_BYTES = 1 << 30


#: What a session stored before 2026-12-05 says of its diagnosis, dropped when it loads.
OLD_DIAGNOSIS_NOTE = (
    "this session's diagnosis was stored by an older version of Hysteresis Explorer, which "
    "kept only its findings and not the result the Diagnosis view and the HTML report are "
    "drawn from, so it was dropped when the session was opened (the recording, the fit and "
    "the model are kept); run the diagnosis again")


@dataclasses.dataclass(frozen=True)
class StoredDiagnosis:
    """The diagnosis part of a stored session, as :func:`decode_diagnosis` read it.

    Attributes
    ----------
    result : DiagnosisResult or None
        The stored result (``None``: no diagnosis, or one of the old form, dropped).
    note : str or None
        Words for the user when a diagnosis stored in the old form was dropped
        (:data:`OLD_DIAGNOSIS_NOTE`); ``None`` otherwise.
    """

    result: DiagnosisResult | None = None
    note: str | None = None


def encode_diagnosis(result: DiagnosisResult | None) -> bytes | None:
    """The diagnosis part's blob: ``{"result": DiagnosisResult.to_json()}`` compressed
    (zlib); ``None`` without a diagnosis."""
    if result is None:
        return None
    text = json.dumps({"result": result.to_json()}, allow_nan=False)
    return zlib.compress(text.encode(), 6)


def decode_diagnosis(report: str | None, blob: bytes | None) -> StoredDiagnosis:
    """The stored diagnosis: its result (``DiagnosisResult.from_json`` of the blob of
    :func:`encode_diagnosis`), or, for the form stored before 2026-12-05, nothing and
    :data:`OLD_DIAGNOSIS_NOTE`.

    The old form is the report in the ``diagnosis`` column (the page's findings and
    ``DiagnosisResult.to_dict()``) beside the blob JSON ``{"diagnosed": model document or
    null}``. It is dropped whatever it holds: a report of derived numbers cannot be rebuilt
    into a result, and a session is better kept without it than reset for it.

    Raises
    ------
    DamagedPartError
        The blob is neither form (e.g. an old pickle, never unpickled), or the stored
        result does not inflate or read back.
    """
    if blob is None:
        return StoredDiagnosis(note=None if report is None else OLD_DIAGNOSIS_NOTE)
    if blob.lstrip()[:1] != b"{":  # the compressed result (its row's column is not read)
        return StoredDiagnosis(result=_result(blob))
    doc = decode_document("diagnosis", blob)
    if doc is None or set(doc) != {"diagnosed"}:
        raise DamagedPartError("diagnosis", "its blob is not the stored diagnosed model")
    return StoredDiagnosis(note=OLD_DIAGNOSIS_NOTE)


def _result(blob: bytes) -> DiagnosisResult:
    """The diagnosis result of a compressed blob (:func:`encode_diagnosis`)."""
    from core.diagnosis.results import DiagnosisResult

    try:
        inflate = zlib.decompressobj()
        text = inflate.decompress(blob, MAX_DIAGNOSIS_BYTES)
        if inflate.unconsumed_tail or not inflate.eof:
            raise ValueError("it is cut short or inflates beyond "
                             f"{MAX_DIAGNOSIS_BYTES >> 20} MB")
    except (zlib.error, ValueError) as exc:
        raise DamagedPartError("diagnosis", f"its blob does not inflate ({_why(exc)})") from None
    doc = decode_document("diagnosis", text)
    if doc is None or set(doc) != {"result"}:
        raise DamagedPartError("diagnosis", "its blob is not a stored diagnosis result")
    try:
        return DiagnosisResult.from_json(doc["result"])
    except ValueError as exc:  # DocumentError says where
        raise DamagedPartError("diagnosis", str(exc)[:300]) from None


def recording_to_blob(rec: Recording) -> bytes:
    """``rec`` as bytes (``.npz`` with the arrays and a JSON ``meta`` entry)."""
    arrays: dict[str, Any] = {"t": rec.t, "u": rec.u, "y": rec.y}
    if rec.lines is not None:
        arrays["lines"] = np.asarray(rec.lines)
    extra_text: dict[str, list[str]] = {}
    for k, v in rec.extra.items():
        if np.asarray(v).dtype.kind in "biuf":
            arrays[f"extra:{k}"] = np.asarray(v, dtype=np.float64)
        else:
            extra_text[k] = [str(x) for x in v]
    meta = {"name": rec.name, "units": dict(rec.units), "columns": dict(rec.columns),
            "extra_units": dict(rec.extra_units), "source": rec.source, "run": rec.run,
            "cleaning": list(rec.cleaning), "has_time": rec.has_time,
            "citation": rec.citation, "extra_text": extra_text}
    buf = io.BytesIO()
    np.savez(buf, meta=np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8), **arrays)
    return buf.getvalue()


def recording_from_blob(data: bytes) -> Recording:
    """Inverse of :func:`recording_to_blob` (arrays only: ``allow_pickle=False``)."""
    with np.load(io.BytesIO(data), allow_pickle=False) as z:
        meta = json.loads(bytes(z["meta"]).decode())
        extra: dict[str, np.ndarray] = {k[6:]: z[k] for k in z.files if k.startswith("extra:")}
        extra.update({k: np.asarray(v, dtype=str) for k, v in meta["extra_text"].items()})
        return Recording(
            t=z["t"], u=z["u"], y=z["y"], name=meta["name"], units=meta["units"],
            columns=meta["columns"], extra=extra, extra_units=meta["extra_units"],
            source=meta["source"], run=meta["run"], cleaning=tuple(meta["cleaning"]),
            has_time=meta["has_time"], citation=meta["citation"],
            lines=z["lines"] if "lines" in z.files else None,
        )


def decode_recording(blob: bytes | None) -> Recording | None:
    """The stored recording (``None`` stays ``None``)."""
    if blob is None:
        return None
    try:
        return recording_from_blob(blob)
    except Exception as exc:  # noqa: BLE001 - zip, npz, JSON and Recording errors alike
        raise DamagedPartError("recording", _why(exc)) from None
