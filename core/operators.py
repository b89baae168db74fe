"""Elementary hysteresis operators: play, stop and dead-zone (paper 001 eq. 1-5, 42)."""

from __future__ import annotations

import numpy as np

from . import kernels
from ._typing import ArrayLike, Float1D, Float2D
from .exceptions import ParameterError
from .validation import as_input_signal, as_vector

__all__ = ["dead_zone", "play", "play_bank", "stop"]


def play_bank(
    u: ArrayLike, thresholds: ArrayLike, state0: ArrayLike | None = None
) -> tuple[Float2D, Float1D]:
    """Outputs of a bank of play operators driven by one input.

    Parameters
    ----------
    u : array_like of shape (N,)
        Input samples.
    thresholds : array_like of shape (n,)
        Thresholds ``r_i >= 0`` (any order).
    state0 : array_like of shape (n,), optional
        Operator outputs before the first sample (the paper's M0); zeros by default.

    Returns
    -------
    Y : ndarray of shape (N, n)
        ``Y[k, i] = Γ_{r_i}[u](t_k)``.
    state : ndarray of shape (n,)
        Operator outputs after the last sample; pass as ``state0`` to continue.

    Examples
    --------
    >>> Y, z = play_bank([0.0, 1.0, 0.0], [0.5])
    >>> Y[:, 0].tolist()
    [0.0, 0.5, 0.5]
    """
    u = as_input_signal(u)
    r = as_vector(thresholds, "thresholds", nonnegative=True)
    z = (
        np.zeros(r.size)
        if state0 is None
        else np.array(as_vector(state0, "state0", length=r.size), copy=True)
    )
    out = np.empty((u.size, r.size))
    kernels.play_matrix(u, r, z, out)
    return out, z


def play(u: ArrayLike, r: float, state0: float = 0.0) -> Float1D:
    """Play (backlash) operator Γ_r[u] with initial output ``state0`` (eq. 1-2).

    Parameters
    ----------
    u : array_like of shape (N,)
    r : float
        Threshold, ``r >= 0``.
    state0 : float
        Output before the first sample (M0).

    Returns
    -------
    ndarray of shape (N,)
    """
    Y, _ = play_bank(u, [r], [state0])
    return Y[:, 0]


def stop(u: ArrayLike, r: float, state0: float = 0.0) -> Float1D:
    """Stop (elastic-plastic) operator Ξ_r[u] = u − Γ_r[u], bounded by ``|Ξ| <= r`` (eq. 4-6, 26).

    Parameters
    ----------
    u : array_like of shape (N,)
    r : float
        Threshold, ``r >= 0``.
    state0 : float
        Stop output before the first sample, ``|state0| <= r``; it corresponds to a play
        state ``u[0] - state0`` referred to the first input.

    Returns
    -------
    ndarray of shape (N,)
    """
    u = as_input_signal(u)
    if abs(state0) > r:
        raise ParameterError(f"stop state0 = {state0:g} must satisfy |state0| <= r = {r:g}")
    if u.size == 0:
        return u.copy()
    return u - play(u, r, float(u[0]) - state0)


def dead_zone(u: ArrayLike, rho: float) -> Float1D:
    """Dead-zone operator S_ρ (paper 001 eq. 42).

    ``max(u - ρ, 0)`` for ρ > 0, ``u`` for ρ = 0, ``min(u - ρ, 0)`` for ρ < 0.

    Parameters
    ----------
    u : array_like of shape (N,)
    rho : float

    Returns
    -------
    ndarray of shape (N,)
    """
    u = np.asarray(u, dtype=np.float64)
    if rho > 0:
        return np.maximum(u - rho, 0.0)
    if rho < 0:
        return np.minimum(u - rho, 0.0)
    return u.copy()
