"""The solve of a structure fit (:func:`core.diagnosis.structure.fit_structure`).

The design matrix of a structure (its columns, the output last) becomes weights here: the
Gram matrix with its memoised PI-stage block (:func:`gram`), the bounds of the weights
(:func:`constraints`, :func:`min_slope`), the constrained solve with its pseudo rows
(:func:`solve`, :func:`level_penalty`) and the unconstrained residual of a ranking solve
(:func:`unconstrained_rss`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..fitting.gram import COND_LIMIT, r_factor, solve_constrained
from .bankcache import BankCache, recent

if TYPE_CHECKING:
    from .structure import Structure

__all__ = ["constraints", "gram", "level_penalty", "min_slope", "solve", "still_elements",
           "unconstrained_rss"]


def gram(X: np.ndarray, nq: int, cache: BankCache, key: Any, owner: Any) -> np.ndarray:
    """``X.T @ X`` with the block of the first ``nq`` columns (the PI stage: play bank through
    the output dynamics) memoised in ``cache`` on ``key``; ``owner`` is kept with the entry
    and must be the same object on a hit (its identity is part of the key).

    A miss forms the whole matrix in one symmetric product (one pass over the ``(N, p)``
    rows; the block alone and then its cross products read the PI-stage columns twice). On
    a hit only the cross products of the other columns (bilinear regressors, bias, drift,
    output: they change between structures and refreshes) are formed, as ``X2.T @ X`` (the
    thin factor on the left reads the wide block once, in row order)."""
    hit = recent(cache.g, key)
    if hit is not None and hit[0] is owner:
        X2 = np.ascontiguousarray(X[:, nq:])
        G = np.empty((X.shape[1], X.shape[1]))
        G[:nq, :nq] = hit[1]
        G[nq:, :] = X2.T @ X
        G[:nq, nq:] = G[nq:, :nq].T
        return G
    G = X.T @ X
    if len(cache.g) >= 16:
        cache.g.pop(next(iter(cache.g)))
    cache.g[key] = (owner, G[:nq, :nq].copy())
    return G


def unconstrained_rss(Xa: np.ndarray) -> float:
    """Residual sum of squares of the unconstrained least-squares fit of the last column of
    ``Xa`` on the others: Cholesky of the column-scaled normal equations, or ``lstsq`` when
    they are ill conditioned (condition number above :data:`core.fitting.gram.COND_LIMIT`)."""
    G = Xa.T @ Xa
    p = G.shape[0] - 1
    d = np.sqrt(np.diag(G)[:p])
    d[d == 0] = 1.0
    Gs = G[:p, :p] / d[:, None] / d[None, :]
    ev = np.linalg.eigvalsh(Gs)
    if ev[0] > 0 and ev[-1] <= COND_LIMIT * ev[0]:
        L = np.linalg.cholesky(Gs)
        w = np.linalg.solve(L.T, np.linalg.solve(L, G[:p, p] / d)) / d
    else:
        w = np.linalg.lstsq(Xa[:, :p], Xa[:, p], rcond=None)[0]
    e = Xa @ np.append(w, -1.0)
    return float(e @ e)


def level_penalty(n_play: int, m: int, ncol: int, lam: float) -> np.ndarray:
    """Pseudo rows ``sqrt(lam) (W[i, j] - W[i, j - 1])`` of a Preisach base (column
    ``i m + j``), zero in the output column; ``(n_play (m - 1), ncol + 1)``."""
    P = np.zeros((n_play * (m - 1), ncol + 1))
    q = np.sqrt(lam)
    row = 0
    for i in range(n_play):
        for j in range(1, m):
            P[row, i * m + j] = q
            P[row, i * m + j - 1] = -q
            row += 1
    return P


def min_slope(inputs: list, train: Sequence[np.ndarray], ylo: float, yhi: float) -> float:
    """The smallest loop-segment slope of an invertible PI stage: 1e-3 of the output range
    over the range of the play bank's input ``inputs`` (per recording; the loop-shape map's
    output when there is one; a bank may stop at its last training row) on the training
    rows, as :func:`core.fitting.default_min_slope`."""
    w_tr = [w[m[: w.shape[0]]] for w, m in zip(inputs, train, strict=True) if m.any()]
    ulo = min(float(w.min()) for w in w_tr)
    uhi = max(float(w.max()) for w in w_tr)
    return 1e-3 * (yhi - ylo) / max(uhi - ulo, 1e-300)


def constraints(s: Structure, X: np.ndarray, nb: int, eps: float, terms: list) -> np.ndarray:
    """Lower bounds of the weights (the columns of ``X`` but its last), ``nb`` base columns
    first, then the static ``terms`` (:func:`~.structure._term_columns`). An invertible PI
    stage (as the fitting's constraint_transform): free weights solve for the loop-segment slopes
    ``S_j = p0 + p_1 + ... + p_j >= eps`` (the columns of ``X`` become ``X_j - X_{j+1}``, in
    place), classical ones for ``p0 >= eps, p_j >= 0``; each term's weights within its own
    bound."""
    lower = np.full(X.shape[1] - 1, -np.inf)
    lower[:nb] = eps
    n_lev = len(s.levels) + 1
    if s.levels:
        # Preisach base: every segment of the reversible part rises (>= eps), the level
        # segments of the plays are a nonnegative relay density
        lower[n_lev:nb] = 0.0
    elif s.bouc_wen:
        # Bouc-Wen base: columns m_j u - z_j, weights >= 0 (an invertible hardening loop,
        # core.diagnosis.bases) or of either sign with free weights
        lower[1:nb] = -np.inf if s.free_weights else 0.0
    elif s.stop:
        # stop base: columns [v, v - Gamma_i(v)] (the elements' deflections), k >= eps and
        # w_i >= 0 (a clockwise, invertible Maxwell-slip bank)
        X[:, 1:nb] = X[:, :1] - X[:, 1:nb]
        lower[1:nb] = 0.0
    elif s.free_weights:
        X[:, : nb - 1] -= X[:, 1:nb]
    else:
        lower[1:nb] = 0.0
    for _, t, _, a, b in terms:
        lower[a:b] = t.lower
    return lower


def still_elements(s: Structure, X: np.ndarray, nb: int,
                   plays: np.ndarray | None = None) -> np.ndarray | None:
    """The Maxwell-slip elements of a stop base that never slide on the solved rows (their
    play column, ``X[:, i]`` for ``1 <= i < nb`` before :func:`constraints` turns it into the
    deflection ``v - P_i(v)``, is constant there: a threshold above the rows' travel), as a
    mask over the weights ``(X.shape[1] - 1,)``; ``None`` when there are none (or the base is
    not a stop base).

    On those rows such an element's deflection is the spring's column ``v`` (shifted by its
    constant slider), so the spring ``k`` and the elements that never slid are the same
    column, and how the least squares splits the stiffness among them is a tie that
    round-off decides; it matters only where they are predicted, past the travel they were
    fitted on (a recording predicted from a shorter one: 25.6 against 0.04 output units^2 on
    the Maxwell-slip plant's ``slow`` recording, with the stiffness on the element at 139.65
    or on the spring). :func:`solve` pins them at 0 instead, so the spring carries that
    stiffness, as the play frame of the PI base already does (a play that never moves from a
    relaxed state has an empty column, pinned at 0).

    ``plays``: the base's columns on the solved rows without the gains of a slip force by
    direction (``(rows, nb)``; a signed stop base's rows of ``X`` are times a gain that
    changes with the force's sign, so a still element's column is not constant there);
    ``X``'s own by default."""
    if not s.stop or X.shape[0] == 0 or nb < 2:
        return None
    B = (X if plays is None else plays)[:, 1:nb]
    still = np.all(B == B[:1], axis=0)
    if not still.any():
        return None
    out = np.zeros(X.shape[1] - 1, dtype=bool)
    out[1:nb] = still
    return out


def solve(s: Structure, X: np.ndarray, G: np.ndarray, lower: np.ndarray, nb: int,
          fixed: np.ndarray | None = None) -> np.ndarray:
    """The weights of the design ``X`` (output in its last column; ``G`` its Gram matrix,
    added to in place) within ``lower``.

    The fitting's constrained solver, as core.fitting does it: from the augmented Gram
    matrix, or from the triangular factor of [X, y] when that is ill conditioned. Pseudo
    rows: a column without any solved row (the offset or drift of a recording left out,
    e.g. leave-one-recording-out) is pinned at 0, as if never there; then the unbounded
    weights (bias, drift, output map) also get a ridge 1e-9 of the largest column energy,
    bounding a direction the remaining rows leave (nearly) undetermined (before: offsets of
    1e12 with one recording left out). Fits with rows in every column are solved as they
    were (the ridge alone moved a weak drift on top of creep from a 7 % to a 13 % held-out
    gain: such designs are nearly collinear). ``fixed``: weights held at 0, their columns
    left out of the solve (:func:`still_elements`)."""
    if fixed is not None and fixed.any():
        keep = np.flatnonzero(~fixed)
        cols = np.append(keep, lower.size)  # with the output column
        w = np.zeros(lower.size)
        w[keep] = solve(s, X[:, cols], G[np.ix_(cols, cols)], lower[keep],
                        nb - int(fixed[:nb].sum()))
        return w
    ncol = lower.size
    dg = np.diag(G)[:ncol]
    empty = dg == 0
    ridge = 1e-9 * float(dg.max(initial=0.0)) if empty.any() else 0.0
    lam = np.where(empty, 1.0, np.where(np.isfinite(lower), 0.0, ridge))
    pin = (np.sqrt(lam)[:, None] * np.eye(ncol + 1)[:ncol])[lam > 0]
    if s.levels and s.level_smooth > 0:
        # a Preisach base: the density of neighbouring level segments of each play is
        # pulled together (towards a PI), so cells excited by few rows do not overfit
        n_lev = len(s.levels) + 1
        pin = np.vstack((pin, level_penalty(len(s.thresholds) + 1, n_lev, ncol,
                                             s.level_smooth * float(dg[:nb].mean()))))
    if pin.size:
        G += pin.T @ pin
    # (an ill-conditioned Gram matrix only gives the condition number)
    sol = solve_constrained(lower, gram=G, cond_limit=COND_LIMIT)
    if sol.cond > COND_LIMIT:
        sol = solve_constrained(lower, factor=r_factor(np.vstack((X, pin)) if pin.size else X))
    return sol.theta
