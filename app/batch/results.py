"""Typed results of a batch: one :class:`RecordingResult` per recording, a :class:`BatchResult`."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from .single import Outcome

__all__ = ["BatchResult", "RecordingResult", "from_outcome", "scalar_parameters"]


@dataclass(frozen=True)
class RecordingResult:
    """One recording of a batch (one row of ``summary.csv``).

    Attributes
    ----------
    file : str
        The input path as given.
    name : str
        Output name: the parameter set is ``DIR/<name>.json``.
    status : {"ok", "failed"}
    error : str
        User-facing error message of a failed recording.
    samples : int
        Samples in the file.
    model : str
        Model family (``--model`` of fit; ``pi + effects`` chain for diagnose).
    n_operators : int or None
        Play operators of the fitted (final) model.
    train_rmse, train_rmse_pct : float
        RMSE on the training rows (output units, % of the output range); NaN when the
        command does not report it (diagnose).
    heldout_rmse, heldout_rmse_pct : float
        RMSE on held-out rows of the final model (NaN when nothing was held out).
    baseline_heldout_rmse_pct : float
        Diagnose: held-out RMSE of the PI baseline, % of range (NaN for fit).
    effects : tuple of str
        Diagnose: accepted effects, in order.
    parameters : dict
        Main scalar parameters (``"pi.p0"``, ``"offset.offset"``, ``"lag.tau_s"``...).
    elapsed_s : float
        Worker wall time (s); 0 for a resumed recording.
    resumed : bool
        Taken from an earlier run (same content and options).
    fmu : str
        With ``--fmu``: the FMU's path in the output folder (``""``: none).
    fmu_note : str
        What the FMU holds, or why there is none.
    """

    file: str
    name: str
    status: str
    error: str = ""
    samples: int = 0
    model: str = ""
    n_operators: int | None = None
    train_rmse: float = math.nan
    train_rmse_pct: float = math.nan
    heldout_rmse: float = math.nan
    heldout_rmse_pct: float = math.nan
    baseline_heldout_rmse_pct: float = math.nan
    effects: tuple[str, ...] = ()
    parameters: dict[str, float] = field(default_factory=dict)
    elapsed_s: float = 0.0
    resumed: bool = False
    fmu: str = ""
    fmu_note: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["effects"] = list(self.effects)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any], **changes: Any) -> RecordingResult:
        kw = {k: d[k] for k in cls.__dataclass_fields__ if k in d}
        kw["effects"] = tuple(kw.get("effects", ()))
        kw.update(changes)
        return cls(**kw)


@dataclass(frozen=True)
class BatchResult:
    """Outcome of :func:`app.batch.run_batch`.

    Attributes
    ----------
    kind : {"fit", "diagnose"}
    output : Path
        The output folder.
    recordings : tuple of RecordingResult
        In input order.
    summary_csv, report_html : Path
    elapsed_s : float
        Wall time of the whole batch (s).
    workers : int
        Worker threads the cluster had.
    """

    kind: str
    output: Path
    recordings: tuple[RecordingResult, ...]
    summary_csv: Path
    report_html: Path
    elapsed_s: float
    workers: int

    @property
    def failed(self) -> tuple[RecordingResult, ...]:
        return tuple(r for r in self.recordings if not r.ok)

    @property
    def succeeded(self) -> tuple[RecordingResult, ...]:
        return tuple(r for r in self.recordings if r.ok)

    @property
    def resumed(self) -> tuple[RecordingResult, ...]:
        return tuple(r for r in self.recordings if r.resumed)


def scalar_parameters(model: dict[str, Any]) -> dict[str, float]:
    """Main scalar parameters of a model document: ``"<type>.<field>"`` for every finite
    scalar, ``"<type>.n"`` for the length of a ``thresholds`` vector (nested chains walked)."""
    out: dict[str, float] = {}

    def walk(d: Any) -> None:
        if isinstance(d, list):
            for x in d:
                walk(x)
            return
        if not isinstance(d, dict):
            return
        t = str(d.get("type", "model"))
        for k, v in d.items():
            if isinstance(v, bool) or k == "type":
                continue
            if isinstance(v, (int, float)) and math.isfinite(v):
                out.setdefault(f"{t}.{k}", float(v))
            elif k == "thresholds" and isinstance(v, list):
                out.setdefault(f"{t}.n", float(len(v)))
            else:
                walk(v)

    walk(model)
    return out


def _n_operators(params: dict[str, float]) -> int | None:
    ns = [v for k, v in params.items() if k.endswith(".n")]
    return int(ns[0]) if ns else None


def from_outcome(kind: str, file: str, name: str, outcome: Outcome) -> RecordingResult:
    """The summary row of one worker outcome."""
    if not outcome.ok:
        return RecordingResult(file, name, "failed", error=outcome.error,
                               elapsed_s=outcome.elapsed_s)
    ps = json.loads(outcome.parameter_set)
    params = scalar_parameters(ps["model"])
    fit = ps.get("provenance", {}).get("fit", {})
    common = dict(samples=outcome.samples, n_operators=_n_operators(params),
                  elapsed_s=outcome.elapsed_s, fmu_note=outcome.fmu_note,
                  fmu=fmu_path(name, outcome.fmu_note) if outcome.fmu else "")
    if kind == "fit":
        rep = fit["report"]
        test = rep.get("test") or {}
        return RecordingResult(
            file, name, "ok", model=str(fit.get("model", "")), parameters=params,
            train_rmse=rep["train"]["rmse"], train_rmse_pct=rep["train"]["rmse_pct"],
            heldout_rmse=test.get("rmse", math.nan),
            heldout_rmse_pct=test.get("rmse_pct", math.nan),
            **common)
    doc = json.loads(outcome.diagnosis)
    for e in doc["effects"]:
        for k, v in e["parameters"].items():
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
                params[f"{e['name']}.{k}"] = float(v)
    effects = tuple(doc["final"]["effects"])
    return RecordingResult(
        file, name, "ok", model="pi" + "".join(f" + {e}" for e in effects), parameters=params,
        heldout_rmse=doc["final"]["heldout_rmse"],
        heldout_rmse_pct=doc["final"]["heldout_rmse_pct"],
        baseline_heldout_rmse_pct=doc["baseline"]["heldout_rmse_pct"], effects=effects, **common)


def fmu_path(name: str, note: str) -> str:
    """Where a recording's FMU goes in the output folder (``fmu/<name>-<what>.fmu``)."""
    return f"fmu/{name}-{'compensator' if note == 'compensator' else 'model'}.fmu"


def write_json(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` (parents created)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
