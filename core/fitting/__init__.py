"""Identification: recordings in, invertible PI-family parameter sets and honest metrics out.

Estimators (sklearn style: ``fit(u, y)`` or ``fit(recording)``, ``predict(u)``, fitted
attributes ``model_``, ``full_model_`` (offsets included, exact ``inverse()``), ``report_``):

* :class:`PIRegressor` — classical PI; weights by NNLS on streamed normal equations.
* :class:`DeadZoneGPIRegressor` — ``y = c + P[γ(v)]`` (paper 001 order), variable projection.
* :class:`ModifiedPIRegressor` — Kuhnen's ``y = c0 + S[P[v] + c1]``, linear in parameters.
* :class:`TanhGPIRegressor` — ``y = c + P[κ(v)]`` with the tanh envelope, variable projection.
* :class:`DigitizedPIRegressor` — paper 000 digitized model from a classical fit.
* :class:`PreisachRegressor` — level-dependent Preisach model (play form), NNLS on streamed
  normal equations of its level-segment columns.
* :class:`BoucWenRegressor` — rate-independent Bouc-Wen bank: bounded least squares on a
  grid of element shapes, the kept shapes polished (variable projection).
* :class:`MenegottoPintoRegressor` — Menegotto-Pinto bank of smooth stop elements
  (non-Masing loops): bounded least squares on a fixed element grid.
* :class:`StopPIRegressor` — stop-operator Prandtl model (Maxwell-slip elements) for
  clockwise, friction-like loops; the PI estimator with stop operators.

The kinds fit the orientation of the data's loops (:func:`loop_orientation`, the signed loop
area): clockwise loops are fitted with stop operators by the PI estimator and with the
clockwise elements by the Bouc-Wen and Preisach ones, and the report says which.

Every estimator takes the same option keywords (``n_operators``, ``constraint``,
``initial_memory``; a value a kind cannot use raises
:class:`~core.exceptions.UnsupportedOptionError`). :func:`fit_recordings` is the one fitting
entry point of ``hyst fit``, the explorer and ``hyst batch fit``: recordings, fit kind,
options and :class:`TimeWindow` s in, a frozen :class:`FitOutcome` (model, report, warnings,
parameter-set document) out.

Each model class names its estimator once (``estimator = "core.fitting:PIRegressor"`` on
:class:`core.pi.PIModel`, ...); :func:`core.models.fit_kinds` and
:func:`core.models.estimator_class` derive the fit kinds of the command line and the explorer
from those declarations, so a new estimator is registered by declaring it on its model class.

:class:`FitReport` holds training / held-out / compensation / inverse-input errors;
:func:`place_thresholds`, :func:`stream_gram` and :func:`solve_constrained` are the
building blocks.
"""

from __future__ import annotations

from .boucwen import BoucWenRegressor
from .digitized import DigitizedPIRegressor
from .entry import EmptyWindowError, FitOutcome, TimeWindow, fit_recordings
from .gpi import DeadZoneGPIRegressor, ModifiedPIRegressor, TanhGPIRegressor
from .gram import Segment, solve_constrained, stream_gram, stream_tsqr
from .metrics import FitReport, PartStats
from .nonmasing import MenegottoPintoRegressor
from .orientation import LoopOrientation, loop_orientation
from .pi import PIRegressor, fit_linear_pi
from .preisach import PreisachRegressor
from .stop import StopPIRegressor
from .thresholds import place_thresholds, reversal_indices, wipeout_index

__all__ = [
    "BoucWenRegressor",
    "MenegottoPintoRegressor",
    "DeadZoneGPIRegressor",
    "DigitizedPIRegressor",
    "EmptyWindowError",
    "FitOutcome",
    "FitReport",
    "LoopOrientation",
    "ModifiedPIRegressor",
    "PIRegressor",
    "PartStats",
    "PreisachRegressor",
    "Segment",
    "StopPIRegressor",
    "TanhGPIRegressor",
    "TimeWindow",
    "fit_linear_pi",
    "fit_recordings",
    "loop_orientation",
    "place_thresholds",
    "reversal_indices",
    "solve_constrained",
    "stream_gram",
    "stream_tsqr",
    "wipeout_index",
]
