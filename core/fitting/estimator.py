"""What every estimator of the fitting package shares: the sklearn-style ``fit`` and
``predict``, the fitted attributes and their types, the checks every fit makes (its
``initial_memory`` rule, its smallest slope) and the scored :class:`FitReport`."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any, ClassVar, Self

import numpy as np

from .._typing import ArrayLike, Float1D
from ..base import Model
from ..exceptions import NotFittedError, ParameterError
from ._data import Prepared, as_recordings, check_initial_memory, masked_range
from .gram import Segment
from .metrics import FitReport, evaluate_fit

__all__ = ["Estimator", "default_min_slope", "without_compensation_scores"]

#: Whether the reports of fits run the fitted model's inverse (:func:`evaluate_fit`'s
#: compensation errors); off inside :func:`without_compensation_scores`.
_COMPENSATION_SCORED: ContextVar[bool] = ContextVar("compensation_scored", default=True)


@contextmanager
def without_compensation_scores() -> Iterator[None]:
    """Fits made inside leave their report's compensation errors unscored (NaN): the inverse
    is formed (a model without one raises as before) but not run.

    For callers that read only the fitted model and its predictions (the diagnosis fits
    every other model class to compare their residuals): running the inverse over every
    sample took about half of such a fit (the Bouc-Wen inverse 9 of 24 s of the adequacy
    check of four 50,000-sample recordings). The fitted model is the same either way.
    """
    token = _COMPENSATION_SCORED.set(False)
    try:
        yield
    finally:
        _COMPENSATION_SCORED.reset(token)


def default_min_slope(prep: Prepared, rel: float = 1e-3) -> float:
    """ε = ``rel`` × (output range / input range) on the training samples."""
    du = masked_range(prep.us, prep.train_masks) or masked_range(prep.us)
    return rel * masked_range(prep.ys, prep.train_masks) / du


class Estimator:
    """An sklearn-style estimator: ``fit(u, y, train=, test=)`` fits the model in place and
    returns the estimator, ``predict(u)`` runs it; a subclass writes ``_fit`` (and
    ``_model_for`` when its model's start depends on the recording).

    Attributes (set by ``fit``)
    ---------------------------
    model_ : Model
        The fitted model, without the output offset.
    offset_ : float
        The output offset (output units).
    full_model_ : Model
        ``model_ >> Offset(offset_)`` (serialisable, exactly invertible where the model is).
    report_ : FitReport
        Training / held-out / compensation errors and the kind's own numbers.
    """

    #: The ``initial_memory`` rules the estimator can apply (``("keep",)``: every recording is
    #: fitted from the relaxed state).
    initial_memory_rules: ClassVar[tuple[str, ...]] = ("keep",)
    initial_memory: str
    min_slope: float | None

    model_: Any
    offset_: float
    full_model_: Model
    report_: FitReport

    def fit(self, u: Any, y: Any = None, *, train: Any = None, test: Any = None) -> Self:
        """Fit the model.

        Parameters
        ----------
        u : array_like of shape (N,), or list of such, or Recording(s)
            Input record(s) (input units). With a list, the model's memory restarts at every
            recording. A :class:`core.recordings.Recording` (or a list of them) may be passed
            instead of ``(u, y)``.
        y : array_like of shape (N,), or list of such, optional
            Measured output(s) (output units), same lengths as ``u``; omitted with
            recordings.
        train, test : array_like of bool, shape (N,), or list of such, optional
            Samples used for fitting / held-out scoring (see
            :func:`core.fitting._data.prepare` for the rules). Samples in neither still
            drive the model's states.

        Returns
        -------
        Self
            ``self``, with the fitted attributes (``model_``, ``offset_``, ``full_model_``,
            ``report_``).

        Raises
        ------
        ParameterError
            Bad inputs (mismatched lengths, NaN, constant input or output, too few samples)
            or options (each message names it).

        Warns
        -----
        FitWarning
            Where the fit is poorly determined (a nearly collinear design, a slope on its
            lower bound); the kind's docstring says which.
        """
        self._fit(u, y, train, test)
        return self

    def _fit(self, u: Any, y: Any, train: Any, test: Any) -> None:  # pragma: no cover
        raise NotImplementedError

    # ------------------------------------------------------------------ predict
    def _check(self) -> None:
        if not hasattr(self, "full_model_"):
            raise NotFittedError(
                f"this {type(self).__name__} is not fitted yet; call fit(u, y) first"
            )

    def _model_for(self, u: Float1D) -> Any:
        """The fitted model (without the offset) started as it is for a recording with input
        ``u``; by default ``model_`` itself."""
        return self.model_

    def _output(self, u: Float1D) -> Float1D:
        """Predicted output of one non-empty record."""
        out: Float1D = self._model_for(u)(u) + self.offset_
        return out

    def predict(self, u: ArrayLike | Sequence[ArrayLike]) -> Float1D | list[Float1D]:
        """Predicted output ``model_(u) + offset_``, every record started as in ``fit``.

        Parameters
        ----------
        u : array_like of shape (N,), or list of such
            Input record(s) (input units).

        Returns
        -------
        ndarray of shape (N,), or list of such
            Predicted output (output units).

        Raises
        ------
        NotFittedError
            Before :meth:`fit`.
        """
        self._check()
        us, multi = as_recordings(u, "u")
        out = [self._output(x) if x.size else x.copy() for x in us]
        return out if multi else out[0]

    # ------------------------------------------------------------------ shared checks
    def _check_initial_memory(self) -> None:
        """``initial_memory`` against :attr:`initial_memory_rules`
        (:func:`core.fitting._data.check_initial_memory`)."""
        check_initial_memory(self)

    def _min_slope(self, prep: Prepared) -> float:
        """ε: ``min_slope`` or :func:`default_min_slope` of the training samples.

        Raises
        ------
        ParameterError
            ε is not a finite number > 0.
        """
        eps = float(self.min_slope) if self.min_slope is not None else default_min_slope(prep)
        if not (np.isfinite(eps) and eps > 0):
            raise ParameterError(f"min_slope = {eps!r} must be > 0 (it keeps the model invertible)")
        return eps

    # ------------------------------------------------------------------ report
    def _scored_report(
        self,
        segments: Sequence[Segment],
        *,
        model_type: str,
        n_parameters: int,
        invertible: bool,
        min_slope: float,
        condition_number: float,
        solver: str,
        extra: dict[str, Any],
        model_for: Callable[[Float1D], Any] | None = None,
        offset: float | None = None,
        train_labels: Sequence[int] = (0,),
        test_labels: Sequence[int] = (1,),
        run_inverse: bool = True,
    ) -> FitReport:
        """The :class:`FitReport` of the fitted model scored on ``segments``
        (:func:`core.fitting.metrics.evaluate_fit`: ``model_for`` defaults to
        :meth:`_model_for`, ``offset`` to ``offset_``; ``run_inverse`` scores the
        compensation)."""
        train, test, cmax, crmse = evaluate_fit(
            self._model_for if model_for is None else model_for,
            self.offset_ if offset is None else offset,
            segments,
            train_labels=train_labels,
            test_labels=test_labels,
            invertible=run_inverse,
            compensation=_COMPENSATION_SCORED.get(),
        )
        return FitReport(
            model_type=model_type,
            n_parameters=n_parameters,
            train=train,
            test=test,
            compensation_max_abs=cmax,
            compensation_rmse=crmse,
            invertible=invertible,
            min_slope=min_slope,
            condition_number=condition_number,
            solver=solver,
            extra=extra,
        )
