"""Plain-numpy reference implementations (the test oracle and the no-numba fallback).

The per-sample loop is vectorised over operators only; it is slow (about 2 µs per
sample) but obviously correct, and the compiled kernels must match it bit for bit.
"""

from __future__ import annotations

import numpy as np

from ._typing import Float1D, Float2D

__all__ = ["pi_output_reference", "play_matrix_reference"]


def play_matrix_reference(u: Float1D, r: Float1D, z0: Float1D) -> tuple[Float2D, Float1D]:
    """Play outputs by paper 001 eq. (1)-(2), one numpy step per sample.

    Parameters
    ----------
    u : ndarray of shape (N,)
    r : ndarray of shape (n,)
    z0 : ndarray of shape (n,)
        State before the first sample (the paper's M0).

    Returns
    -------
    Y : ndarray of shape (N, n)
    z : ndarray of shape (n,)
        State after the last sample.
    """
    u = np.asarray(u, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    z = np.array(z0, dtype=np.float64, copy=True)
    Y = np.empty((u.size, r.size))
    for k in range(u.size):
        z = np.maximum(u[k] - r, np.minimum(u[k] + r, z))
        Y[k] = z
    return Y, z


def pi_output_reference(
    u: Float1D, r: Float1D, w: Float1D, p0: float, z0: Float1D
) -> tuple[Float1D, Float1D]:
    """PI output ``p0*u + sum_i w_i Γ_{r_i}[u]`` with a sequential sum over operators.

    Returns
    -------
    y : ndarray of shape (N,)
    z : ndarray of shape (n,)
    """
    Y, z = play_matrix_reference(u, r, z0)
    acc = np.zeros(Y.shape[0])
    for i in range(Y.shape[1]):
        acc += w[i] * Y[:, i]
    return p0 * np.asarray(u, dtype=np.float64) + acc, z
