"""Streaming normal equations and the constrained least-squares solver behind every PI fit.

A PI-type model is linear in its weights once the thresholds are fixed: with the play
outputs ``z_i(t) = Γ_{r_i}[x](t)`` the model reads ``y ≈ c + p0 x + Σ p_i z_i + Σ e_j E_j``,
a least-squares problem with the design matrix ``A = [1, x, Z, E]`` (``E`` are optional extra
memoryless columns). For long records the ``N × m`` matrix is never built: the input is
streamed in chunks of ~8k samples, the play operators run into a reused ``(chunk, n)``
buffer with their state carried from chunk to chunk, and the augmented Gram matrix
``[A, y]ᵀ [A, y]`` is accumulated with BLAS (``shared/notes/perf-baseline.md`` §5, §8).
Memory is ``O(chunk · m + m²)`` whatever the record length.

Each sample carries an integer label: ``-1`` samples only advance the operator states
(burn-in, gaps, the part before a training window), ``0..L-1`` select the Gram matrix the
sample is added to (blocks for cross-validation, training, held-out). Labels cost one byte
per sample; a recording without labels goes entirely to label 0.

The solver (:func:`solve_constrained`) minimises ``||A θ - y||²`` subject to per-parameter
lower bounds (``-inf`` = free, 0 for the play weights, ``ε > 0`` for ``p0``) by
(1) shifting the bounded variables so that every bound becomes 0, (2) ordering the free
variables first, (3) column scaling, (4) taking an upper-triangular factor ``R`` with
``RᵀR`` = the scaled Gram matrix (Cholesky), and (5) solving the small NNLS problem on the
rows of ``R`` that do not involve the free variables, then back-substituting the free ones.
When the scaled Gram matrix is ill conditioned (above :data:`COND_LIMIT`) the factor ``R`` is
recomputed without squaring the condition number, by a chunked TSQR pass over the data
(:func:`stream_tsqr`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import kernels
from .._typing import Float1D, Float2D

__all__ = [
    "COND_LIMIT",
    "DEFAULT_CHUNK",
    "ConstrainedSolution",
    "Segment",
    "nnls_checked",
    "r_factor",
    "solve_constrained",
    "stream_gram",
    "stream_tsqr",
]

#: Samples per chunk of the streaming passes (~8k rows: buffers stay in L2/L3 cache).
DEFAULT_CHUNK = 8192
#: Condition number of the column-scaled Gram matrix above which TSQR is used instead.
COND_LIMIT = 1e10

Transform = Callable[[Float1D], Float1D]
Extra = Callable[[Float1D, Float1D, Float1D | None], Float2D]


@dataclass(frozen=True, eq=False)
class Segment:
    """One recording prepared for streaming.

    Attributes
    ----------
    u : ndarray of shape (N,)
        Input samples.
    y : ndarray of shape (N,)
        Output samples.
    labels : ndarray of int8, shape (N,), or None
        Gram matrix each sample is added to (``-1``: none, only advances the state);
        ``None`` means every sample has label 0.
    z0 : ndarray of shape (n,), or None
        Play states before the first sample; ``None`` relaxes every operator at the first
        (transformed) input sample, ``z_i = x[0]``.
    aux : ndarray of shape (N,), or None
        Extra per-sample signal handed to the ``extra`` column callable (e.g. the measured
        output when the regression target is a transformed output).
    """

    u: Float1D
    y: Float1D
    labels: np.ndarray | None = None
    z0: Float1D | None = None
    aux: Float1D | None = None


@dataclass(frozen=True, eq=False)
class ConstrainedSolution:
    """Result of :func:`solve_constrained`.

    Attributes
    ----------
    theta : ndarray of shape (p,)
        Parameters in the column order of the design matrix.
    sse : float
        Residual sum of squares of the solution on the rows in the Gram matrix.
    cond : float
        Condition number of the column-scaled Gram matrix (parameter columns only).
    active : ndarray of bool, shape (p,)
        Parameters sitting on their lower bound.
    """

    theta: Float1D
    sse: float
    cond: float
    active: np.ndarray = field(repr=False)


def _columns(
    x: Float1D, y: Float1D, extra_cols: Float2D | None, out: Float2D
) -> Float2D:
    """Fill ``out`` (rows, 3 + k) with ``[1, x, E, y]``."""
    k = out.shape[1] - 3
    out[:, 0] = 1.0
    out[:, 1] = x
    if k:
        out[:, 2 : 2 + k] = extra_cols
    out[:, -1] = y
    return out


def _iter_chunks(
    segments: Sequence[Segment],
    thresholds: Float1D,
    n_extra: int,
    transform: Transform | None,
    extra: Extra | None,
    chunk: int,
):
    """Yield ``(Z, W, labels_or_None)`` per chunk; Z and W are reused buffers."""
    r = np.ascontiguousarray(thresholds, dtype=np.float64)
    n = r.size
    zbuf = np.empty((chunk, n))
    wbuf = np.empty((chunk, 3 + n_extra))
    for seg in segments:
        N = seg.u.size
        z = None
        for s0 in range(0, N, chunk):
            s1 = min(N, s0 + chunk)
            uc = seg.u[s0:s1]
            xc = uc if transform is None else np.ascontiguousarray(transform(uc))
            if z is None:
                z = (
                    np.full(n, float(xc[0]))
                    if seg.z0 is None
                    else np.array(seg.z0, dtype=np.float64, copy=True)
                )
            c = s1 - s0
            Z = zbuf[:c]
            kernels.play_matrix(xc, r, z, Z)
            ac = None if seg.aux is None else seg.aux[s0:s1]
            ec = extra(uc, seg.y[s0:s1], ac) if extra is not None else None
            W = _columns(xc, seg.y[s0:s1], ec, wbuf[:c])
            lab = None if seg.labels is None else seg.labels[s0:s1]
            yield Z, W, lab


def _assemble(gzz: Float2D, gzw: Float2D, gww: Float2D) -> Float2D:
    """Full Gram matrix in the column order [1, x, Z, E, y] from its blocks."""
    n = gzz.shape[0]
    k = gww.shape[0] - 3
    m = n + k + 3
    pos_w = np.r_[0, 1, np.arange(2 + n, 2 + n + k), m - 1].astype(int)
    pos_z = np.arange(2, 2 + n)
    G = np.empty((m, m))
    G[np.ix_(pos_z, pos_z)] = gzz
    G[np.ix_(pos_z, pos_w)] = gzw
    G[np.ix_(pos_w, pos_z)] = gzw.T
    G[np.ix_(pos_w, pos_w)] = gww
    return G


def stream_gram(
    segments: Sequence[Segment],
    thresholds: Float1D,
    *,
    n_labels: int = 1,
    transform: Transform | None = None,
    extra: Extra | None = None,
    n_extra: int = 0,
    chunk: int = DEFAULT_CHUNK,
) -> Float2D:
    """Accumulate the augmented Gram matrices ``[A, y]ᵀ[A, y]`` per label, chunk by chunk.

    Parameters
    ----------
    segments : sequence of Segment
        Recordings; the play states restart at each recording's ``z0``.
    thresholds : ndarray of shape (n,)
        Play thresholds (units of the transformed input ``x``).
    n_labels : int
        Number of Gram matrices (labels ``0..n_labels-1``; ``-1`` and labels
        ``>= n_labels`` are skipped).
    transform : callable, optional
        Memoryless input map ``x = transform(u)`` applied per chunk before the play
        operators (e.g. a dead-zone or tanh envelope); identity by default.
    extra : callable, optional
        ``extra(u_chunk, y_chunk, aux_chunk) -> (rows, n_extra)`` memoryless extra columns
        (``aux_chunk`` is ``None`` when the segment has no ``aux``).
    n_extra : int
        Number of extra columns.
    chunk : int
        Samples per chunk.

    Returns
    -------
    ndarray of shape (n_labels, m, m)
        With ``m = n + n_extra + 3`` and columns ``[1, x, z_1..z_n, E_1..E_k, y]``.
    """
    r = np.ascontiguousarray(thresholds, dtype=np.float64)
    n = r.size
    k = 3 + n_extra
    gzz = np.zeros((n_labels, n, n))
    gzw = np.zeros((n_labels, n, k))
    gww = np.zeros((n_labels, k, k))
    for Z, W, lab in _iter_chunks(segments, r, n_extra, transform, extra, chunk):
        if lab is None:
            groups = [(0, None)]
        else:
            lo, hi = int(lab.min()), int(lab.max())
            if lo == hi:
                groups = [] if (lo < 0 or lo >= n_labels) else [(lo, None)]
            else:
                groups = [(g, lab == g) for g in range(max(lo, 0), min(hi, n_labels - 1) + 1)]
        for g, sel in groups:
            if sel is None:
                Zs, Ws = Z, W
            else:
                if not sel.any():
                    continue
                Zs, Ws = Z[sel], W[sel]
            gzz[g] += Zs.T @ Zs
            gzw[g] += Zs.T @ Ws
            gww[g] += Ws.T @ Ws
    return np.stack([_assemble(gzz[g], gzw[g], gww[g]) for g in range(n_labels)])


def _qr_r(a: Float2D) -> Float2D:
    """The R factor of ``a`` (``numpy.linalg.qr(a, mode="r")``)."""
    return np.asarray(np.linalg.qr(a, mode="r"), dtype=np.float64)


def stream_tsqr(
    segments: Sequence[Segment],
    thresholds: Float1D,
    *,
    use_labels: Sequence[int] = (0,),
    transform: Transform | None = None,
    extra: Extra | None = None,
    n_extra: int = 0,
    chunk: int = DEFAULT_CHUNK,
) -> Float2D:
    """Upper-triangular factor ``R`` of ``[A, y]`` by chunked QR (TSQR), same columns as Gram.

    ``RᵀR`` equals the Gram matrix of the selected rows, but ``R`` is computed without
    forming ``AᵀA``, so its accuracy follows cond(A) rather than cond(A)².

    Parameters
    ----------
    segments, thresholds, transform, extra, n_extra, chunk
        As in :func:`stream_gram`.
    use_labels : sequence of int
        Rows whose label is in this set are used (all rows when a segment has no labels).

    Returns
    -------
    ndarray of shape (m, m)
    """
    r = np.ascontiguousarray(thresholds, dtype=np.float64)
    n = r.size
    m = n + n_extra + 3
    pos_w = np.r_[0, 1, np.arange(2 + n, 2 + n + n_extra), m - 1].astype(int)
    pos_z = np.arange(2, 2 + n)
    R = np.zeros((0, m))
    keep = np.asarray(list(use_labels))
    for Z, W, lab in _iter_chunks(segments, r, n_extra, transform, extra, chunk):
        sel = None if lab is None else np.isin(lab, keep)
        if sel is not None and not sel.any():
            continue
        rows = Z.shape[0] if sel is None else int(sel.sum())
        A = np.empty((rows, m))
        A[:, pos_z] = Z if sel is None else Z[sel]
        A[:, pos_w] = W if sel is None else W[sel]
        R = _qr_r(np.vstack((R, A)))
    if R.shape[0] < m:
        R = np.vstack((R, np.zeros((m - R.shape[0], m))))
    return R


def r_factor(A: Float2D) -> Float2D:
    """The triangular factor ``R`` of ``A = QR``, ``(min(m, n), n)`` for ``A`` ``(m, n)``:
    what ``np.linalg.qr(A, mode="r")`` returns (LAPACK's Householder ``dgeqrf``, the same
    numbers), from one Fortran-ordered copy of ``A`` factorised in place. numpy's gufunc
    copies the tall ``A`` in and out around the same call: a third slower on the ~10^4 x 100
    fallbacks of the diagnosis' structure fits."""
    from scipy.linalg import lapack

    F = np.array(A, dtype=np.float64, order="F")
    qr, _, _, info = lapack.dgeqrf(F, overwrite_a=True)
    if info != 0:  # pragma: no cover - LAPACK argument error
        return _qr_r(A)
    return np.triu(qr[: min(F.shape)])


