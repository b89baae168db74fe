"""``summary.csv`` of a batch and the robust (median / MAD) outlier rule of the fleet report."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .results import RecordingResult

__all__ = ["COLUMNS", "Outlier", "fleet_metrics", "robust_outliers", "write_summary"]

#: Columns of ``summary.csv``, in order.
COLUMNS = ("file", "name", "samples", "model", "n", "train_rmse", "train_rmse_pct",
           "heldout_rmse", "heldout_rmse_pct", "baseline_heldout_rmse_pct", "effects", "status",
           "error")

#: |robust z| above which a value is flagged (Iglewicz and Hoaglin's modified z-score).
OUTLIER_Z = 3.5
#: Fewest values a metric needs before outliers are flagged.
MIN_FOR_OUTLIERS = 5


def _num(x: float | int | None) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return ""
    return repr(float(x)) if isinstance(x, float) else str(x)


def write_summary(path: Path, rows: Sequence[RecordingResult]) -> Path:
    """Write one row per recording (empty cell = not reported / not applicable)."""
    with Path(path).open("w", encoding="utf-8", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(COLUMNS)
        for r in rows:
            w.writerow([r.file, r.name, r.samples if r.ok else "", r.model, _num(r.n_operators),
                        _num(r.train_rmse), _num(r.train_rmse_pct), _num(r.heldout_rmse),
                        _num(r.heldout_rmse_pct), _num(r.baseline_heldout_rmse_pct),
                        ";".join(r.effects), r.status, r.error])
    return Path(path)


def fleet_metrics(rows: Sequence[RecordingResult]) -> dict[str, dict[str, float]]:
    """Per metric, the value of each successful recording that has it.

    Metrics: ``held-out RMSE (% of range)``, ``train RMSE (% of range)``, ``baseline
    held-out RMSE (% of range)`` and every main scalar parameter.
    """
    out: dict[str, dict[str, float]] = {}
    for r in rows:
        if not r.ok:
            continue
        vals = {"held-out RMSE (% of range)": r.heldout_rmse_pct,
                "train RMSE (% of range)": r.train_rmse_pct,
                "baseline held-out RMSE (% of range)": r.baseline_heldout_rmse_pct,
                **r.parameters}
        for k, v in vals.items():
            if v is not None and math.isfinite(v):
                out.setdefault(k, {})[r.name] = float(v)
    return out


@dataclass(frozen=True)
class Outlier:
    """A value far from the fleet: ``|z| = 0.6745 |x - median| / MAD > 3.5``."""

    name: str
    metric: str
    value: float
    median: float
    mad: float
    z: float


def robust_outliers(metrics: dict[str, dict[str, float]]) -> list[Outlier]:
    """Values whose modified z-score exceeds :data:`OUTLIER_Z`, largest first.

    Metrics with fewer than :data:`MIN_FOR_OUTLIERS` values or a zero MAD (more than half
    the fleet identical) flag nothing.
    """
    found = []
    for metric, vals in metrics.items():
        if len(vals) < MIN_FOR_OUTLIERS:
            continue
        x = np.array(list(vals.values()))
        med = float(np.median(x))
        mad = float(np.median(np.abs(x - med)))
        if not mad > 0:
            continue
        for name, v in vals.items():
            z = 0.6745 * (v - med) / mad
            if abs(z) > OUTLIER_Z:
                found.append(Outlier(name, metric, v, med, mad, z))
    return sorted(found, key=lambda o: -abs(o.z))
