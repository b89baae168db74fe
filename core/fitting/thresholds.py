"""Placement of play-operator thresholds from the data.

A play operator ``Γ_r`` only changes its output once the input has travelled ``2 r`` since the
last reversal, so the useful thresholds lie between 0 and half of the largest travel between
two reversals. Two rules are offered:

``"uniform"``
    ``r_i = r_max · i / n`` for ``i = 1..n``, with ``r_max`` a fraction (default 0.9) of the
    largest half-travel between reversals (for a symmetric sine: of the input amplitude).
``"quantile"``
    Every travel between two reversals contributes uniformly to the half-travel interval
    ``[0, a_s/2]`` it sweeps; thresholds are the quantiles ``i/(n+1)`` of that mixture. For a
    constant-amplitude sine this reduces to uniform thresholds; for tapered or multi-amplitude
    records (friction dampers, B-H loops at several amplitudes) operators crowd where many
    small loops live.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .._typing import Float1D
from ..exceptions import ParameterError
from ..kernels import njit

__all__ = [
    "half_travels",
    "place_thresholds",
    "reversal_indices",
    "thresholds_from_travels",
    "travels_at",
    "wipeout_index",
]

#: Default fraction of the largest half-travel used as the widest threshold ("uniform").
DEFAULT_R_FRACTION = 0.9


@njit(cache=True, nogil=True)
def _turning_points(u, tol, out):  # pragma: no cover - compiled
    """Write the indices of the turning points of ``u`` (hysteresis ``tol``) into ``out``.

    Returns the number written. ``out[0] = 0`` (the first sample); afterwards an extreme is
    confirmed once the input has moved back from it by more than ``tol``.
    """
    N = u.shape[0]
    out[0] = 0
    k = 1
    direction = 0  # +1 rising, -1 falling, 0 undecided
    ext_i = 0
    ext_v = u[0]
    lo_i = 0
    hi_i = 0
    for j in range(1, N):
        v = u[j]
        if direction == 0:
            if v > u[hi_i]:
                hi_i = j
            if v < u[lo_i]:
                lo_i = j
            if u[hi_i] - u[0] > tol and u[hi_i] - u[0] >= u[0] - u[lo_i]:
                direction = 1
                ext_i = hi_i
                ext_v = u[hi_i]
            elif u[0] - u[lo_i] > tol:
                direction = -1
                ext_i = lo_i
                ext_v = u[lo_i]
        elif direction > 0:
            if v >= ext_v:
                ext_v = v
                ext_i = j
            elif ext_v - v > tol:
                out[k] = ext_i
                k += 1
                direction = -1
                ext_v = v
                ext_i = j
        else:
            if v <= ext_v:
                ext_v = v
                ext_i = j
            elif v - ext_v > tol:
                out[k] = ext_i
                k += 1
                direction = 1
                ext_v = v
                ext_i = j
    return k


def reversal_indices(u: Float1D, tol: float) -> np.ndarray:
    """Indices of input reversals, ignoring wiggles smaller than ``tol``.

    A maximum (minimum) counts as a reversal once the input has fallen (risen) from it by
    more than ``tol``: noise of peak-to-peak size below ``tol`` creates no reversal.

    Parameters
    ----------
    u : ndarray of shape (N,)
        Input samples.
    tol : float
        Smallest travel (input units) that counts as a real reversal, ``tol >= 0``.

    Returns
    -------
    ndarray of int, shape (K,)
        Sample indices (into ``u``) of the turning points, first sample included.
    """
    u = np.ascontiguousarray(u, dtype=np.float64)
    if u.size < 2:
        return np.zeros(1, dtype=np.int64)
    out = np.empty(u.size, dtype=np.int64)
    k = _turning_points(u, float(tol), out)
    return out[:k].copy()


def wipeout_index(u: Float1D, frac: float = 0.98) -> int:
    """First sample after which the input has visited both ends of its range (``t_w``).

    Once the input has reached (within ``1 - frac`` of the range) both its largest and its
    smallest value, every play operator of a PI model with thresholds below half the range
    has been driven into a state fixed by the input alone: the unknown initial memory is
    wiped out and only the rows before this index depend on it.

    Parameters
    ----------
    u : ndarray of shape (N,)
        Input samples.
    frac : float
        Fraction of the range that counts as "reached an end", ``0 < frac <= 1``.

    Returns
    -------
    int
        Index ``t_w`` (``0`` for a constant input; ``N`` when one end is never reached).
    """
    u = np.asarray(u, dtype=np.float64)
    lo, hi = float(u.min()), float(u.max())
    span = hi - lo
    if span <= 0:
        return 0
    a = np.flatnonzero(u >= hi - (1 - frac) * span)
    b = np.flatnonzero(u <= lo + (1 - frac) * span)
    if a.size == 0 or b.size == 0:
        return int(u.size)
    return int(max(a[0], b[0]))


def half_travels(recordings: Sequence[Float1D], tol_fraction: float = 1e-3) -> Float1D:
    """Half of the input travel between consecutive reversals, over all recordings.

    Parameters
    ----------
    recordings : sequence of ndarray of shape (N_k,)
        Input signals.
    tol_fraction : float
        Reversals smaller than this fraction of the overall input range are ignored.

    Returns
    -------
    ndarray of shape (M,)
        Half-travels ``|u(t_{j+1}) - u(t_j)| / 2`` (input units), ``M >= 1``; the last
        (unfinished) travel of each recording is included.
    """
    lo = min(float(np.min(u)) for u in recordings)
    hi = max(float(np.max(u)) for u in recordings)
    tol = tol_fraction * (hi - lo)
    return travels_at(recordings, [reversal_indices(u, tol) for u in recordings])


def place_thresholds(
    recordings: Sequence[Float1D],
    n: int,
    rule: str = "uniform",
    r_max: float | None = None,
) -> Float1D:
    """Choose ``n`` increasing play thresholds from the input data.

    Parameters
    ----------
    recordings : sequence of ndarray of shape (N_k,)
        Input signals (the travels between reversals are measured on them).
    n : int
        Number of play operators, ``n >= 1``.
    rule : {"uniform", "quantile"}
        Placement rule (see the module docstring).
    r_max : float, optional
        Widest threshold for ``"uniform"`` (input units); by default 0.9 times the largest
        half-travel between reversals. For ``"quantile"`` it caps the thresholds.

    Returns
    -------
    ndarray of shape (n,)
        Strictly increasing thresholds ``0 < r_1 < ... < r_n``.

    Raises
    ------
    ParameterError
        For an unknown rule, ``n < 1``, ``r_max <= 0`` or an input without travel.
    """
    return thresholds_from_travels(half_travels(recordings), n, rule, r_max)


def travels_at(signals: Sequence[Float1D], indices: Sequence[np.ndarray]) -> Float1D:
    """Half-travels of ``signals`` between given reversal ``indices`` (one array per signal).

    Used when a monotone map of the input (dead-zone, envelope) changes with the parameters
    of a fit but its reversal samples do not.
    """
    out = []
    for x, idx in zip(signals, indices, strict=True):
        ext = x[np.concatenate((idx, [x.size - 1]))] if idx[-1] != x.size - 1 else x[idx]
        out.append(np.abs(np.diff(ext)) / 2.0)
    a = np.concatenate(out) if out else np.zeros(0)
    a = a[a > 0]
    if a.size == 0:
        raise ParameterError("the input never moves, so no play thresholds can be placed")
    return a


def thresholds_from_travels(
    a: Float1D, n: int, rule: str = "uniform", r_max: float | None = None
) -> Float1D:
    """Thresholds from half-travels ``a`` (see :func:`place_thresholds`)."""
    if int(n) != n or n < 1:
        raise ParameterError(f"n_operators must be a positive integer, got {n!r}")
    n = int(n)
    a_max = float(a.max())
    if r_max is not None and not (np.isfinite(r_max) and r_max > 0):
        raise ParameterError(f"r_max = {r_max!r} must be a finite number > 0 (input units)")
    if rule == "uniform":
        top = DEFAULT_R_FRACTION * a_max if r_max is None else float(r_max)
        return top * np.arange(1, n + 1) / n
    if rule == "quantile":
        # mixture of uniforms on [0, a_s]: CDF F(r) = sum_s min(r, a_s) / sum_s a_s
        s = np.sort(a)
        m = s.size
        # F at the knots s_k: (sum_{j<k} s_j + (m - k) s_k) / total
        csum = np.concatenate(([0.0], np.cumsum(s)[:-1]))
        F = (csum + (m - np.arange(m)) * s) / s.sum()
        knots_r = np.concatenate(([0.0], s))
        knots_F = np.concatenate(([0.0], F))
        if r_max is None:
            q = np.arange(1, n + 1) / (n + 1)
        else:  # spread the quantiles up to F(r_max) so that r_n = r_max
            q = float(np.interp(r_max, knots_r, knots_F, right=1.0)) * np.arange(1, n + 1) / n
        r = np.interp(q, knots_F, knots_r)
        if r_max is not None and r_max > knots_r[-1]:
            r[-1] = float(r_max)
        # guarantee strict increase (ties happen when many travels are equal)
        floor = 1e-9 * a_max
        for i in range(1, n):
            if r[i] <= r[i - 1] + floor:
                r[i] = r[i - 1] + floor
        r[0] = max(r[0], floor)
        return r
    raise ParameterError(
        f"thresholds must be 'uniform', 'quantile' or an array of increasing values, got {rule!r}"
    )
