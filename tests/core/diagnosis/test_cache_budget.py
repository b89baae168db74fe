"""The one byte budget of a diagnosis's caches (issue 31): derived from the memory target and
the measured peaks without caches, and obeyed by the banks, their derived arrays and the fit
memo together, the least valuable and least recently used entries out first."""

from __future__ import annotations

import numpy as np
import pytest

from core.diagnosis import cache_budget as cb
from core.diagnosis import context as cx
from core.diagnosis import structure as st
from core.pi import PIModel
from core.recordings import Recording

#: ``hyst diagnose FILE --json`` with no cache beyond the 4 most recent fits (one thread,
#: /usr/bin/time; tilings of the shipped piezo recording, main b9acf70 with its caches
#: switched off): (samples, resident bytes when the diagnosis started, peak bytes)
MEASURED_WITHOUT_CACHES = [(25_000, 209e6, 326e6), (100_000, 224e6, 401e6),
                           (400_000, 251e6, 510e6), (1_000_000, 315e6, 588e6)]


@pytest.mark.parametrize(("n", "resident", "peak"), MEASURED_WITHOUT_CACHES)
def test_the_budget_fits_under_the_target_beside_the_measured_need(n, resident, peak) -> None:
    """What a diagnosis held without caches plus the whole budget, given what was resident
    when it started, stays within issue 31's target (400 MB + 0.3 kB per sample) at every
    measured size."""
    assert peak + cb.cache_budget(n, resident) <= 400e6 + 300.0 * n


def test_the_budget_follows_what_is_resident() -> None:
    """The same recording gets less cache in a process that holds more (another set of
    libraries, a notebook with other data), none once the target is spent, and the shipped
    piezo recording (50,001 samples) keeps some banks in the command line's process (about
    215 MB resident at its start)."""
    n = 50_001
    assert cb.cache_budget(n, 215e6) > 30e6
    assert cb.cache_budget(n, 230e6) == pytest.approx(cb.cache_budget(n, 215e6) - 15e6)
    assert cb.cache_budget(n, 2e9) == 0.0
    now = cb.resident_bytes()
    assert now is not None and 10e6 < now < 1e12  # this process's own, read on Linux
    assert cb.cache_budget(n) <= cb.cache_budget(n, now - 1e6)


