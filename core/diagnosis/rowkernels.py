"""The compiled row kernels of the structure fit (:mod:`core.diagnosis.structure`).

A structure fit solves its weights on a few thousand sampled rows of signals that run over
every sample (play banks, output filters). These kernels form only the rows asked for,
with the numbers of the whole computation: the play bank's rows (:func:`play_rows`), the
product of a play bank with a reduced basis formed along the input
(:func:`play_projection`, :func:`bank_rows_times`, :func:`input_rows_times`), and the rows
of columns through a filter (:func:`iir_rows`) or a fractional delay (:func:`delay_rows`).
"""

from __future__ import annotations

import numpy as np

from ..kernels import njit, play_update

__all__ = ["bank_rows_times", "delay_rows", "iir_rows", "input_rows_times", "play_projection",
           "play_rows", "row_selector", "turns_rarely"]


def row_selector(idx: np.ndarray) -> slice | np.ndarray:
    """Index ``B[sel]`` equal to ``B[idx]`` for increasing indices ``idx``: a slice (a strided
    view, no gather) when they are evenly spaced, as in a single training window."""
    if idx.size > 1:
        d = np.diff(idx)
        if d[0] > 0 and np.all(d == d[0]):
            return slice(int(idx[0]), int(idx[-1]) + 1, int(d[0]))
    return idx


@njit(cache=True, nogil=True)
def iir_rows(b, a, zi, x, rows, out):  # pragma: no cover - compiled
    """Direct-form-II-transposed filter ``b/a`` (order 1 or 2) of the columns of ``x``.

    ``x`` is row-major ``(N, m)``, the filter starts in the steady state of ``x[0]``
    (state ``zi * x[0]``, as :func:`core.stages.foh_filter`), and only the increasing rows
    ``rows`` are written to ``out`` ``(rows.size, m)``. Time is the outer loop so that the
    ``m`` independent recursions vectorise; the operation order is scipy's ``lfilter``.
    """
    m = x.shape[1]
    order = a.size - 1
    b0 = b[0]
    b1 = b[1]
    a1 = a[1]
    b2 = b[2] if order == 2 else 0.0
    a2 = a[2] if order == 2 else 0.0
    z0 = np.empty(m)
    z1 = np.zeros(m)
    for j in range(m):
        z0[j] = zi[0] * x[0, j]
        if order == 2:
            z1[j] = zi[1] * x[0, j]
    k = 0
    for i in range(rows[-1] + 1 if rows.size else 0):
        take = rows[k] == i
        for j in range(m):
            xi = x[i, j]
            yi = b0 * xi + z0[j]
            if order == 2:
                z0[j] = z1[j] + xi * b1 - yi * a1
                z1[j] = xi * b2 - yi * a2
            else:
                z0[j] = xi * b1 - yi * a1
            if take:
                out[k, j] = yi
        if take:
            k += 1
    return out


@njit(cache=True, nogil=True)
def play_rows(u, r, z, rows, out):  # pragma: no cover - compiled
    """Rows ``rows`` (increasing) of the play bank of thresholds ``r`` on input ``u`` from the
    state ``z`` (updated in place), without storing the others: the update of
    :func:`core.kernels.play_matrix`, so the same numbers."""
    n = r.size
    k = 0
    for i in range(rows[-1] + 1 if rows.size else 0):
        ui = u[i]
        for j in range(n):
            z[j] = play_update(z[j], ui, r[j])
        if i == rows[k]:
            for j in range(n):
                out[k, j] = z[j]
            k += 1
    return out