def _triangular_factor(G: Float2D) -> Float2D:
    """Upper Cholesky factor of a symmetric PSD matrix; tiny diagonal jitter if singular."""
    try:
        return np.asarray(np.linalg.cholesky(G).T, dtype=np.float64)
    except np.linalg.LinAlgError:
        pass
    jitter = 1e-14 * max(float(np.max(np.diag(G))), 1e-300)
    for _ in range(8):
        try:
            return np.asarray(np.linalg.cholesky(G + jitter * np.eye(G.shape[0])).T,
                              dtype=np.float64)
        except np.linalg.LinAlgError:
            jitter *= 100.0
    # last resort: symmetric square root from the eigen-decomposition, then QR
    w, V = np.linalg.eigh(G)
    S = np.sqrt(np.clip(w, 0.0, None))[:, None] * V.T
    return _qr_r(S)


#: Largest violation of the optimality (KKT) conditions of a non-negative least-squares
#: solution accepted from ``scipy.optimize.nnls``, relative to ``|R| |z|`` of the scaled problem.
NNLS_KKT_TOL = 1e-9


def nnls_checked(Rb: Float2D, zb: Float1D, maxiter: int) -> tuple[Float1D, float]:
    """``min |Rb x - zb|, x >= 0``: scipy's ``nnls``, its answer checked against the
    optimality conditions (gradient ``g = Rb^T (zb - Rb x)``: ``g <= 0`` where ``x = 0``,
    ``g = 0`` where ``x > 0``). Where they fail, active-set iterations continue from that
    answer (:func:`_active_set_from`), and bounded-variable least squares
    (``lsq_linear(method="bvls")``) solves from scratch if those do not meet the conditions
    either; the residual norm is that of the returned ``x``.

    scipy 1.16 and 1.17's ``nnls`` can stop at a point that is not the minimum and return a
    residual norm that is not its own: on a diagnosis fold of the Preisach rate plant
    (130 columns, condition number 3.5e3) it returned residual 4.94e-3 (reported 2.97e-3)
    where the minimum is 3.607e-3, and the exact minimum for the same matrix changed by
    1e-12; scipy 1.15.3 solves both."""
    import scipy.optimize

    xb, _ = scipy.optimize.nnls(Rb, zb, maxiter=maxiter)
    tol = NNLS_KKT_TOL * max(float(np.linalg.norm(Rb)) * float(np.linalg.norm(zb)), 1e-300)
    if not _kkt_holds(Rb, zb, xb, tol):
        polished = _active_set_from(Rb, zb, xb, tol, max_steps=2 * Rb.shape[1] + 10)
        if polished is not None and _kkt_holds(Rb, zb, polished, tol):
            xb = polished
        else:
            xb = scipy.optimize.lsq_linear(Rb, zb, bounds=(0.0, np.inf), method="bvls",
                                           tol=1e-14).x
            xb = np.maximum(xb, 0.0)
    return xb, float(np.linalg.norm(Rb @ xb - zb))


