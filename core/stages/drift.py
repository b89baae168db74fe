"""Drift ``y = x + Σ_k a_k P_k(2t/T - 1)``: a Legendre polynomial in time."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .._typing import ArrayLike, Float1D
from ..base import SAMPLE_BYTES, Control, Field, Model, RunCost, register_model
from ..validation import as_finite_scalar, as_vector, filled


@register_model
@dataclass(frozen=True, eq=False)
class Drift(Model):
    """Slow additive drift in absolute time: ``y = x + Σ_k a_k P_k(2 t / T - 1)``.

    ``P_k`` are Legendre polynomials (k = 1..m) over the fitted span ``[0, T]``; outside that
    span the drift is held at its end value (polynomials must not be extrapolated). Time is
    counted from the first sample of the first ``simulate`` call (``start_s`` at that
    sample); the state is the elapsed time in seconds. The inverse is the drift with the
    opposite sign (exact).

    Parameters
    ----------
    coefficients : array_like of shape (m,)
        ``a_1..a_m`` in output units.
    span_s : float
        Length ``T`` of the time span in seconds, ``> 0``.
    start_s : float
        Time of the first sample (s), 0 by default (a previewed compensator starts early).
    """

    type_name: ClassVar[str] = "drift"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = (
        Field("coefficients", "numbers", doc="Legendre coefficients a_1..a_m (output units)",
              title="Drift coefficients a_k", control=Control("a{i}", "output", (-2.0, 2.0))),
        Field("span_s", "number", doc="time span of the drift (s)", title="Drift span T",
              control=Control("T", "s", (0.0, 2.0), lower=0.0, strict=True)),
        Field("start_s", "number", optional=True, default=0.0, title="Start time t0",
              scale_with=("span_s",), control=Control("t0", "s", (-1.0, 1.0)),
              doc="time of the first sample (s)"),
    )
    coefficients: Float1D
    span_s: float
    start_s: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", as_vector(self.coefficients, "coefficients"))
        object.__setattr__(self, "span_s", as_finite_scalar(self.span_s, "span_s", positive=True))
        object.__setattr__(self, "start_s", as_finite_scalar(self.start_s, "start_s"))

    def drift(self, t: ArrayLike) -> Float1D:
        """Drift ``d(t)`` in output units at times ``t`` (seconds from the start), shape (N,)."""
        s = np.clip(2.0 * np.asarray(t, dtype=np.float64) / self.span_s - 1.0, -1.0, 1.0)
        c = np.concatenate(([0.0], self.coefficients))
        return np.asarray(np.polynomial.legendre.legval(s, c), dtype=np.float64)

    def default_state(self) -> float:
        return self.start_s

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        t0 = float(state)
        t = t0 + np.arange(u.size) * float(filled(dt))
        return u + self.drift(t), t0 + u.size * float(filled(dt))

    def inverse(self) -> Drift:
        return Drift(-self.coefficients, self.span_s, self.start_s)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Coefficients x samples: one Legendre recurrence step per coefficient and sample
        (element operations, bytes)."""
        n, m = float(samples), float(self.coefficients.size)
        return RunCost(6.0 * n * (m + 2.0), SAMPLE_BYTES * (7.0 * n + m))