@njit(cache=True, nogil=True)
def play_projection(w, r, z, V, rows, out):  # pragma: no cover - compiled  # noqa: C901 - the fast paths of one product, each a guarded branch
    """Rows ``rows`` of ``B @ V``, ``B`` the play bank of thresholds ``r`` (``r[0] = 0``: the
    input itself) on input ``w``, without forming ``B`` or the ``(N, n) x (n, q)`` product.

    ``z`` ``(n,)``: the bank's row 0 (the play outputs after ``w[0]``); overwritten.
    On a monotone stretch a play either follows the input (``z_j = w -/+ r_j``) or is
    stuck, so ``B[i] @ V = C + w_i S - R`` with ``C`` the stuck plays' ``z_j V_j``, ``S`` the
    moving plays' ``V_j`` and ``R`` their ``+/- r_j V_j``: a row costs ``O(q)``, and the exact
    play update (:func:`core.kernels.play_matrix`) runs over all plays only at a reversal or
    where a stuck play may start to move (its level is within round-off of the input). The
    sums are rebuilt after ``4 n`` changes, so their round-off stays that of a few sums.
    Writes ``out`` ``(rows.size, q)`` (increasing rows).
    """
    n = r.size
    q = V.shape[1]
    status = np.zeros(n, dtype=np.int8)  # 0 stuck, 1 follows w - r, -1 follows w + r
    C = np.zeros(q)
    S = np.zeros(q)
    R = np.zeros(q)
    for j in range(n):
        for c in range(q):
            C[c] += z[j] * V[j, c]
    n_up = 0  # moving plays with r > 0 by direction
    n_dn = 0
    up_lvl = -np.inf  # the input levels where a stuck play starts to move up / down
    dn_lvl = np.inf
    changes = 4 * n + 1  # force the first exact pass to set the levels
    rmax = 0.0
    for j in range(n):
        rmax = max(rmax, r[j])
    k = 0
    last = rows[-1] if rows.size else -1
    for i in range(last + 1):
        wi = w[i]
        fast = True
        if i > 0:
            tol = 8.0 * 2.220446049250313e-16 * (abs(wi) + rmax)
            wp = w[i - 1]
            fast = wi == wp or (wi > wp and n_dn == 0 and wi < up_lvl - tol) or (
                wi < wp and n_up == 0 and wi > dn_lvl + tol)
            if not fast:
                for j in range(n):
                    lo = wi - r[j]
                    hi = wi + r[j]
                    # (a moving play's state is not stored on the fast rows: it is the
                    # previous input -/+ its threshold, formed as the play update forms it)
                    zj = z[j] if status[j] == 0 else (wp - r[j] if status[j] == 1
                                                      else wp + r[j])
                    if zj > hi:
                        zj = hi
                    if zj < lo:
                        zj = lo
                    st = 1 if zj == lo else (-1 if zj == hi else 0)
                    if st != status[j]:
                        old = status[j]
                        if old == 0:
                            for c in range(q):
                                C[c] -= z[j] * V[j, c]
                        else:
                            for c in range(q):
                                S[c] -= V[j, c]
                                R[c] -= old * r[j] * V[j, c]
                            if r[j] > 0:
                                if old == 1:
                                    n_up -= 1
                                else:
                                    n_dn -= 1
                        if st == 0:
                            for c in range(q):
                                C[c] += zj * V[j, c]
                        else:
                            for c in range(q):
                                S[c] += V[j, c]
                                R[c] += st * r[j] * V[j, c]
                            if r[j] > 0:
                                if st == 1:
                                    n_up += 1
                                else:
                                    n_dn += 1
                        status[j] = st
                        changes += 1
                    z[j] = zj
        if changes > 4 * n:
            # rebuild the sums from the play states (bounds their round-off) and the levels
            for c in range(q):
                C[c] = 0.0
                S[c] = 0.0
                R[c] = 0.0
            for j in range(n):
                if status[j] == 0:
                    for c in range(q):
                        C[c] += z[j] * V[j, c]
                else:
                    for c in range(q):
                        S[c] += V[j, c]
                        R[c] += status[j] * r[j] * V[j, c]
            changes = 0
        if changes == 0 or not fast:
            up_lvl = np.inf
            dn_lvl = -np.inf
            for j in range(n):
                if status[j] == 0:
                    up_lvl = min(up_lvl, z[j] + r[j])
                    dn_lvl = max(dn_lvl, z[j] - r[j])
        if i == rows[k]:
            if i == 0:
                for c in range(q):
                    acc = 0.0
                    for j in range(n):
                        acc += z[j] * V[j, c]
                    out[k, c] = acc
            else:
                for c in range(q):
                    out[k, c] = C[c] + wi * S[c] - R[c]
            k += 1
    return out


def bank_rows_times(B: np.ndarray, V: np.ndarray, r: np.ndarray, rows: np.ndarray
                     ) -> np.ndarray | None:
    """``(B @ V)[rows]`` for a play bank ``B`` ``(N, n)`` of thresholds ``r`` (``r[0] = 0``,
    column 0 the input) by :func:`play_projection`, from row ``rows[0]`` on; ``None`` when
    the input turns so often (measurement noise on it) that the product is cheaper."""
    if not rows.size:
        return None
    s0 = int(rows[0])
    w = np.ascontiguousarray(B[s0 : int(rows[-1]) + 1, 0])
    if not turns_rarely(w, r.size):
        return None
    return input_rows_times(w, B[s0], V, r, np.asarray(rows, dtype=np.int64) - s0)


def turns_rarely(w: np.ndarray, n: int) -> bool:
    """Whether the input ``w`` reverses rarely enough (``n`` plays) for
    :func:`play_projection` to beat the product."""
    d = np.diff(w)
    d = d[d != 0]
    return bool(np.count_nonzero((d[1:] > 0) != (d[:-1] > 0)) * n <= 0.5 * w.size)


def input_rows_times(w: np.ndarray, z0: np.ndarray, V: np.ndarray, r: np.ndarray,
                      rows: np.ndarray) -> np.ndarray:
    """Rows ``rows`` of ``B @ V``, ``B`` the bank of thresholds ``r`` on input ``w`` whose row 0
    is ``z0`` (:func:`play_projection`)."""
    out = np.empty((rows.size, V.shape[1]))
    return play_projection(np.ascontiguousarray(w, dtype=np.float64),
                            np.ascontiguousarray(r, dtype=np.float64),
                            np.array(z0, dtype=np.float64), np.ascontiguousarray(V), rows, out)


@njit(cache=True, nogil=True)
def delay_rows(x, rows, m, f, out):  # pragma: no cover - compiled
    """Rows ``rows`` of ``x`` delayed by ``m + f`` samples (``0 <= f < 1``), linearly
    interpolated and held at ``x[0]`` before the start:
    ``out[k] = f x[rows[k] - m - 1] + (1 - f) x[rows[k] - m]``."""
    g = 1 - f
    for k in range(rows.size):
        i1 = max(rows[k] - m - 1, 0)
        i2 = max(rows[k] - m, 0)
        for j in range(x.shape[1]):
            out[k, j] = f * x[i1, j] + g * x[i2, j]
    return out
