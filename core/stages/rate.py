"""The rate-dependent PI model (thresholds ``r_i + β|u̇|`` for r > 0) and its inverse."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .. import kernels
from .._typing import ArrayLike, Float1D
from ..base import SAMPLE_BYTES, Field, Model, RunCost, register_model
from ..kernels import play_update
from ..pi import PIModel
from ..preisach import RATE_FIELD, as_rate_coefficient, checked_rate_slopes, rate_bracket
from ..validation import as_input_signal, filled

njit = kernels.njit


@njit(cache=True, nogil=True)
def _rd_play_matrix(u, r, k_rate, u_prev, z, out):  # pragma: no cover - compiled
    """Play outputs with thresholds ``r_i + k_rate * |u_k - u_{k-1}|`` (in place, see below)."""
    N = u.shape[0]
    n = r.shape[0]
    up = u_prev
    for k in range(N):
        uk = u[k]
        extra = k_rate * abs(uk - up)
        up = uk
        for i in range(n):
            zi = play_update(z[i], uk, r[i] + extra)
            z[i] = zi
            out[k, i] = zi


def rd_play_bank(
    u: ArrayLike,
    thresholds: ArrayLike,
    beta_s: float,
    dt: float,
    state0: ArrayLike | None = None,
    u_prev: float | None = None,
) -> tuple[np.ndarray, Float1D]:
    """Play operators with additive rate-dependent thresholds ``r_i + β |u̇|``.

    The rate is the backward difference ``(u_k - u_{k-1}) / dt``. With ``β = 0`` this equals
    :func:`core.operators.play_bank`.

    Parameters
    ----------
    u : array_like of shape (N,)
    thresholds : array_like of shape (n,)
        Static thresholds ``r_i > 0`` (input units).
    beta_s : float
        Rate coefficient ``β`` in seconds (threshold increase per unit input rate).
    dt : float
        Sample spacing in seconds.
    state0 : array_like of shape (n,), optional
        Play outputs before the first sample (zeros by default).
    u_prev : float, optional
        Input before the first sample (``u[0]`` by default: no rate at the first sample).

    Returns
    -------
    Y : ndarray of shape (N, n)
    state : ndarray of shape (n,)
    """
    u = as_input_signal(u)
    r = np.ascontiguousarray(thresholds, dtype=np.float64)
    z = np.zeros(r.size) if state0 is None else np.array(state0, dtype=np.float64, copy=True)
    out = np.empty((u.size, r.size))
    if u.size:
        up = float(u[0]) if u_prev is None else float(u_prev)
        _rd_play_matrix(u, r, float(beta_s) / float(dt), up, z, out)
    return out, z


@njit(cache=True, nogil=True)
def _rd_eval(u, r, w, p0, k_rate, up, has_prev, z):  # pragma: no cover - compiled
    """Output of the rate-dependent PI for the sample ``u`` from plays ``z`` (not updated)."""
    extra = k_rate * abs(u - up) if has_prev else 0.0
    acc = p0 * u
    for i in range(r.shape[0]):
        acc += w[i] * play_update(z[i], u, r[i] + extra)
    return acc


@njit(cache=True, nogil=True)
def _rd_inverse(y, r, w, p0, k_rate, m_lo, m_hi, up, has_prev, z, out):  # pragma: no cover
    """Per-sample bisection of the rate-dependent PI (slopes in ``[m_lo, m_hi]``, > 0)."""
    n = r.shape[0]
    for k in range(y.shape[0]):
        yk = y[k]
        ref = up if has_prev else 0.0
        f0 = _rd_eval(ref, r, w, p0, k_rate, up, has_prev, z)
        lo, hi = rate_bracket(yk, f0, ref, m_lo, m_hi)
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            if mid == lo or mid == hi:
                break
            if _rd_eval(mid, r, w, p0, k_rate, up, has_prev, z) < yk:
                lo = mid
            else:
                hi = mid
        uk = 0.5 * (lo + hi)
        extra = k_rate * abs(uk - up) if has_prev else 0.0
        for i in range(n):
            z[i] = play_update(z[i], uk, r[i] + extra)
        up = uk
        has_prev = True
        out[k] = uk
    return up


@register_model
@dataclass(frozen=True, eq=False)
class RateDependentPI(Model):
    """Rate-dependent PI: the r > 0 play thresholds widen with the input rate.

    ``y = p0 u + Σ p_i Γ_{r_i + β|u̇|}[u]`` (Al Janaideh, Su & Rakheja 2008, additive form,
    applied to the hysteretic operators only so that it differs from a pure delay: the
    reversible ``p0 u`` term is not delayed). The state is ``(play outputs, previous input)``.

    Parameters
    ----------
    p0 : float
        Weight of the reversible term (output units per input unit).
    thresholds : array_like of shape (n,)
        Static thresholds ``0 < r_1 < ... < r_n`` (input units).
    weights : array_like of shape (n,)
        Play weights.
    beta_s : float
        Rate coefficient β in seconds, ``>= 0``.
    state0 : array_like of shape (n,), optional
        Play outputs before the first sample (zeros by default).
    """

    type_name: ClassVar[str] = "rate"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = (
        *PIModel.fields[:3],  # p0, the static thresholds r_i and the weights p_i
        RATE_FIELD,
        PIModel.fields[3],  # state0
    )
    p0: float
    thresholds: Float1D
    weights: Float1D
    beta_s: float
    state0: Float1D | None = None

    def __post_init__(self) -> None:
        base = PIModel(self.p0, self.thresholds, self.weights, self.state0)
        object.__setattr__(self, "p0", base.p0)
        object.__setattr__(self, "thresholds", base.thresholds)
        object.__setattr__(self, "weights", base.weights)
        object.__setattr__(self, "state0", base.state0)
        object.__setattr__(self, "beta_s", as_rate_coefficient(self.beta_s))

    @property
    def static(self) -> PIModel:
        """The rate-independent PI model (β = 0)."""
        return PIModel(self.p0, self.thresholds, self.weights, self.state0)

    def default_state(self) -> tuple[Float1D, None]:
        return (np.array(self.state0, copy=True), None)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        z, up = state
        Y, zf = rd_play_bank(u, self.thresholds, self.beta_s, float(filled(dt)), z, up)
        y = self.p0 * u + Y @ self.weights
        return y, (zf, float(u[-1]) if u.size else up)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Operators x samples of work; the play outputs are kept as a ``(samples,
        operators)`` matrix before they are weighted, so memory is operators + 4 sample
        arrays (measured: operators + 2). Work in element operations, memory in bytes."""
        n, k = float(samples), float(np.size(self.thresholds))
        return RunCost(n * (1.0 + self.field_size()), SAMPLE_BYTES * (n * (k + 4.0) + 4.0 * k))

    def slope_bounds(self, dt: float) -> tuple[float, float]:
        """Smallest and largest slope of the per-sample map ``u_k -> y_k`` at ``dt``.

        Each play output moves with slope 0, ``1 - κ`` or ``1 + κ`` in ``u_k`` (``κ = β/dt``).
        """
        kap = self.beta_s / float(dt)
        cand = np.stack((np.zeros_like(self.weights), self.weights * (1 - kap),
                         self.weights * (1 + kap)))
        return float(self.p0 + cand.min(axis=0).sum()), float(self.p0 + cand.max(axis=0).sum())

    def inverse(self) -> RateDependentPIInverse:
        """Per-sample inverse (bisection, see :class:`RateDependentPIInverse`).

        Raises
        ------
        NotInvertibleError
            If the static model is not invertible (a slope ``<= 0``).
        """
        self.static.inverse()  # the static slope rules, with their messages
        return RateDependentPIInverse(self.p0, self.thresholds, self.weights, self.beta_s,
                                      self.state0)


