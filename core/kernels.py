"""Compiled play-operator kernels (numba, ``cache=True``).

Loop order is time outer, operators inner (row-major ``(N, n)`` outputs), which lets
LLVM vectorise across the independent operators (see ``shared/notes/perf-baseline.md``).
Every kernel takes the operator state before the first sample and returns the state
after the last, so long or streamed records can be processed in chunks.

Two PI-output kernels exist:

* :func:`pi_output_fast` sums the weighted operators with ``fastmath={'reassoc'}`` so the
  dot product vectorises (about 0.25 ns per operator-update); results may differ from a
  sequential sum at the 1e-16 relative level.
* :func:`pi_output_strict` sums sequentially; it is bit-identical to the numpy oracle in
  :mod:`core.reference`.

The play update is ``z = max(u - r, min(u + r, z))`` (paper 001 eq. 1), written with
comparisons only, so the operator matrix is bit-identical to any other implementation.
"""

from __future__ import annotations

import os

__all__ = [
    "NUMBA_ENABLED",
    "pi_batch",
    "pi_output_fast",
    "pi_output_strict",
    "play_matrix",
]

NUMBA_ENABLED = os.environ.get("HYST_DISABLE_NUMBA", "") not in ("1", "true", "yes")

if NUMBA_ENABLED:
    from numba import njit
else:  # pragma: no cover - exercised only when numba is disabled on purpose

    def njit(*args, **kwargs):  # type: ignore[no-redef]
        if args and callable(args[0]):
            return args[0]
        return lambda f: f


@njit(cache=True, nogil=True)
def play_matrix(u, r, z, out):  # pragma: no cover - compiled
    """Play-operator outputs for every sample and operator.

    Parameters
    ----------
    u : ndarray of shape (N,)
        Input samples.
    r : ndarray of shape (n,)
        Thresholds, ``r >= 0``.
    z : ndarray of shape (n,)
        Operator outputs before the first sample; updated in place to the final state.
    out : ndarray of shape (N, n)
        C-contiguous buffer written with the operator outputs.
    """
    N = u.shape[0]
    n = r.shape[0]
    for k in range(N):
        uk = u[k]
        for i in range(n):
            lo = uk - r[i]
            hi = uk + r[i]
            zi = z[i]
            if zi > hi:
                zi = hi
            if zi < lo:
                zi = lo
            z[i] = zi
            out[k, i] = zi


@njit(cache=True, nogil=True)
def pi_output_strict(u, r, w, p0, z, out):  # pragma: no cover - compiled
    """PI output ``p0*u + sum_i w_i * play_i`` summed sequentially (deterministic).

    Parameters
    ----------
    u : ndarray of shape (N,)
    r, w : ndarray of shape (n,)
        Thresholds and weights.
    p0 : float
        Weight of the linear term.
    z : ndarray of shape (n,)
        Operator state, updated in place.
    out : ndarray of shape (N,)
    """
    N = u.shape[0]
    n = r.shape[0]
    for k in range(N):
        uk = u[k]
        acc = 0.0
        for i in range(n):
            lo = uk - r[i]
            hi = uk + r[i]
            zi = z[i]
            if zi > hi:
                zi = hi
            if zi < lo:
                zi = lo
            z[i] = zi
            acc += w[i] * zi
        out[k] = p0 * uk + acc


@njit(cache=True, nogil=True, fastmath={"reassoc"})
def pi_output_fast(u, r, w, p0, z, out):  # pragma: no cover - compiled
    """Same as :func:`pi_output_strict` but the sum may be reassociated (vectorised)."""
    N = u.shape[0]
    n = r.shape[0]
    for k in range(N):
        uk = u[k]
        acc = 0.0
        for i in range(n):
            lo = uk - r[i]
            hi = uk + r[i]
            zi = z[i]
            zi = min(zi, hi)
            zi = max(zi, lo)
            z[i] = zi
            acc += w[i] * zi
        out[k] = p0 * uk + acc


@njit(cache=True, nogil=True, fastmath={"reassoc"})
def pi_batch(u, R, W, p0, Z, out):  # pragma: no cover - compiled
    """Evaluate S parameter sets on one input (slider dragging, sweeps).

    Parameters
    ----------
    u : ndarray of shape (N,)
    R, W : ndarray of shape (S, n)
        Thresholds and weights per set.
    p0 : ndarray of shape (S,)
    Z : ndarray of shape (S, n)
        States, updated in place.
    out : ndarray of shape (S, N)
    """
    S = R.shape[0]
    N = u.shape[0]
    n = R.shape[1]
    for s in range(S):
        for k in range(N):
            uk = u[k]
            acc = 0.0
            for i in range(n):
                zi = Z[s, i]
                zi = min(zi, uk + R[s, i])
                zi = max(zi, uk - R[s, i])
                Z[s, i] = zi
                acc += W[s, i] * zi
            out[s, k] = p0[s] * uk + acc
