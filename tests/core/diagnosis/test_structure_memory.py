"""What the structure fits keep alive (issue 31): caches bounded in bytes, fits that hold no
play bank, and PI-stage outputs streamed over row blocks equal to the whole bank's product."""

from __future__ import annotations

import numpy as np
import pytest

from core.diagnosis import structure as st
from core.diagnosis.bankcache import BankCache
from core.operators import play_bank
from core.pi import PIModel
from core.recordings import Recording


def _record(n: int = 20001, dt: float = 1e-3) -> tuple[Recording, list[np.ndarray]]:
    t = np.arange(n) * dt
    u = 40.0 * np.sin(2 * np.pi * 0.7 * t) * (1 - np.exp(-t / 3))
    y = PIModel(0.5, [4.0, 12.0], [0.4, 0.2])(u)
    return Recording(t, u, y + 0.002 * y**2, "sine"), [t <= 14.0]


@pytest.mark.parametrize("history", [(), ((25.0, -30.0),)])
def test_streamed_stage_output_equals_the_whole_bank_product(monkeypatch, history) -> None:
    """With no bank cached (budget 0) and blocks of 3,000 rows, a fit's PI-stage output is
    formed block by block; it equals the whole bank (plays from the virtual history) times
    the weights, and the fit keeps no bank alive."""
    monkeypatch.setattr(st, "STREAM_ROWS", 3000)
    rec, train = _record()
    r = (2.0, 6.0, 12.0, 20.0)
    s = st.Structure(r, history or ((),), dynamics=("lag", 0.004))
    cache = BankCache(0.0)
    f = st.fit_structure(s, [rec], train, cache)
    assert not cache.d  # nothing stored beyond the budget
    assert isinstance(f.x_pi, st.PIStageOutputs) and f.x_pi._x is None
    w = np.concatenate(([f.p0], f.weights))
    z0 = play_bank(np.asarray(history[0]), np.asarray(r))[1] if history else np.zeros(len(r))
    B = play_bank(rec.u, np.r_[0.0, r], np.r_[0.0, z0])[0]
    want = B @ w
    scale = float(np.ptp(want))
    np.testing.assert_allclose(f.x_pi[0], want, rtol=0, atol=1e-12 * scale)


def test_fits_memoised_by_a_context_are_bounded_in_bytes(monkeypatch) -> None:
    """The fit memo of a diagnosis drops its least recently used fits past the cache budget
    (each fit holds its predictions, N per recording), keeping at least the most recent few."""
    from core.diagnosis import context as cx

    monkeypatch.setattr(cx, "cache_budget", lambda n: 1.0)
    rec, train = _record(4001)
    ctx = cx.FitContext([rec], train, [~train[0]])
    r = (2.0, 6.0, 12.0)
    fits = [ctx.fit(st.Structure(r, ((),), dynamics=("lag", tau)))
            for tau in (0.002, 0.004, 0.006, 0.008, 0.010, 0.012)]
    assert len(ctx._fits) == cx.FIT_MEMO_MIN
    # the most recent are kept (a hit returns the same object), the oldest were dropped
    assert ctx.fit(st.Structure(r, ((),), dynamics=("lag", 0.012))) is fits[-1]
    assert ctx.fit(st.Structure(r, ((),), dynamics=("lag", 0.002))) is not fits[0]


@pytest.mark.parametrize("dyn", [(), ("lag", 0.004), ("delay", 0.0123),
                                 ("resonance", 40.0, 0.3), ("lag", 0.003, "delay", 0.002)])
