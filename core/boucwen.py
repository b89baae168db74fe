"""Rate-independent Bouc-Wen hysteresis: a bank of elements integrated in the input.

Element ``j`` has the hysteretic variable ``z_j`` (input units) driven by the input ``u``,

    dz_j/du = 1 - (beta_j sign(du z_j) + gamma_j) |z_j|^n_j,

(the Bouc-Wen law with ``alpha = 1``, written in the input instead of time, so the output
depends on the sequence of input values only). With ``beta_j >= 0`` and ``beta_j + gamma_j > 0``
the variable saturates at ``z_s = (beta_j + gamma_j)^(-1/n_j)`` and never leaves
``[-z_s, z_s]`` from a start inside it; ``beta_j > |gamma_j|`` gives the usual loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import kernels
from ._typing import ArrayLike, Float1D, Float2D
from .exceptions import ParameterError
from .validation import as_finite_scalar, as_input_signal, as_vector

__all__ = ["BoucWenState", "bouc_wen_states", "saturation_levels"]


@dataclass(frozen=True, eq=False)
class BoucWenState:
    """Where a bank of Bouc-Wen elements stands: the last input and each hysteretic variable.

    Attributes
    ----------
    u : float
        The last input value (input units); the next sample is integrated from it.
    z : ndarray of shape (m,)
        Hysteretic variable of each element at that input (input units).
    """

    u: float
    z: Float1D


def saturation_levels(beta: ArrayLike, gamma: ArrayLike, n: ArrayLike) -> Float1D:
    """Saturation ``z_s = (beta + gamma)^(-1/n)`` of each element, ``inf`` where
    ``beta + gamma <= 0`` (no bound).

    Returns
    -------
    ndarray of shape (m,)
        Input units.
    """
    s = np.asarray(beta, dtype=np.float64) + np.asarray(gamma, dtype=np.float64)
    e = np.asarray(n, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(s > 0, np.abs(s) ** (-1.0 / e), np.inf)
    return np.asarray(out, dtype=np.float64)


def bouc_wen_states(
    u: ArrayLike,
    beta: ArrayLike,
    gamma: ArrayLike,
    n: ArrayLike,
    z0: ArrayLike | None = None,
    *,
    max_step: float,
    u0: float | None = None,
    max_substeps: int = 0,
) -> tuple[Float2D, BoucWenState]:
    """Hysteretic variables of a bank of rate-independent Bouc-Wen elements.

    Each ``z_j`` is integrated along the input path with classical RK4 in the input, in
    ``ceil(|du| / max_step)`` equal sub-steps between consecutive samples (so a large jump,
    such as a staircase's step, is integrated as accurately as a slow ramp), and kept inside
    ``[-z_s, z_s]`` (:func:`saturation_levels`), which the exact solution never leaves.

    Parameters
    ----------
    u : array_like of shape (N,)
        Input samples (input units).
    beta, gamma : array_like of shape (m,)
        Shape parameters of each element (input units to the power ``-n_j``).
    n : array_like of shape (m,)
        Exponents, ``>= 1``.
    z0 : array_like of shape (m,), optional
        Hysteretic variables before the first sample (zeros by default).
    max_step : float
        Largest RK4 sub-step (input units), ``> 0``.
    u0 : float, optional
        Input before the first sample: the integration starts there. By default ``u[0]``
        (``z`` at the first sample is ``z0``).
    max_substeps : int
        Most sub-steps per sample (0: no limit); a longer jump takes longer sub-steps.

    Returns
    -------
    Z : ndarray of shape (N, m)
        ``Z[k, j] = z_j`` after sample ``k``.
    state : BoucWenState
        The last input and the variables after it: continue a record with
        ``bouc_wen_states(u_next, ..., z0=state.z, u0=state.u)``.

    Raises
    ------
    ParameterError
        If a parameter is not finite, the lengths differ, ``n < 1`` or ``max_step <= 0``.

    Examples
    --------
    >>> Z, st = bouc_wen_states([0.0, 1.0], [0.5], [0.5], [1.0], max_step=0.01)
    >>> round(float(Z[1, 0]), 6)  # 1 - exp(-1)
    0.632121
    """
    x = as_input_signal(u)
    b = as_vector(beta, "beta")
    g = as_vector(gamma, "gamma", length=b.size)
    e = as_vector(n, "n", length=b.size)
    if (e < 1).any():
        j = int(np.flatnonzero(e < 1)[0])
        raise ParameterError(f"n[{j}] = {e[j]:g} must be >= 1 (the exponent of |z|)")
    z = (
        np.zeros(b.size)
        if z0 is None
        else np.array(as_vector(z0, "z0", length=b.size), dtype=np.float64, copy=True)
    )
    h = as_finite_scalar(max_step, "max_step", positive=True)
    start = (float(x[0]) if x.size else 0.0) if u0 is None else as_finite_scalar(u0, "u0")
    out = np.empty((x.size, b.size))
    kernels.bouc_wen_bank(
        x,
        start,
        np.ascontiguousarray(b),
        np.ascontiguousarray(g),
        np.ascontiguousarray(e),
        saturation_levels(b, g, e),
        h,
        int(max_substeps),
        z,
        out,
    )
    last = float(x[-1]) if x.size else start
    return out, BoucWenState(last, z)
