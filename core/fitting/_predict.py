"""``predict`` of the play-operator estimators (PI, Preisach): one definition for both."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from .._typing import ArrayLike, Float1D
from ..exceptions import NotFittedError
from ._data import as_recordings


class RelaxedPredictor:
    """Mixin: ``predict(u) = model_(u) + offset_`` with the operators relaxed at ``u[0]``.

    The estimator sets ``model_`` and ``offset_`` in ``fit`` and defines
    ``_model_for(u)``, the fitted model started from the state relaxed at ``u[0]``.
    """

    #: the constant output offset ``fit`` sets
    offset_: float

    def _model_for(self, u: Float1D) -> Any:  # pragma: no cover - defined by the estimator
        raise NotImplementedError

    def _check(self) -> None:
        if not hasattr(self, "model_"):
            raise NotFittedError(
                f"this {type(self).__name__} is not fitted yet; call fit(u, y) first"
            )

    def predict(self, u: ArrayLike | Sequence[ArrayLike]) -> Float1D | list[Float1D]:
        """Model output ``model_(u) + offset_`` with the operators relaxed at ``u[0]``.

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
        out = [self._model_for(x)(x) + self.offset_ if x.size else x.copy()
               for x in us]
        return out if multi else out[0]