@pytest.mark.parametrize("history", [(), ((25.0, -30.0),)])
def test_full_fits_with_streamed_banks_equal_those_of_whole_banks(monkeypatch, dyn,
                                                                  history) -> None:
    """A bank too large to keep (budget 0 here) is streamed through the output dynamics in
    blocks of 3,000 rows, each group of solved rows filtered from where its start transient
    has died out: the same weights, predictions and training RSS as the fit on the whole
    bank, to round-off; bilinear regressors (asymmetry) refreshed from streamed outputs too,
    and a Preisach base's level segments split block by block."""
    rec, train = _record()
    r = (2.0, 6.0, 12.0, 20.0)
    base = st.Structure(r, history or ((),), dynamics=dyn)
    for s in (base, base.with_term("asymmetry", True),
              base.with_(levels=(-10.0, 15.0), level_smooth=0.1)):  # a Preisach base
        want = st.fit_structure(s, [rec], train, BankCache())
        with monkeypatch.context() as m:
            m.setattr(st, "STREAM_ROWS", 3000)
            cache = BankCache(0.0)
            assert st._streams(cache, s, [rec])
            got = st.fit_structure(s, [rec], train, cache)
            assert not cache.d
        scale = float(np.ptp(rec.y))
        np.testing.assert_allclose(got.weights, want.weights, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(got.pred[0], want.pred[0], rtol=0, atol=1e-9 * scale)
        assert got.train_rss == pytest.approx(want.train_rss, rel=1e-7)


@pytest.mark.parametrize("dyn", [("lag", 0.004), ("resonance", 40.0, 0.3)])
def test_streamed_rows_across_held_out_gaps_equal_the_whole_bank(monkeypatch, dyn) -> None:
    """Training rows in blocks of 4,000 with held-out gaps of 4,000 (longer than the 3,000-row
    stream blocks): the plays' state is carried over each gap without keeping its rows, and
    the fit is the whole bank's to round-off."""
    rec, _ = _record()
    train = [(np.arange(rec.n_samples) // 4000) % 2 == 0]
    s = st.Structure((2.0, 6.0, 12.0, 20.0), ((),), dynamics=dyn)
    want = st.fit_structure(s, [rec], train, BankCache())
    monkeypatch.setattr(st, "STREAM_ROWS", 3000)
    got = st.fit_structure(s, [rec], train, BankCache(0.0))
    np.testing.assert_allclose(got.weights, want.weights, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(got.pred[0], want.pred[0], rtol=0,
                               atol=1e-9 * float(np.ptp(rec.y)))
    assert got.train_rss == pytest.approx(want.train_rss, rel=1e-7)


@pytest.mark.parametrize("history", [(), ((25.0, -30.0),)])
def test_bank_rows_are_the_rows_of_the_whole_bank(history) -> None:
    """Sampled rows of a bank that is not kept (larger than the cache budget) are
    formed without the bank and equal its rows exactly; nothing is stored. With a budget the
    bank is formed and kept, as :meth:`BankCache.bank` does."""
    rec, _ = _record(5001)
    r = np.array([2.0, 6.0, 12.0, 20.0])
    hist = history[0] if history else ()
    z0 = play_bank(np.asarray(hist), r)[1] if history else np.zeros(r.size)
    want = play_bank(rec.u, np.r_[0.0, r], np.r_[0.0, z0])[0]
    idx = np.arange(3, 5001, 7)
    none = BankCache(0.0)
    got = none.bank_rows(0, rec, r, hist, None, (), idx)
    np.testing.assert_array_equal(got, want[idx])
    assert not none.d
    full = BankCache()
    np.testing.assert_array_equal(full.bank_rows(0, rec, r, hist, None, (), idx), want[idx])
    assert full.has_bank(0, r, hist)


def test_a_diagnosis_cache_has_the_budget_of_its_samples(monkeypatch) -> None:
    """A diagnosis's cache gets the budget of its samples; sub-contexts share its account;
    with no budget (a long record) no bank or projection is kept and the fit memo holds its
    most recent fits."""
    from core.diagnosis import cache_budget as cb
    from core.diagnosis import context as cx

    rec, train = _record(4001)
    # the engine's own budget (the session's is fixed at the command line's, tests/conftest.py)
    monkeypatch.setattr(cx, "cache_budget", cb.cache_budget)
    monkeypatch.setattr(cb, "resident_bytes", lambda: 220e6)  # the command line's start
    assert cx.FitContext([rec], train, [~train[0]]).cache.budget.limit == cb.cache_budget(4001)
    assert cb.cache_budget(4001) > 0
    monkeypatch.setattr(cx, "cache_budget", lambda n: 0.0)
    ctx = cx.FitContext([rec], train, [~train[0]])
    assert ctx.cache.budget.limit == 0.0
    sub = cx.FitContext([rec], [train[0] & (rec.t < 2.0)], train, parent=ctx)
    assert sub.cache.budget is ctx.cache.budget and sub.cache.d is ctx.cache.d
    r = (2.0, 6.0, 12.0)
    fits = [ctx.fit(st.Structure(r, ((),), dynamics=("lag", tau)))
            for tau in (0.002, 0.004, 0.006, 0.008, 0.010, 0.012)]
    assert not ctx.cache.d and not ctx.cache.p  # no bank or projection kept
    assert len(ctx._fits) == cx.FIT_MEMO_MIN and ctx.fit(fits[-1].structure) is fits[-1]


@pytest.mark.parametrize("free_weights", [False, True])
def test_bilinear_refresh_on_the_solved_rows_equals_the_refresh_from_the_bank(
        monkeypatch, free_weights) -> None:
    """Without output dynamics the asymmetry's regressors are refreshed from the solve's own
    columns on the solved rows; declared a filter (``sample_spacing``), the same term is
    refreshed from the PI-stage output on every sample, the path before issue 31's round 6.
    Both give the same fit to round-off."""
    from dataclasses import replace

    from core.diagnosis import registry

    rec, train = _record()
    s = st.Structure((2.0, 6.0, 12.0, 20.0), ((),), free_weights=free_weights).with_term(
        "asymmetry", True)
    rows_fit = st.fit_structure(s, [rec], train, BankCache())
    assert isinstance(rows_fit, st.Fit)
    as_filter = [(n, replace(t, sample_spacing=True) if n == "asymmetry" else t, o)
                 for n, t, o in registry.static_terms()]
    monkeypatch.setattr(st, "static_terms", lambda: as_filter)
    bank_fit = st.fit_structure(s, [rec], train, BankCache())
    assert isinstance(bank_fit, st.Fit)
    scale = float(np.ptp(rec.y))
    assert np.max(np.abs(rows_fit.pred[0] - bank_fit.pred[0])) <= 1e-9 * scale
    a, b = rows_fit.terms["asymmetry"].a, bank_fit.terms["asymmetry"].a
    np.testing.assert_allclose(a, b, rtol=1e-8, atol=1e-12)