def _kkt_holds(Rb: Float2D, zb: Float1D, x: Float1D, tol: float) -> bool:
    """Whether ``x >= 0`` meets the optimality conditions of ``min |Rb x - zb|, x >= 0`` to
    ``tol``: gradient ``g = Rb^T (zb - Rb x)`` at most ``tol`` where ``x = 0`` and within
    ``tol`` of zero where ``x > 0``."""
    g = Rb.T @ (zb - Rb @ x)
    return not (np.any(g[x <= 0] > tol) or np.any(np.abs(g[x > 0]) > tol))


def _active_set_from(Rb: Float2D, zb: Float1D, x0: Float1D, tol: float,
                     max_steps: int) -> Float1D | None:
    """Lawson-Hanson active-set iterations for ``min |Rb x - zb|, x >= 0`` started from the
    positive set of ``x0`` (a near-optimal answer), or ``None`` when they have not met the
    optimality conditions within ``max_steps`` column moves.

    Each pass solves the unconstrained problem on the positive set; where that solution
    leaves the feasible set, ``x`` moves toward it until the first coordinate reaches zero,
    which leaves the set. When the solution is feasible, the zero coordinate with the
    largest gradient above ``tol`` joins the set. Started from scipy's answer, a few moves
    suffice where a solve from scratch (bounded-variable least squares) takes hundreds of
    least-squares solves: 78 such problems of 130-505 columns, 15.2 s -> 1.4 s, residuals
    equal to 1e-15."""
    x = np.maximum(np.asarray(x0, dtype=np.float64), 0.0)
    positive = x > 0
    for _ in range(max_steps):
        s = np.zeros_like(x)
        if positive.any():
            s[positive] = np.linalg.lstsq(Rb[:, positive], zb, rcond=None)[0]
        leaving = positive & (s <= 0)
        if leaving.any():
            idx = np.flatnonzero(leaving)
            ratios = x[idx] / (x[idx] - s[idx])
            x = x + float(np.min(ratios)) * (s - x)
            positive[idx[np.argmin(ratios)]] = False
            positive &= x > 0
            x[~positive] = 0.0
            continue
        x = s
        g = Rb.T @ (zb - Rb @ x)
        entering = ~positive & (g > tol)
        if not entering.any():
            return x
        positive[int(np.argmax(np.where(entering, g, -np.inf)))] = True
    return None


