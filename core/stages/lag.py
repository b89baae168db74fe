"""The first-order lag ``τ ẏ + y = x`` and its exact inverse."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .._typing import Float1D
from ..base import Control, Field, Model, register_model
from ..validation import as_finite_scalar, filled
from .linear import (
    LagBank,
    LinearStage,
    lag_bank_inverse,
)


@register_model
@dataclass(frozen=True, eq=False)
class Lag(LinearStage):
    """First-order lag ``τ ẏ + y = x`` (amplifier output impedance × stack capacitance, sensor).

    Parameters
    ----------
    tau_s : float
        Time constant in seconds, ``tau_s > 0``.
    """

    type_name: ClassVar[str] = "lag"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("tau_s", "number", doc="time constant (s)", title="Time constant τ",
              control=Control("τ", "s", (0.001, 2.0), lower=0.0, strict=True, scale=1e-3,
                              log=True)),
    )
    tau_s: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "tau_s", as_finite_scalar(self.tau_s, "tau_s", positive=True))

    def _tf(self) -> tuple[list[float], list[float]]:
        return [1.0], [self.tau_s, 1.0]

    def bank(self, dt: float) -> LagBank:
        """This lag as a :class:`LagBank` at ``dt``."""
        return LagBank.of([self.tau_s], [1.0], 0.0, dt)

    def time_constants(self) -> tuple[tuple[str, float], ...]:
        """The lag's time constant (s)."""
        return (("lag tau_s", float(self.tau_s)),)

    def inverse(self) -> LagInverse:
        """The exact inverse of the discretised lag (its FOH zero lies in (-1, 0))."""
        return LagInverse(self.tau_s)


@register_model
@dataclass(frozen=True, eq=False)
class LagInverse(Model):
    """Exact inverse of the first-order-hold discretised :class:`Lag` (per-sample solve).

    ``x_k = (y_k - s_k) / b0`` with the lag's own DF2T state ``s``, so
    ``Lag(τ)(LagInverse(τ)(y)) == y`` to rounding from the first sample. The state is the
    forward lag's filter state (shape (1,)); by default at rest at the first sample. The
    inverse amplifies the input's high frequencies by up to ``|H(-1)|⁻¹`` (≈ 2τ/dt·... for
    τ ≫ dt): feed it a smooth desired trajectory.

    Parameters
    ----------
    tau_s : float
        Time constant of the lag being inverted (s).
    """

    type_name: ClassVar[str] = "lag-inverse"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = (
        Field("tau_s", "number", doc="time constant of the inverted lag (s)",
              title="Time constant τ",
              control=Control("τ", "s", (0.001, 2.0), lower=0.0, strict=True, scale=1e-3,
                              log=True)),
    )
    tau_s: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "tau_s", as_finite_scalar(self.tau_s, "tau_s", positive=True))

    def default_state(self) -> Any:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        bank = Lag(self.tau_s).bank(float(filled(dt)))
        s = bank.states(state, float(u[0]) if u.size else 0.0)
        out = np.empty_like(u)
        lag_bank_inverse(u, bank.g0, bank.c, bank.b0, bank.b1, bank.a1, s, out)
        return out, s

    def inverse(self) -> Lag:
        return Lag(self.tau_s)
