"""Identification: recordings in, invertible PI-family parameter sets and honest metrics out.

* :class:`PIRegressor` — classical PI (weights by NNLS on streamed normal equations).
* :class:`FitReport` — modelling, held-out, compensation and inverse-input errors.
* :func:`place_thresholds` — uniform or travel-quantile threshold placement.
* :func:`stream_gram` / :func:`solve_constrained` — the streaming linear-algebra layer.
"""

from __future__ import annotations

from .gram import Segment, solve_constrained, stream_gram, stream_tsqr
from .metrics import FitReport, PartStats
from .pi import PIRegressor, fit_linear_pi
from .thresholds import place_thresholds

__all__ = [
    "FitReport",
    "PIRegressor",
    "PartStats",
    "Segment",
    "fit_linear_pi",
    "place_thresholds",
    "solve_constrained",
    "stream_gram",
    "stream_tsqr",
]
