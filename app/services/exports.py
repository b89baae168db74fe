"""Parameter-set documents and download bytes of the explorer's model (no web imports).

The document is :class:`core.paramset.ParameterSet`, ``.mat`` files come from
:func:`core.export_mat.export_mat` and C code from :func:`core.export_c.generate_c`.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from core.base import Model, model_from_dict
from core.exceptions import NotInvertibleError, ParameterError
from core.export_c import generate_c
from core.export_mat import export_mat
from core.paramset import (
    ParameterSet,
    ParameterSetError,
    load_parameter_set,
    model_from_document,
)

from .sessions import Session

__all__ = [
    "EXPORT_FORMATS",
    "export_bytes",
    "export_session",
    "parameter_set",
    "parameter_set_from_document",
    "parameter_set_model",
]

#: Download formats of a parameter set.
EXPORT_FORMATS = ("json", "mat", "c")


def parameter_set(model: Model, fit: dict[str, Any] | None = None) -> ParameterSet:
    """``model`` as a parameter set with the explorer as its source (and the fit report)."""
    return ParameterSet.from_model(model, source="hysteresis explorer", fit=fit)


def parameter_set_from_document(
    doc: Any, *, source: str | None = None, require_inverse: bool = False
) -> ParameterSet:
    """A parameter set from a parsed JSON document (an upload, ``hyst`` model files).

    A document with ``"format"`` is a full parameter set (:func:`core.paramset.load_parameter_set`);
    otherwise it is a ``{"model": ...}`` wrapper or a bare ``Model.to_dict()`` document (the
    JSON editor, hand-written files), wrapped with default units and ``source``.

    Raises
    ------
    ParameterSetError
        If the document is malformed (the message names the JSON path).
    NotInvertibleError
        ``require_inverse`` and the model has no inverse.
    """
    if not isinstance(doc, dict):
        raise ParameterSetError("a parameter set must be a JSON object")
    if "format" in doc:
        return load_parameter_set(doc, require_inverse=require_inverse)
    model = model_from_document(doc["model"] if "model" in doc else doc)
    ps = ParameterSet.from_model(model, source=source)
    if require_inverse:
        ps.check_invertible()
    return ps


def parameter_set_model(doc: Any) -> Model:
    """The model of :func:`parameter_set_from_document` ``(doc)``."""
    return parameter_set_from_document(doc).model


def export_bytes(
    model: Model, fmt: str, code: str = "", fit: dict[str, Any] | None = None,
    dt: float | None = None,
) -> tuple[str, bytes]:
    """``(filename, content)`` of ``model`` exported as ``json``, ``mat`` or ``c``.

    ``c`` is one file: the generated header followed by the source (the inverse compensator
    and the forward model when the model is invertible, the forward model only otherwise);
    ``dt`` (s) is the sample time baked into dynamic stages (creep, lag, resonance, ...).

    Raises
    ------
    ParameterError
        For an unknown format, or a model stage without a C emitter.
    """
    stem = f"hysteresis-{model.type_name}{'-' + code if code else ''}"
    ps = parameter_set(model, fit)
    if fmt == "json":
        return f"{stem}.json", ps.to_json().encode()
    if fmt == "mat":
        with tempfile.TemporaryDirectory() as tmp:
            return f"{stem}.mat", export_mat(ps, Path(tmp) / "p.mat").read_bytes()
    if fmt == "c":
        try:
            model.inverse()
            invertible = True
        except (NotInvertibleError, ParameterError):
            invertible = False
        cc = generate_c(ps, "hyst", inverse=invertible, forward=True,
                        dt=dt if model.is_dynamic else None)
        src = cc.source.replace(f'#include "{cc.name}.h"', f"/* {cc.name}.h inlined above */")
        text = f"/* ===== {cc.name}.h ===== */\n{cc.header}\n/* ===== {cc.name}.c ===== */\n{src}"
        return f"{stem}.c", text.encode()
    raise ParameterError(f"unknown export format {fmt!r}; known: {list(EXPORT_FORMATS)}")


def export_session(session: Session, fmt: str) -> tuple[str, bytes]:
    """:func:`export_bytes` of ``session``'s current model (with the fit report when the
    model is the fitted one); dynamic models get the sample time of the session's
    recording, else of its signal."""
    cfg, _ = session.snapshot()
    fit = session.fit_report if session.fitted == cfg.model else None
    rec = session.recording
    if rec is not None and rec.t.size > 1:
        dt = float(rec.t[1] - rec.t[0])
    else:
        dt = cfg.signal.duration / max(cfg.signal.samples - 1, 1)
    return export_bytes(model_from_dict(cfg.model), fmt, session.code, fit, dt=dt)
