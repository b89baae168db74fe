"""Creep ``y = x + Σ_j c_j (L_{τ_j}[x] - x)`` (log-spaced lags) and its exact inverse."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .._typing import Float1D
from ..base import SAMPLE_BYTES, Control, Field, Model, RunCost, register_model
from ..exceptions import NotInvertibleError, ParameterError
from ..validation import as_vector, filled
from .linear import (
    LagBank,
    foh_filter,
    lag_bank_inverse,
    lag_state_tuple,
)


@register_model
@dataclass(frozen=True, eq=False)
class Creep(Model):
    """Logarithmic creep as a bank of slow first-order lags (Krejčí–Kuhnen, linear form).

    ``y = x + Σ_j c_j (L_{τ_j}[x] - x)`` where ``τ_j L̇ + L = x``. After a step ``Δx`` the
    output keeps moving in the direction of the step; with equal ``c_j = γ`` on one lag per
    decade it moves by about ``γ Δx`` per decade of time (the PI tutorial's log law).

    Parameters
    ----------
    taus_s : array_like of shape (m,)
        Time constants in seconds, increasing, ``> 0``.
    weights : array_like of shape (m,)
        Creep weights ``c_j`` (dimensionless fraction of the step per lag), ``>= 0``.
    """

    type_name: ClassVar[str] = "creep"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = (
        Field("taus_s", "numbers", doc="lag time constants (s), increasing",
              title="Creep time constants τ_j", increasing=True,
              control=Control("τ{i}", "s", (0.001, 1.25), lower=0.0, strict=True, log=True)),
        Field("weights", "numbers", doc="creep weight of each lag (fraction of a step)",
              title="Creep weights c_j",
              control=Control("c{i}", "1", (0.0, 2.0), lower=0.0, scale=0.01)),
    )
    taus_s: Float1D
    weights: Float1D

    def __post_init__(self) -> None:
        t = as_vector(self.taus_s, "taus_s", positive=True, increasing=True)
        w = as_vector(self.weights, "weights", length=t.size, nonnegative=True)
        object.__setattr__(self, "taus_s", t)
        object.__setattr__(self, "weights", w)

    @property
    def gamma_per_decade(self) -> float:
        """Mean creep weight per decade of time constant (≈ creep per decade of time)."""
        if self.taus_s.size < 2:
            return float(self.weights.sum())
        decades = np.log10(self.taus_s[-1] / self.taus_s[0]) + 1.0
        return float(self.weights.sum() / decades)

    def time_constants(self) -> tuple[tuple[str, float], ...]:
        """Each lag's time constant (s)."""
        return tuple(("creep taus_s", float(t)) for t in self.taus_s)

    def bank(self, dt: float) -> LagBank:
        """This operator as a :class:`LagBank` at ``dt`` (``g0 = 1 - Σ c_j``)."""
        return LagBank.of(self.taus_s, self.weights, 1.0 - float(self.weights.sum()), dt)

    def default_state(self) -> Any:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        y = u.copy()
        out = []
        for j, (tau, c) in enumerate(zip(self.taus_s, self.weights, strict=True)):
            zi = None if state is None else np.asarray(state[j], dtype=np.float64)
            lj, zf = foh_filter(u, [1.0], [float(tau), 1.0], float(filled(dt)), zi)
            y += c * (lj - u)
            out.append(zf)
        return y, tuple(out)

    def inverse(self) -> CreepInverse:
        """Inverse of the minimum-phase discrete operator (per-sample, exact).

        Raises
        ------
        NotInvertibleError
            If ``Σ c_j >= 1``: the creep then has no instantaneous response left (or a
            right-half-plane zero) and its inverse would be improper or unstable.
        """
        total = float(self.weights.sum())
        if total >= 1.0:
            raise NotInvertibleError(
                f"creep weights sum to {total:g} >= 1: the operator's high-frequency gain "
                "1 - sum(weights) is not positive, so it has no stable causal inverse"
            )
        return CreepInverse(self.taus_s, self.weights)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Terms x samples: one filtered pass of the input per lag (element operations,
        bytes)."""
        n, m = float(samples), float(self.taus_s.size)
        return RunCost(12.0 * n * m, SAMPLE_BYTES * (5.0 * n + m))


@register_model
@dataclass(frozen=True, eq=False)
class CreepInverse(Model):
    """Exact inverse of the discretised :class:`Creep` operator.

    The creep is a bank of lags ``y = g0 x + Σ c_j L_j[x]`` (:class:`LagBank`), solved for
    ``x`` at every sample: ``x_k = (y_k - Σ c_j s_j) / (g0 + Σ c_j b0_j)``. With ``c_j >= 0``
    and ``Σ c_j < 1`` the discrete operator is minimum phase whenever its response at
    Nyquist is positive (checked at run time: ``ParameterError`` otherwise), so the inverse
    is stable; ``Creep(CreepInverse(y)) == y`` to rounding. The state is the creep's own
    state (one filter state per lag); by default at rest at the first sample.

    Parameters
    ----------
    taus_s, weights : array_like of shape (m,)
        The creep being inverted (see :class:`Creep`).
    """

    type_name: ClassVar[str] = "creep-inverse"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = Creep.fields
    taus_s: Float1D
    weights: Float1D

    def __post_init__(self) -> None:
        fwd = Creep(self.taus_s, self.weights)
        object.__setattr__(self, "taus_s", fwd.taus_s)
        object.__setattr__(self, "weights", fwd.weights)

    def checked_bank(self, dt: float) -> LagBank:
        """The forward :class:`LagBank` at ``dt``, checked to be minimum phase."""
        bank = Creep(self.taus_s, self.weights).bank(dt)
        if not (bank.gain0 > 0 and bank.gain_at_nyquist() > 0):
            raise ParameterError(
                f"creep inverse at dt={dt:g} s is unstable (the discretised creep is not "
                "minimum phase); sample faster or reduce the creep weights"
            )
        return bank

    def default_state(self) -> Any:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        bank = self.checked_bank(float(filled(dt)))
        s = bank.states(None if state is None else [np.ravel(v)[0] for v in state],
                        float(u[0]) if u.size else 0.0)
        out = np.empty_like(u)
        lag_bank_inverse(u, bank.g0, bank.c, bank.b0, bank.b1, bank.a1, s, out)
        return out, lag_state_tuple(s)

    def inverse(self) -> Creep:
        return Creep(self.taus_s, self.weights)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Terms x samples: every lag updated at every sample (element operations, bytes)."""
        n, m = float(samples), float(self.taus_s.size)
        return RunCost(4.0 * n * (m + 1.0), SAMPLE_BYTES * (2.0 * n + 4.0 * m))
