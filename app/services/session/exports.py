"""Parameter-set documents and download bytes of the explorer's model (no web imports).

The document is :class:`core.paramset.ParameterSet`, ``.mat`` files come from
:func:`core.export_mat.export_mat`, C code from :func:`core.export_c.generate_c` and FMUs
from :func:`core.export_fmu.build_fmu` (compiled on this machine).
"""

from __future__ import annotations

import re
import tempfile
import threading
from pathlib import Path
from typing import Any

from app.services.explore.catalog import EXPORT_FORMATS
from app.services.session.sessions import Session
from app.services.words import type_words
from core.base import Model
from core.exceptions import NotInvertibleError, ParameterError
from core.export_c import generate_c
from core.export_fmu import FMI_VERSIONS, build_fmu
from core.export_mat import export_mat
from core.paramset import (
    ParameterSet,
    ParameterSetError,
    load_parameter_set,
    model_from_document,
)

__all__ = [
    "EXPORT_FORMATS",
    "fmi_version",
    "export_bytes",
    "export_session",
    "parameter_set",
    "parameter_set_from_document",
    "parameter_set_model",
]

#: FMU builds run the C compiler: at most two at a time in this process.
_FMU_BUILDS = threading.BoundedSemaphore(2)


def fmi_version(text: object) -> int:
    """The FMI version of an export request (``"3"``, ``"3.0"``, ``"2"``, ``"2.0"``).

    Raises
    ------
    ParameterError
        Anything else (the message lists the versions).
    """
    v = {"3": 3, "3.0": 3, "2": 2, "2.0": 2}.get(str(text).strip())
    if v is None:
        raise ParameterError(
            f"unknown FMI version {str(text)[:20]!r}; choose "
            + " or ".join(f"{x} (FMI {x}.0)" for x in FMI_VERSIONS))
    return v


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
    dt: float | None = None, *, fmi: int = 3, inverse: bool = False,
) -> tuple[str, bytes]:
    """``(filename, content)`` of ``model`` exported as ``json``, ``mat``, ``c`` or ``fmu``.

    ``c`` is one file: the generated header followed by the source (the inverse compensator
    and the forward model when the model is invertible, the forward model only otherwise);
    ``dt`` (s) is the sample time baked into dynamic stages (creep, lag, resonance, ...).
    ``fmu`` is a co-simulation FMU of FMI version ``fmi`` (3 or 2) running the model, or its
    inverse compensator with ``inverse``.

    Raises
    ------
    ParameterError
        For an unknown format, a model stage without a C emitter, no C compiler or FMI
        headers (FMU), or ``inverse`` for a model without an inverse.
    """
    # named for what the model is, in words ("hysteresis-dead-zone-gpi.json"); a session's
    # code is a key to the session and never goes into a file a student shares
    kind = re.sub(r"[^a-z0-9]+", "-", type_words(model.type_name).lower()).strip("-")
    stem = f"hysteresis-{kind or 'model'}{'-' + code if code else ''}"
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
    if fmt == "fmu":
        what = "compensator" if inverse else "model"
        with _FMU_BUILDS, tempfile.TemporaryDirectory() as tmp:
            path = build_fmu(ps, Path(tmp) / "h.fmu", fmi_version=fmi, inverse=inverse,
                             dt=dt if model.is_dynamic else None, name=f"hysteresis_{what}")
            return f"{stem}-{what}-fmi{fmi}.fmu", path.read_bytes()
    raise ParameterError(f"unknown export format {fmt!r}; known: {list(EXPORT_FORMATS)}")


def export_session(session: Session, fmt: str, *, fmi: int = 3,
                   inverse: bool = False) -> tuple[str, bytes]:
    """:func:`export_bytes` of ``session``'s current model (with the fit's provenance, as
    ``hyst fit`` writes it, when the model is the fitted one); dynamic models get the
    sample time of the session's recording, else of its signal."""
    with session.lock:  # the config and its typed model of one state
        cfg, _ = session.snapshot()
        model = session.model
    out = session.fit
    fit = (dict(out.parameter_set.provenance.fit or {})
           if out is not None and out.model.to_dict() == cfg.model else None)
    rec = session.recording
    if rec is not None and rec.t.size > 1:
        dt = float(rec.t[1] - rec.t[0])
    else:
        dt = cfg.signal.duration / max(cfg.signal.samples - 1, 1)
    return export_bytes(model, fmt, "", fit, dt=dt, fmi=fmi, inverse=inverse)
