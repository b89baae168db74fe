"""Synthetic CSV recordings and document comparison shared by the batch and fitting tests."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from core.pi import PIModel
from core.stages import Lag

FS = 2000.0
TRUTH = PIModel(0.4, [6.0, 12.0, 18.0, 24.0, 30.0, 36.0, 42.0, 48.0, 54.0, 60.0],
                0.05 * np.exp(-np.arange(1, 11) * 6.0 / 30.0))


def write_recording(path: Path, amp: float, seed: int, lag: float = 0.0) -> Path:
    """A 2 s, 2 Hz decaying sine of amplitude ``amp`` (V) through ``TRUTH`` (and a lag of
    ``lag`` s), 0.01 um of noise, written as ``t_s,u_V,y_um`` CSV."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, 2.0, 1 / FS)
    u = amp * np.sin(2 * np.pi * 2.0 * t) * np.exp(-t / 1.5)
    model = TRUTH >> Lag(lag) if lag else TRUTH
    y = model(u, dt=1 / FS) + 0.01 * rng.standard_normal(u.size)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, np.column_stack((t, u, y)), delimiter=",", header="t_s,u_V,y_um",
               comments="", fmt="%.10g")
    return path


def numbers(x: Any, prefix: str = "") -> dict[str, Any]:
    """Flatten a JSON document into ``{path: number}`` (strings kept as they are)."""
    if isinstance(x, dict):
        out: dict[str, Any] = {}
        for k, v in x.items():
            out.update(numbers(v, f"{prefix}/{k}"))
        return out
    if isinstance(x, list):
        out = {}
        for i, v in enumerate(x):
            out.update(numbers(v, f"{prefix}/{i}"))
        return out
    return {prefix: x}


def assert_same_document(doc: dict[str, Any], ref: dict[str, Any]) -> None:
    """The two documents have the same leaves (floats to 1e-9), creation time aside."""
    a = numbers(doc)
    b = numbers(ref)
    a.pop("/provenance/created", None)
    b.pop("/provenance/created", None)
    assert a.keys() == b.keys()
    for k, v in b.items():
        if isinstance(v, float):
            assert a[k] == pytest.approx(v, rel=1e-9, abs=1e-9), k
        else:
            assert a[k] == v, k


def read_json(path: Path) -> dict[str, Any]:
    return json.loads(path.read_text(encoding="utf-8"))


def small_fit(seed: int = 0) -> Any:
    """A session's fit (``FitOutcome``) of a 400-sample recording of Example 1 (4 operators,
    :func:`app.services.analysis.fitting.fit_recording`, the fit job's own path)."""
    from app.services.analysis.fitting import fit_recording
    from core.recordings import Recording

    t = np.arange(400) * 1e-3
    u = 3 * np.sin(2 * np.pi * 3 * t) * np.exp(-t)
    y = PIModel(0.72, [0.45, 0.9, 1.35], [0.6, 0.48, 0.3])(u)
    y = y + 1e-3 * np.random.default_rng(seed).standard_normal(u.size)
    return fit_recording(Recording(t, u, y, name="small"), 4)


def small_diagnosis() -> tuple[Any, Any]:
    """``(recording, DiagnosisResult)``: the session's diagnosis
    (:func:`app.services.analysis.diagnosis.run_diagnosis`, the diagnosis job's own path) of a
    1,500-sample recording of Example 1 followed by creep (about 1.5 s; it finds an effect)."""
    from app.services.analysis.diagnosis import run_diagnosis
    from app.services.explore.config import Config
    from core.base import Chain, model_from_dict
    from core.recordings import Recording
    from core.stages import Creep

    t = np.arange(1500) * 2e-3
    u = np.sin(2 * np.pi * t) * (1 + 0.5 * np.sin(2 * np.pi * 0.3 * t))
    base = model_from_dict(Config().model)
    y = Chain.of(base, Creep([0.05, 0.3], [0.1, 0.1]))(u, dt=2e-3)
    y = y + 1e-3 * np.random.default_rng(0).standard_normal(u.size)
    rec = Recording(t, u, y, name="creep", units={"input": "V", "output": "um"})
    result = run_diagnosis(rec, base).result
    assert result.effects
    return rec, result
