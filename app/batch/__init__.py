"""Batch fitting and diagnosis of many recordings on Dask (``hyst batch``).

>>> from app.batch import FitOptions, run_batch
>>> res = run_batch(["data/*.csv"], "out/", FitOptions(model="pi", n_operators=8))  # doctest: +SKIP
>>> [r.heldout_rmse_pct for r in res.succeeded]  # doctest: +SKIP

Every recording runs through the single-file command (:mod:`app.batch.single`), so
``out/<name>.json`` is what ``hyst fit`` / ``hyst diagnose --save-model`` writes for it.
"""

from __future__ import annotations

from .options import DiagnoseOptions, FitOptions
from .results import BatchResult, RecordingResult
from .runner import run_batch

__all__ = ["BatchResult", "DiagnoseOptions", "FitOptions", "RecordingResult", "run_batch"]