def solve_constrained(
    lower: Float1D,
    *,
    gram: Float2D | None = None,
    factor: Float2D | None = None,
    cond_limit: float = float("inf"),
) -> ConstrainedSolution:
    """Least squares with lower bounds from an augmented Gram matrix or triangular factor.

    Minimises ``||A θ - y||²`` subject to ``θ_j >= lower_j`` (``-inf`` marks a free
    parameter), given either ``gram = [A, y]ᵀ[A, y]`` or any ``factor`` ``R`` with
    ``RᵀR = gram`` (for instance from :func:`stream_tsqr`).

    Parameters
    ----------
    lower : ndarray of shape (p,)
        Lower bound of each parameter (``p = m - 1``; the last column is ``y``).
    gram : ndarray of shape (m, m), optional
    factor : ndarray of shape (m, m), optional
        Exactly one of ``gram`` / ``factor``.
    cond_limit : float
        Above this condition number the bounded solve is not made: ``theta`` and ``sse``
        are NaN, ``cond`` is set (for a caller that then solves from a triangular factor
        instead, which discards this solution).

    Returns
    -------
    ConstrainedSolution
    """
    import scipy.linalg
    import scipy.optimize

    lower = np.asarray(lower, dtype=np.float64)
    p = lower.size
    m = p + 1
    free = ~np.isfinite(lower)
    lb = np.where(free, 0.0, lower)
    # shift: y' = y - sum_j lb_j a_j   (T = identity with T[j, y] = -lb_j)
    T = np.eye(m)
    T[:p, p] = -lb
    perm = np.r_[np.flatnonzero(free), np.flatnonzero(~free), p]
    nf = int(free.sum())
    if gram is not None:
        Gt = T.T @ gram @ T
        Gt = Gt[np.ix_(perm, perm)]
        d = np.sqrt(np.clip(np.diag(Gt), 0.0, None))
        d[d == 0] = 1.0
        Gs = Gt / d[:, None] / d[None, :]
        R = _triangular_factor(0.5 * (Gs + Gs.T))
    elif factor is not None:
        Rt = (factor @ T)[:, perm]
        d = np.linalg.norm(Rt, axis=0)
        d[d == 0] = 1.0
        R = _qr_r(Rt / d)
    else:  # pragma: no cover - programming error
        raise ValueError("solve_constrained needs gram= or factor=")
    # make the diagonal non-negative (QR sign convention)
    sgn = np.where(np.diag(R) < 0, -1.0, 1.0)
    R = R * sgn[:, None]
    Rp = R[:p, :p]
    sv = np.linalg.svd(Rp, compute_uv=False)
    ratio = float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")
    cond = ratio * ratio if ratio < 1e150 else float("inf")  # no overflow warning
    if cond > cond_limit:
        return ConstrainedSolution(theta=np.full(p, np.nan), sse=float("nan"), cond=cond,
                                   active=np.zeros(p, dtype=bool))
    zb = R[nf:p, p]
    Rb = R[nf:p, nf:p]
    if p - nf > 0:
        xb, rnorm = nnls_checked(Rb, zb, 50 * (p - nf) + 100)
    else:
        xb, rnorm = np.zeros(0), float(np.linalg.norm(zb))
    if nf:
        rhs = R[:nf, p] - R[:nf, nf:p] @ xb
        diag = np.diag(R[:nf, :nf])
        if np.any(diag == 0):
            xf = np.linalg.lstsq(R[:nf, :nf], rhs, rcond=None)[0]
        else:
            xf = scipy.linalg.solve_triangular(R[:nf, :nf], rhs, lower=False)
    else:
        xf = np.zeros(0)
    xs = np.concatenate((xf, xb))
    # unscale (the y column scale d[-1] multiplies every parameter and the residual)
    x_perm = xs * d[-1] / d[:p]
    theta = np.empty(p)
    theta[perm[:p]] = x_perm
    theta = theta + lb
    sse = float((rnorm**2 + R[p, p] ** 2) * d[-1] ** 2)
    active = np.zeros(p, dtype=bool)
    active[perm[nf:p]] = xb <= 0
    return ConstrainedSolution(theta=theta, sse=sse, cond=cond, active=active)
