"""Digitized PI identification (paper 000): a classical fit converted to binary states.

:class:`DigitizedPIRegressor` fits the classical model with
:class:`~core.fitting.pi.PIRegressor` (so it is invertible, ``p0 > 0``), converts it with
:meth:`core.digitized.DigitizedPI.from_pi` over the input range of the data, and reports
the **discretisation error**: the digitized model against the classical model with the same
segments started in the same state (:meth:`DigitizedPI.to_pi`), on the recorded input. The
two agree exactly along paths whose reversals fall on state points; a reversal inside a
segment is not remembered by the digitized model (paper 000 §3.3 and
``shared/notes/seed-notes.md``), and that is what the number measures.

Initial state: the digitized model starts at the lower extreme of the major loop (all
digits 0; paper 000 has no "relaxed" state), so score windows that start after the input
has swept the range (the piezo record from 3.3 s), or expect an initial transient.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._typing import ArrayLike
from ..base import Chain
from ..digitized import DigitizedPI
from ..exceptions import ParameterError
from ..stages import Offset
from ._data import prepare, unpack_recordings
from .estimator import Estimator
from .gram import DEFAULT_CHUNK
from .pi import PIRegressor

__all__ = ["DigitizedPIRegressor"]


@dataclass(eq=False, repr=False)
class DigitizedPIRegressor(Estimator):
    """Fit a digitized PI model (paper 000) through an invertible classical fit.

    Parameters
    ----------
    n_operators : int, optional
        Play operators of the classical model (``n_operators + 1`` digits before
        refinement); ``None`` chooses by cross-validation.
    refine : int
        Split every segment into ``refine`` equal parts (finer state grid, smaller
        discretisation error; ``(n + 1) * refine`` digits).
    thresholds, include_offset, validation, min_slope, constraint, chunk
        As in :class:`~core.fitting.pi.PIRegressor`.
    initial_memory : {"keep"}
        Taken by every estimator (one signature, :func:`core.fitting.fit_recordings`);
        the digits start relaxed, so ``"exclude"`` raises
        :class:`~core.exceptions.UnsupportedOptionError`.

    Attributes
    ----------
    model_ : DigitizedPI
        Without the offset, in classical coordinates (``shift=False``).
    offset_ : float
    full_model_ : Chain
        ``model_ >> Offset(offset_)``.
    classical_ : PIRegressor
        The classical fit it was converted from.
    report_ : FitReport
        Errors of the digitized model; ``extra`` holds the discretisation RMSE / max
        (digitized vs classical with the same segments and start), the classical model's
        own test RMSE and the reversal error bound.
    """

    n_operators: int | None = None
    refine: int = 1
    thresholds: str | ArrayLike = "uniform"
    include_offset: bool = True
    validation: float = 0.2
    min_slope: float | None = None
    constraint: str = "nonnegative"
    chunk: int = DEFAULT_CHUNK
    initial_memory: str = "keep"

    def _fit(self, u: Any, y: Any, train: Any, test: Any) -> None:
        """Fit (the work of :meth:`fit`).

        Raises
        ------
        ParameterError
            Bad inputs, or ``constraint="slopes"`` with negative weights (paper 000's
            digits need non-decreasing slopes for the stated error bound; the conversion
            itself still works).
        """
        self._check_initial_memory()
        u, y = unpack_recordings(u, y)
        if int(self.refine) != self.refine or self.refine < 1:
            raise ParameterError(f"refine must be a positive integer, got {self.refine!r}")
        classical = PIRegressor.classical_start(self, validation=self.validation).fit(
            u, y, train=train, test=test)
        prep = prepare(u, y, train, test, validation=self.validation, min_train=1)
        lo = min(float(x.min()) for x in prep.us)
        hi = max(float(x.max()) for x in prep.us)
        r_top = float(classical.thresholds_[-1])
        if (hi - lo) / 2 <= r_top:  # the last digit needs 2 (u_A - r_n) > 0
            pad = r_top * (1 + 1e-6) - (hi - lo) / 2
            lo, hi = lo - pad, hi + pad
        pi = classical.model_
        dig = DigitizedPI.from_pi(pi, (lo, hi), refine=int(self.refine))
        self.classical_ = classical
        self.model_ = dig
        self.offset_ = classical.offset_
        self.full_model_ = Chain.of(dig, Offset(self.offset_))
        self.n_operators_ = classical.n_operators_
        segs = prep.segments(1)
        # discretisation error: digitized vs the classical model with the same segments
        # and the same start, on the recorded inputs (scored samples only)
        same = dig.to_pi()
        d_sse, d_max, d_n = 0.0, 0.0, 0
        for s in segs:
            d = dig(s.u) - same(s.u)
            m = s.labels >= 0
            d_sse += float(d[m] @ d[m])
            d_max = max(d_max, float(np.max(np.abs(d[m]))) if m.any() else 0.0)
            d_n += int(m.sum())
        extra: dict[str, Any] = {
            "n_operators": classical.n_operators_,
            "n_digits": dig.n,
            "u_range": [lo, hi],
            "discretisation_rmse": float(np.sqrt(d_sse / max(d_n, 1))),
            "discretisation_max_abs": d_max,
            "reversal_error_bound": dig.reversal_error_bound(),
            "classical_train_rmse": classical.report_.train.rmse,
            "classical_test_rmse": None if classical.report_.test is None
            else classical.report_.test.rmse,
        }
        self.report_ = self._scored_report(
            segs,
            model_type="digitized",
            n_parameters=classical.report_.n_parameters,
            invertible=dig.is_invertible,
            min_slope=float(np.min(dig.dy / dig.dx)),
            condition_number=classical.report_.condition_number,
            solver="classical " + classical.report_.solver + " + DigitizedPI.from_pi",
            extra=extra,
        )
