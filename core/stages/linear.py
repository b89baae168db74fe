"""The discretised linear filters the dynamic stages share: the first-order-hold
discretisation of a transfer function (memoised), :func:`foh_filter`, the unit-DC-gain
:class:`LinearStage` and the first-order lag bank (:class:`LagBank`) of the lag and the creep."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .. import kernels
from .._typing import ArrayLike, Float1D
from ..base import Model
from ..exceptions import ParameterError
from ..validation import filled

njit = kernels.njit


def _tf_coefficients(num: list[float], den: list[float], dt: float) -> tuple[Float1D, Float1D]:
    """First-order-hold discretisation of ``num(s)/den(s)`` (exact for piecewise-linear input).

    Memoised on the exact float values (the diagnosis filters thousands of regressor
    columns with a few distinct transfer functions); copies are returned.
    """
    b, a, _ = discretised_tf(num, den, dt)
    return b.copy(), a.copy()


def discretised_tf(num: list[float], den: list[float], dt: float
                   ) -> tuple[Float1D, Float1D, Float1D]:
    """``(b, a, lfilter_zi(b, a))``, memoised; the arrays are shared: do not modify them.

    Thread-safe: the cache is :func:`functools.lru_cache` on the exact float values (the
    explorer serves concurrent requests from worker threads).
    """
    return _tf_memo_key(tuple(float(v) for v in num), tuple(float(v) for v in den), float(dt))


@functools.lru_cache(maxsize=4096)
def _tf_memo_key(
    num: tuple[float, ...], den: tuple[float, ...], dt: float
) -> tuple[Float1D, Float1D, Float1D]:
    import scipy.signal as ss

    b, a = _tf_coefficients_uncached(list(num), list(den), dt)
    got = (b, a, ss.lfilter_zi(b, a))
    for arr in got:
        arr.setflags(write=False)
    return got


def _tf_coefficients_uncached(
    num: list[float], den: list[float], dt: float
) -> tuple[Float1D, Float1D]:
    import scipy.signal as ss

    b, a, _ = ss.cont2discrete((num, den), dt, method="foh")
    b = np.atleast_1d(np.squeeze(b)).astype(np.float64)
    a = np.atleast_1d(np.squeeze(a)).astype(np.float64)
    if b.size < a.size:
        b = np.concatenate((b, np.zeros(a.size - b.size)))
    return b / a[0], a / a[0]


def foh_filter(
    x: Float1D,
    num: list[float],
    den: list[float],
    dt: float,
    zi: Float1D | None = None,
    axis: int = 0,
) -> tuple[Float1D, Float1D]:
    """Filter ``x`` through the continuous transfer function ``num(s)/den(s)``.

    Parameters
    ----------
    x : ndarray of shape (N,) or (N, m) (or (m, N) with ``axis=-1``)
        Samples (columns are filtered independently).
    num, den : list of float
        Polynomial coefficients in ``s``, highest power first; ``num(0)/den(0) = 1`` for the
        effects of this module.
    dt : float
        Sample spacing in seconds.
    zi : ndarray, optional
        Direct-form-II-transposed state from a previous call; at rest at the first sample by
        default.
    axis : int
        Time axis of a 2-D ``x`` (0 or -1).

    Returns
    -------
    y : ndarray, same shape as ``x``
    zf : ndarray
        Final filter state (pass as ``zi`` to continue).
    """
    import scipy.signal as ss

    b, a, zi_unit = discretised_tf(num, den, dt)
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 2 and axis in (-1, 1):
        if x.shape[1] == 0:
            return x.copy(), np.zeros((x.shape[0], a.size - 1)) if zi is None else zi
        if zi is None:
            zi = zi_unit[None, :] * x[:, :1]
        return ss.lfilter(b, a, x, axis=-1, zi=zi)
    if x.shape[0] == 0:
        return x.copy(), (np.zeros((a.size - 1,) + x.shape[1:]) if zi is None else zi)
    if zi is None:
        zi0 = zi_unit
        zi = zi0[:, None] * x[0][None, :] if x.ndim == 2 else zi0 * x[0]
    y, zf = ss.lfilter(b, a, x, axis=0, zi=zi)
    return y, zf


class LinearStage(Model):
    """Shared machinery of the unit-DC-gain linear dynamics (state = filter state)."""

    needs_dt: ClassVar[bool] = True

    def _tf(self) -> tuple[list[float], list[float]]:  # pragma: no cover - abstract
        raise NotImplementedError

    def discrete(self, dt: float) -> tuple[Float1D, Float1D]:
        """``(b, a)``: the first-order-hold discretisation at ``dt`` (``a[0] = 1``)."""
        num, den = self._tf()
        return _tf_coefficients(num, den, float(dt))

    def default_state(self) -> Any:
        return None  # at rest at the first input sample

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        num, den = self._tf()
        zi = None if state is None else np.asarray(state, dtype=np.float64)
        if zi is not None and zi.shape != (len(den) - 1,):
            raise ParameterError(
                f"{self.type_name} state must have {len(den) - 1} entries, got shape {zi.shape}"
            )
        y, zf = foh_filter(u, num, den, float(filled(dt)), zi)
        return y, zf


@njit(cache=True, nogil=True)
def _lag_bank_forward(x, g0, c, b0, b1, a1, s, out):  # pragma: no cover - compiled
    """``y = g0 x + Σ c_j L_j[x]``, each ``L_j`` a first-order DF2T section (state ``s``)."""
    m = c.shape[0]
    for k in range(x.shape[0]):
        xk = x[k]
        acc = g0 * xk
        for j in range(m):
            lj = b0[j] * xk + s[j]
            s[j] = b1[j] * xk - a1[j] * lj
            acc += c[j] * lj
        out[k] = acc


@njit(cache=True, nogil=True)
def lag_bank_inverse(y, g0, c, b0, b1, a1, s, out):  # pragma: no cover - compiled
    """Exact per-sample inverse of :func:`_lag_bank_forward` (same state layout)."""
    m = c.shape[0]
    gain = g0
    for j in range(m):
        gain += c[j] * b0[j]
    for k in range(y.shape[0]):
        acc = y[k]
        for j in range(m):
            acc -= c[j] * s[j]
        xk = acc / gain
        for j in range(m):
            lj = b0[j] * xk + s[j]
            s[j] = b1[j] * xk - a1[j] * lj
        out[k] = xk


@dataclass(frozen=True)
class LagBank:
    """A bank ``y = g0 x + Σ_j c_j L_j[x]`` of first-order lags discretised at ``dt``.

    The common form of :class:`Lag` (``g0 = 0``, one lag of weight 1) and :class:`Creep`
    (``g0 = 1 - Σ c_j``); the C export and the inverses use it.

    Attributes
    ----------
    g0 : float
        Direct weight.
    c, b0, b1, a1 : ndarray of shape (m,)
        Lag weights and the DF2T coefficients of each section
        (``L = b0 x + s``, ``s ← b1 x - a1 L``).
    zi : ndarray of shape (m,)
        Section states at rest for a unit input (multiply by the first sample).
    """

    g0: float
    c: Float1D
    b0: Float1D
    b1: Float1D
    a1: Float1D
    zi: Float1D

    @classmethod
    def of(cls, taus_s: ArrayLike, weights: ArrayLike, g0: float, dt: float) -> LagBank:
        """Discretise lags ``taus_s`` (s) with weights at ``dt`` (s)."""
        b0, b1, a1, zi = [], [], [], []
        for tau in np.asarray(taus_s, dtype=np.float64):
            b, a, z = discretised_tf([1.0], [float(tau), 1.0], float(dt))
            b0.append(b[0])
            b1.append(b[1])
            a1.append(a[1])
            zi.append(z[0])
        return cls(float(g0), np.asarray(weights, dtype=np.float64), np.array(b0),
                   np.array(b1), np.array(a1), np.array(zi))

    @property
    def gain0(self) -> float:
        """Instantaneous gain ``g0 + Σ c_j b0_j`` (the inverse divides by it)."""
        return float(self.g0 + self.c @ self.b0)

    def gain_at_nyquist(self) -> float:
        """Frequency response at ``z = -1`` (real): > 0 with ``gain0 > 0`` means every zero
        lies in (-1, 1), i.e. the discrete operator is minimum phase (the weights
        ``c_j (1 - p_j)²/α_j`` of its partial fractions are positive, so zeros interlace the
        poles and only the leftmost one can leave the unit disc)."""
        # section transfer (b0 z + b1)/(z + a1) at z = -1
        return float(self.g0 + self.c @ ((self.b1 - self.b0) / (self.a1 - 1.0)))

    def states(self, state: Any, x0: float) -> Float1D:
        """Section states from a stage state (``None``: at rest at ``x0``)."""
        if state is None:
            return self.zi * x0
        s = np.asarray(state, dtype=np.float64).ravel()
        if s.shape != self.c.shape:
            raise ParameterError(
                f"lag-bank state must hold {self.c.size} section state(s), got {s.size}"
            )
        return s.copy()


def lag_state_tuple(s: Float1D) -> tuple[Float1D, ...]:
    return tuple(np.array([v]) for v in s)
