"""Non-negative least squares in :mod:`core.fitting.gram`, checked against scipy's
bounded-variable least squares (a second implementation) and the optimality conditions."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize

from core.fitting import gram


def _problem(seed: int, rows: int, cols: int) -> tuple[np.ndarray, np.ndarray]:
    """A correlated, moderately ill-conditioned problem whose minimum has many zero weights."""
    rng = np.random.default_rng(seed)
    base = rng.standard_normal((rows, cols))
    R = np.cumsum(base, axis=1) / np.sqrt(np.arange(1, cols + 1))
    truth = np.where(rng.random(cols) < 0.5, 0.0, rng.random(cols))
    z = R @ truth + 0.3 * rng.standard_normal(rows)
    return R, z


def _bvls(R: np.ndarray, z: np.ndarray) -> np.ndarray:
    return np.maximum(scipy.optimize.lsq_linear(R, z, bounds=(0.0, np.inf), method="bvls",
                                                tol=1e-14).x, 0.0)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("start", ["zeros", "ones", "shuffled"])
def test_active_set_from_any_start_reaches_the_minimum(seed, start):
    R, z = _problem(seed, 120, 40)
    best = _bvls(R, z)
    x0 = {"zeros": np.zeros(40), "ones": np.ones(40),
          "shuffled": np.random.default_rng(seed).permutation(best)}[start]
    tol = gram.NNLS_KKT_TOL * np.linalg.norm(R) * np.linalg.norm(z)
    x = gram._active_set_from(R, z, x0, tol, max_steps=200)
    assert x is not None and np.all(x >= 0)
    assert gram._kkt_holds(R, z, x, tol)
    assert np.linalg.norm(R @ x - z) == pytest.approx(np.linalg.norm(R @ best - z), rel=1e-12)
    assert np.count_nonzero(x == 0) >= 5  # the bounds are active: not a free solve


def test_active_set_from_gives_up_within_its_steps():
    R, z = _problem(4, 120, 40)
    tol = gram.NNLS_KKT_TOL * np.linalg.norm(R) * np.linalg.norm(z)
    assert gram._active_set_from(R, z, np.zeros(40), tol, max_steps=1) is None


def test_nnls_checked_keeps_the_minimum_when_scipy_stops_short(monkeypatch):
    """scipy's ``nnls`` stopping at a point that is not the minimum (1.16/1.17 can) is caught
    by the optimality check and continued to the minimum; with the continuation broken, the
    bounded-variable solve still answers."""
    R, z = _problem(5, 150, 60)
    best = np.linalg.norm(R @ _bvls(R, z) - z)
    real_nnls = scipy.optimize.nnls

    def short(M, b, **kw):
        x, _ = real_nnls(M, b, **kw)
        x = x.copy()
        x[np.argmax(x)] = 0.0  # a wrong support, reported as an answer
        return x, float(np.linalg.norm(M @ x - b))

    monkeypatch.setattr(scipy.optimize, "nnls", short)
    x, rnorm = gram.nnls_checked(R, z, 1000)
    assert rnorm == pytest.approx(best, rel=1e-12)
    assert rnorm == pytest.approx(np.linalg.norm(R @ x - z), rel=1e-15)
    monkeypatch.setattr(gram, "_active_set_from", lambda *a, **k: None)
    x, rnorm = gram.nnls_checked(R, z, 1000)
    assert rnorm == pytest.approx(best, rel=1e-9)


def test_a_gram_matrix_beyond_the_condition_limit_only_gives_its_condition_number(
        monkeypatch):
    """With ``cond_limit`` below the condition number the bounded solve is not made (the
    caller solves from a triangular factor instead); within it, the solution is the one
    without a limit."""
    rng = np.random.default_rng(5)
    A = rng.standard_normal((200, 4))
    A[:, 3] = A[:, 2] + 1e-7 * rng.standard_normal(200)  # nearly collinear: cond ~ 1e13
    y = A @ np.array([1.0, 0.5, 0.2, 0.3]) + 0.01 * rng.standard_normal(200)
    Ay = np.column_stack((A, y))
    lower = np.array([-np.inf, 0.0, 0.0, 0.0])
    full = gram.solve_constrained(lower, gram=Ay.T @ Ay)
    assert full.cond > 1e10
    calls = []
    real = gram.nnls_checked
    monkeypatch.setattr(gram, "nnls_checked", lambda *a: calls.append(1) or real(*a))
    cut = gram.solve_constrained(lower, gram=Ay.T @ Ay, cond_limit=1e10)
    assert cut.cond == full.cond and np.isnan(cut.theta).all() and np.isnan(cut.sse)
    assert calls == []
    kept = gram.solve_constrained(lower, gram=Ay.T @ Ay, cond_limit=10 * full.cond)
    np.testing.assert_array_equal(kept.theta, full.theta)
    assert kept.sse == full.sse and calls == [1]