def _arrays(n: int, k: int = 1) -> list[np.ndarray]:
    return [np.zeros(n // 8) for _ in range(k)]


def test_least_valuable_then_least_recently_used_go_first() -> None:
    """Derived arrays go before banks, banks before fits; within a rank the least recently
    used (a hit refreshes an entry); an entry larger than the limit is not stored."""
    b = cb.CacheBudget(4000)
    banks: dict = {}
    derived: dict = {}
    fits: dict = {}
    b.put(fits, "f", _arrays(1000), 1000, cb.FIT)
    b.put(banks, "b1", _arrays(1000), 1000, cb.BANK)
    b.put(derived, "p1", _arrays(500), 500, cb.DERIVED)
    b.put(derived, "p2", _arrays(500), 500, cb.DERIVED)
    b.put(banks, "b2", _arrays(1000), 1000, cb.BANK)
    assert b.used == 4000
    assert b.get(derived, "p1") is not None  # p1 now more recent than p2
    assert b.put(banks, "b3", _arrays(500), 500, cb.BANK)
    assert list(derived) == ["p1"] and list(banks) == ["b1", "b2", "b3"]  # p2 went first
    assert b.put(banks, "b4", _arrays(1000), 1000, cb.BANK)
    assert not derived and list(banks) == ["b2", "b3", "b4"]  # then p1, then the oldest bank
    assert list(fits) == ["f"] and b.used == 3500
    assert not b.put(banks, "huge", _arrays(4001), 4001, cb.BANK)
    assert "huge" not in banks and b.used == 3500  # nothing pushed out for it
    assert b.put(banks, "b5", _arrays(10), 10, cb.BANK, count=3)
    assert list(banks) == ["b3", "b4", "b5"]  # the count bound of a store holds too


def test_make_room_before_forming_and_the_floor_of_a_store() -> None:
    """Room is made before an array is formed (the caches and the new array within the
    limit); the most recent entries of a store with a floor are kept whatever the limit,
    their bytes counted."""
    b = cb.CacheBudget(3000)
    fits: dict = {}
    banks: dict = {}
    b.floor[id(fits)] = 2
    for k in range(3):
        b.put(fits, k, _arrays(1000), 1000, cb.FIT)
    assert list(fits) == [0, 1, 2]
    assert b.make_room(1000) and list(fits) == [1, 2]  # room for 1000 bytes made
    assert not b.make_room(1500) and list(fits) == [1, 2]  # the floor holds
    assert not b.put(banks, "b", _arrays(1500), 1500, cb.BANK) and not banks
    assert b.put(fits, 3, _arrays(2500), 2500, cb.FIT)  # over the limit, within the floor
    assert list(fits) == [2, 3] and b.used == 3500
    b.put(fits, 4, _arrays(100), 100, cb.FIT)
    assert list(fits) == [3, 4] and b.used == 2600


def _record(n: int = 20001, dt: float = 1e-3) -> tuple[Recording, list[np.ndarray]]:
    t = np.arange(n) * dt
    u = 40.0 * np.sin(2 * np.pi * 0.7 * t) * (1 - np.exp(-t / 3))
    y = PIModel(0.5, [4.0, 12.0], [0.4, 0.2])(u)
    return Recording(t, u, y + 0.002 * y**2, "sine"), [t <= 14.0]


def _held(ctx: cx.FitContext) -> float:
    """Bytes of the arrays the caches and the fit memo of ``ctx`` hold, counted from the
    stores themselves (not the budget's account): banks, level segments, projections, the
    memoised fits' predictions and formed PI-stage outputs."""
    c = ctx.cache
    total = sum(B.nbytes for B in c.d.values()) + sum(L.nbytes for L in c.lv.values())
    total += sum(e[1].nbytes for e in c.p.values())
    total += sum(B.nbytes for key, B in c.bw.items() if key[1])
    for _, _, f in ctx._fits.values():
        total += sum(p.nbytes for p in f.pred)
        x = f.x_pi._x if isinstance(f.x_pi, st.PIStageOutputs) else f.x_pi
        total += sum(np.asarray(v).nbytes for v in (x or ()))
    return float(total)


def test_the_tests_run_the_budget_of_the_command_line() -> None:
    """In the test session a diagnosis's caches get what a lean ``hyst diagnose`` process
    gets (tests/conftest.py: its resident bytes at the start), not what this pytest process
    would get (its imports alone hold more than the target: no cache at all, a slower path
    than the users')."""
    from tests.conftest import CLI_RESIDENT_BYTES

    rec, train = _record()
    ctx = cx.FitContext([rec], train, [~train[0]])
    assert ctx.cache.budget.limit == cb.cache_budget(rec.n_samples, CLI_RESIDENT_BYTES)
    assert ctx.cache.budget.limit > 30e6


@pytest.mark.parametrize("limit", [2.5e6, 6e6])
def test_a_diagnosis_context_holds_no_more_than_its_budget(monkeypatch, limit) -> None:
    """Fits of PI and Preisach structures, with and without a virtual history, their PI-stage
    outputs and ranking solves through one fitting context: after every step the arrays its
    caches and fit memo hold stay within the budget (a bank is 0.8 MB, its level segments
    2.4 MB, a fit 0.3 MB), and the budget is used (entries kept, some pushed out)."""
    monkeypatch.setattr(cx, "cache_budget", lambda n: limit)
    rec, train = _record()
    ctx = cx.FitContext([rec], train, [~train[0]])
    assert ctx.cache.budget.limit == limit
    r = (2.0, 6.0, 12.0, 20.0)
    peak = 0.0
    kept = set()
    for tau in (0.002, 0.004, 0.006):
        for hist in ((), (25.0, -30.0)):
            for levels in ((), (-10.0, 15.0)):
                s = st.Structure(r, (hist,), dynamics=("lag", tau))
                if levels:
                    s = s.with_(levels=levels, level_smooth=0.1)
                f = ctx.fit(s)
                ctx.rss(s.with_term("asymmetry", True), f)
                _ = f.x_pi[0]  # the PI-stage outputs formed
                held = _held(ctx)
                assert held <= limit
                assert ctx.cache.budget.used >= held  # the account is never short
                peak = max(peak, held)
                kept |= {("d", k) for k in ctx.cache.d} | {("lv", k) for k in ctx.cache.lv}
    assert peak > 0.5 * limit  # the budget is filled, not ignored
    assert len(kept) > len(ctx.cache.d) + len(ctx.cache.lv)  # and entries were pushed out