@register_model
@dataclass(frozen=True, eq=False)
class RateDependentPIInverse(Model):
    """Inverse of a :class:`RateDependentPI`, solved sample by sample.

    At each sample the forward map ``u_k -> y_k`` (plays and previous input fixed) is
    piecewise linear with slopes in ``[m_lo, m_hi]`` (:meth:`RateDependentPI.slope_bounds`);
    with ``m_lo > 0`` it is strictly increasing, so ``u_k`` is bracketed from one evaluation
    and bisected to adjacent doubles (at most 100 steps). Tolerance: ``|forward(u_k) - y_k|
    <= m_hi · ulp(u_k)``, i.e. about 1e-15 relative. The state is the forward model's state
    ``(play outputs, previous input)``, so the two stay consistent.

    Parameters
    ----------
    p0, thresholds, weights, beta_s, state0
        The model being inverted (see :class:`RateDependentPI`).
    """

    type_name: ClassVar[str] = "rate-inverse"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = RateDependentPI.fields
    p0: float
    thresholds: Float1D
    weights: Float1D
    beta_s: float
    state0: Float1D | None = None

    def __post_init__(self) -> None:
        fwd = RateDependentPI(self.p0, self.thresholds, self.weights, self.beta_s, self.state0)
        for k in ("p0", "thresholds", "weights", "beta_s", "state0"):
            object.__setattr__(self, k, getattr(fwd, k))

    @property
    def forward(self) -> RateDependentPI:
        """The model being inverted."""
        return RateDependentPI(self.p0, self.thresholds, self.weights, self.beta_s, self.state0)

    def checked_slopes(self, dt: float) -> tuple[float, float]:
        """Slope bounds at ``dt``, checked to be positive."""
        return checked_rate_slopes("rate-dependent PI", self.forward.slope_bounds(dt),
                                   self.beta_s, dt)

    def default_state(self) -> tuple[Float1D, None]:
        return (np.array(self.state0, copy=True), None)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        m_lo, m_hi = self.checked_slopes(float(filled(dt)))
        z0, up = state
        z = np.array(z0, dtype=np.float64, copy=True)
        out = np.empty_like(u)
        up_f = _rd_inverse(u, self.thresholds, self.weights, self.p0,
                           self.beta_s / float(filled(dt)), m_lo, m_hi,
                           0.0 if up is None else float(up), up is not None, z, out)
        return out, (z, float(up_f) if (u.size or up is not None) else None)

    def inverse(self) -> RateDependentPI:
        return self.forward

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Operators x samples x solver iterations (each over every operator; typically
        well under the cap of 100 per sample); work in element operations, memory in
        bytes."""
        n, k = float(samples), float(np.size(self.thresholds))
        return RunCost(60.0 * n * (k + 1.0), SAMPLE_BYTES * (2.0 * n + 4.0 * k))
