"""The play-bank cache of the structure fits (core.diagnosis.bankcache) without a budget: a
search over the output dynamics forms its bank and reduced product once, to the same numbers
as forming them at every trial."""

from __future__ import annotations

import numpy as np

from core.diagnosis import bankcache as bc
from core.diagnosis import structure as st
from core.diagnosis.bankcache import BankCache
from core.pi import PIModel
from core.recordings import Recording


def _noisy_record(n: int = 6000, dt: float = 1e-3) -> tuple[Recording, list[np.ndarray]]:
    """An input that reverses at almost every sample (the bank, not the input, is multiplied)."""
    rng = np.random.default_rng(3)
    t = np.arange(n) * dt
    u = 30.0 * np.sin(2 * np.pi * 0.9 * t) + rng.normal(0.0, 2.0, n)
    y = PIModel(0.4, [3.0, 9.0], [0.3, 0.2])(u)
    return Recording(t, u, y + 0.01 * rng.normal(size=n), "noisy"), [t <= 4.5]


def test_a_search_over_the_dynamics_forms_its_bank_once_to_the_same_numbers(monkeypatch) -> None:
    """Ranking solves of one bank with output lags of several time constants, with no byte
    budget: the bank's plays run at the first trial only, and every training RSS equals that
    of a fresh cache, which forms the bank and its product for that trial alone."""
    rec, train = _noisy_record()
    r = (1.0, 4.0, 8.0, 14.0, 20.0)
    calls = []
    real = bc.play_bank
    monkeypatch.setattr(bc, "play_bank", lambda *a: calls.append(a[0].size) or real(*a))
    shared = BankCache(0.0)
    taus = (0.002, 0.005, 0.011, 0.003)
    got = [
        st.fit_structure(
            st.Structure(r, ((),), dynamics=("lag", tau)), [rec], train, shared, rss_only=True
        )
        for tau in taus
    ]
    assert len(calls) == 1  # the bank of the first trial, then its product is read again
    assert not shared.d and not shared.p  # the budget keeps nothing
    want = [
        st.fit_structure(
            st.Structure(r, ((),), dynamics=("lag", tau)),
            [rec],
            train,
            BankCache(0.0),
            rss_only=True,
        )
        for tau in taus
    ]
    assert got == want
    assert len(calls) == 1 + len(taus)


def test_a_product_is_read_again_only_for_the_same_start_basis_and_rows() -> None:
    """What ``kept_product`` returns is the product ``projected`` formed for the same first
    row, basis and rows; another start, basis or row count is formed again (``None``)."""
    rng = np.random.default_rng(0)
    B = rng.normal(size=(500, 6))
    V = rng.normal(size=(6, 3))
    cache = BankCache(0.0)
    key = (0, "basis", 500)
    P = cache.projected(B, V, key, start=40)
    np.testing.assert_array_equal(P, B[40:] @ V)
    again = cache.kept_product(V, key, 500, 40, False, False)
    assert again is not None and np.array_equal(again, P)
    assert cache.kept_product(V, key, 500, 0, False, False) is None
    assert cache.kept_product(V, key, 500, 41, False, False) is None
    assert cache.kept_product(V.copy(), key, 500, 40, False, False) is None
    assert cache.kept_product(V, key, 499, 40, False, False) is None
    assert cache.kept_product(V, key, 500, 40, True, False) is None
    assert not cache.p
