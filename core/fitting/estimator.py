"""What every estimator of the transformed-input fits shares: the sklearn-style ``fit``."""

from __future__ import annotations

from typing import Any, Self

__all__ = ["Estimator"]


class Estimator:
    """An sklearn-style estimator: ``fit(u, y, train=, test=)`` fits the model in place and
    returns the estimator; a subclass writes only ``_fit``."""

    def fit(self, u: Any, y: Any = None, *, train: Any = None, test: Any = None) -> Self:
        """Fit the model; arguments as :meth:`core.fitting.pi.PIRegressor.fit`.

        Returns
        -------
        Self
            ``self``, with the fitted attributes (``model_``, ``full_model_``, ``report_``).

        Raises
        ------
        ParameterError
            Bad inputs or options (the subclass's ``_fit`` says which).
        """
        self._fit(u, y, train, test)
        return self

    def _fit(self, u: Any, y: Any, train: Any, test: Any) -> None:  # pragma: no cover
        raise NotImplementedError
