"""The shortcuts of the structure fits' hot paths against the plain computations they replace:
the reduced play-bank products formed along the input, and output dynamics started where
their start transient has died out."""

from __future__ import annotations

import numpy as np
import pytest

from core.diagnosis import bankcache, rowkernels, solver
from core.diagnosis import structure as st
from core.diagnosis.shapes import shape_thresholds
from core.operators import play_bank
from core.pi import PIModel
from core.recordings import Recording


def _sine(n: int = 30001, dt: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(n) * dt
    # growing loops with a hold (repeated input) in the middle
    u = 40.0 * np.sin(2 * np.pi * 0.7 * t) * (1 - np.exp(-t / 3))
    u[12000:12500] = u[12000]
    return t, u


@pytest.mark.parametrize("start", [0, 9000])
def test_play_bank_rows_times_a_basis_equal_the_product(start: int) -> None:
    """Rows of ``B @ V`` formed along the input (stuck and moving plays) equal the product of
    the play bank, from any start row and a virtual initial state."""
    rng = np.random.default_rng(3)
    _, u = _sine()
    r = np.r_[0.0, np.linspace(1.0, 35.0, 30)]
    B = play_bank(u, r, rng.uniform(-10, 10, r.size) * (r > 0))[0]
    V = rng.standard_normal((r.size, 7))
    rows = np.arange(start, u.size, 3)
    got = rowkernels.bank_rows_times(B, V, r, rows)
    assert got is not None
    want = (B @ V)[rows]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


def test_a_noisy_input_falls_back_to_the_product() -> None:
    """An input that turns at nearly every sample (measurement noise) is left to the
    product (``None``), and the projection cache then forms it as before."""
    rng = np.random.default_rng(4)
    _, u = _sine()
    u = u + rng.normal(0.0, 0.5, u.size)
    r = np.r_[0.0, np.linspace(1.0, 35.0, 30)]
    B = play_bank(u, r)[0]
    V = rng.standard_normal((r.size, 5))
    assert rowkernels.bank_rows_times(B, V, r, np.arange(u.size)) is None
    P = bankcache.BankCache().projected(B, V, "k", w=u, start=100, r=r)
    np.testing.assert_allclose(P, (B @ V)[100:], rtol=0, atol=1e-12 * np.abs(P).max())


@pytest.mark.parametrize("dyn", [("lag", 0.004), ("resonance", 60.0, 0.3), ("delay", 0.0123)])
def test_dynamics_started_late_give_the_rows_of_dynamics_from_the_first_sample(dyn) -> None:
    """Rows after :func:`_filter_start` equal those of the dynamics run from sample 0 (to
    round-off), and the start is well inside the record (the shortcut does something)."""
    _, u = _sine()
    x = np.column_stack((u, np.sin(u / 7.0)))
    rows = np.arange(20000, 30001, 2)
    s0 = st._filter_start(dyn, 1e-3, int(rows[0]))
    assert 10000 < s0 < rows[0]
    want = st._dyn_rows(x, dyn, 1e-3, rows)
    got = st._dyn_rows(x[s0:], dyn, 1e-3, rows - s0)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


def test_dynamics_that_do_not_forget_start_at_the_first_sample() -> None:
    """A lightly damped slow mode remembers its start state for longer than the record
    before the first row: no shortcut."""
    assert st._filter_start(("resonance", 2.0, 0.01), 1e-3, 20000) == 0


@pytest.mark.parametrize("dyn", [(), ("lag", 0.004)])
def test_ranking_and_full_fits_equal_those_without_the_shortcuts(monkeypatch, dyn) -> None:
    """The ranking RSS (reduced basis) and a full fit with the shortcuts equal those with the
    plain products of the stored bank and dynamics run from sample 0 (a history and a loop
    shape included: the ranking's bank is not stored, its plays run along the input)."""
    t, u = _sine()
    y = PIModel(0.5, [4.0, 12.0], [0.4, 0.2])(u)
    rec = Recording(t, u, y + 0.001 * y**2, "sine")
    train = [(t >= 14.0) & (t <= 26.0)]
    shape = (("tanh", 0.02, 0.1),)
    r = tuple(float(v) for v in shape_thresholds(shape, [rec], train, 8))
    s = st.Structure(r, ((30.0, -10.0),), dynamics=dyn, shape=shape)
    got_rss = st.fit_structure(s, [rec], train, bankcache.BankCache(), [0.8 * u], iterations=1,
                               rss_only=True)
    got = st.fit_structure(s, [rec], train, bankcache.BankCache())
    monkeypatch.setattr(st, "bank_rows_times", lambda B, V, r, rows: None)
    monkeypatch.setattr(bankcache, "bank_rows_times", lambda B, V, r, rows: None)
    monkeypatch.setattr(st, "_sampled_banks", lambda *a: None)
    monkeypatch.setattr(st, "_filter_start", lambda dyn, dt, first: 0)
    want_rss = st.fit_structure(s, [rec], train, bankcache.BankCache(), [0.8 * u], iterations=1,
                                rss_only=True)
    want = st.fit_structure(s, [rec], train, bankcache.BankCache())
    assert got_rss == pytest.approx(want_rss, rel=1e-9)
    assert got.train_rss == pytest.approx(want.train_rss, rel=1e-9)
    np.testing.assert_allclose(got.pred[0], want.pred[0], rtol=0, atol=1e-9 * np.ptp(y))


def test_lookalike_split_equals_the_full_regressions() -> None:
    """The reversible/hysteretic split and g1, g2 (regressions of the residual on two columns
    with the play bank partialled out) equal, by the Frisch-Waugh-Lovell theorem, the last
    two coefficients of the full regressions on the bank and those columns."""
    from core.diagnosis.context import FitContext
    from core.diagnosis.lookalikes import lookalike_evidence

    t, u = _sine(12001)
    y = PIModel(0.5, [4.0, 12.0], [0.4, 0.2])(u)
    rng = np.random.default_rng(5)
    rec = Recording(t, u, y + 0.3 * np.gradient(y, t) * 1e-2 + 0.01 * rng.standard_normal(
        u.size), "sine")
    train = [t <= 9.0]
    ctx = FitContext([rec], train, [~train[0]])
    r = tuple(float(v) for v in shape_thresholds((), [rec], train, 8))
    cur = ctx.fit(st.Structure(r, ((),)))
    got = lookalike_evidence(ctx, cur)
    m = train[0]
    dx = np.gradient(cur.x_pi[0], rec.dt)
    vrev = cur.p0 * np.gradient(u, rec.dt)
    J = np.column_stack((ctx.cache.bank(0, rec, np.asarray(r), (), None), np.ones(u.size)))[m]
    e = (rec.y - cur.pred[0])[m]
    c = np.linalg.lstsq(np.column_stack((J, vrev[m], (dx - vrev)[m])), e, rcond=None)[0][-2:]
    g = np.linalg.lstsq(np.column_stack((J, dx[m], np.gradient(dx, rec.dt)[m])), e,
                        rcond=None)[0][-2:]
    assert [got.a_rev_s, got.a_hys_s] == pytest.approx(c, rel=1e-6)
    assert [got.g1_s, got.g2_s2] == pytest.approx(g, rel=1e-6)


def test_stages_in_series_start_from_the_sum_of_their_warm_ups() -> None:
    """A lag then a mode (a ``dynamics`` tuple holding two stages) starts no later than each
    stage alone would need, and its rows equal those of the series run from sample 0."""
    _, u = _sine()
    x = u[:, None].copy()
    rows = np.arange(20000, 30001, 2)
    lag, mode = ("lag", 0.004), ("resonance", 60.0, 0.3)
    s0 = st._filter_start(lag + mode, 1e-3, int(rows[0]))
    assert s0 < min(st._filter_start(lag, 1e-3, 20000), st._filter_start(mode, 1e-3, 20000))
    every = np.arange(30001)
    want = st._dyn_rows(st._dyn_rows(x, lag, 1e-3, every), mode, 1e-3, rows)
    tail = every[: every.size - s0]
    got = st._dyn_rows(st._dyn_rows(x[s0:], lag, 1e-3, tail), mode, 1e-3, rows - s0)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


def test_gram_on_a_miss_and_on_a_hit_equals_the_product() -> None:
    """``solver.gram`` forms ``X.T @ X`` in one product on a miss and from the memoised PI-stage
    block plus the other columns' products on a hit: both equal the plain product (to
    round-off) and are exactly symmetric; a hit for another owner is a miss."""
    rng = np.random.default_rng(6)
    X = rng.standard_normal((5000, 30)) * rng.uniform(0.1, 50.0, 30)
    want = X.T @ X
    cache = bankcache.BankCache()
    owner = object()
    miss = solver.gram(X, 26, cache, "k", owner)
    assert len(cache.g) == 1
    X[:, 26:] = rng.standard_normal((5000, 4))  # other regressors on the same PI block
    want_hit = X.T @ X
    hit = solver.gram(X, 26, cache, "k", owner)
    for got, ref in ((miss, want), (hit, want_hit)):
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-13 * np.abs(ref).max())
        assert np.array_equal(got, got.T)
    X[:, :26] *= 2.0  # a new owner: the block is formed anew
    np.testing.assert_allclose(solver.gram(X, 26, cache, "k", object()), X.T @ X, rtol=0,
                               atol=1e-13 * np.abs(X.T @ X).max())


@pytest.mark.parametrize("shape", [(3000, 40), (40, 60)])
def test_r_factor_equals_numpys_qr(shape) -> None:
    """The QR fallback's factor from one Fortran copy equals ``np.linalg.qr(mode="r")`` (the
    same LAPACK routine) for tall and wide matrices, badly scaled columns included."""
    from core.fitting.gram import r_factor

    rng = np.random.default_rng(7)
    A = rng.standard_normal(shape) * np.geomspace(1e-4, 1e4, shape[1])
    want = np.linalg.qr(A, mode="r")
    got = r_factor(A)
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * np.abs(want).max())
    assert np.array_equal(got, np.triu(got))
