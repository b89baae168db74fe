"""Creep judged inside the holds after input changes (core.diagnosis.effects.creep
.hold_signature): each block of a hold (as long as the creep bank's fastest lag) compared
with the block at half its time into the hold, as the change of the residual's mean; the
noise floor of such a change is 2 sigma^2 / block; along a hold a rate-independent base's
misfit does not change, so a misfit of the base alone cannot pass as creep there, and the
creep weights are fitted on the same changes."""

from __future__ import annotations

import numpy as np
import pytest

from core.diagnosis import diagnose
from core.diagnosis.acceptance import floor_mse
from core.diagnosis.context import FitContext, block_means
from core.diagnosis.data import split_masks
from core.diagnosis.effects.creep import HOLD_BLOCK_SHARE, bank_taus, hold_signature
from core.diagnosis.registry import EFFECTS
from core.recordings import Recording

FS = 1000.0  # Hz


def _staircase(levels: tuple[float, ...] = (0, 40, 80, 120, 60, 20, 100, 0),
               hold_s: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """Input steps ramped over 5 ms, each level held ``hold_s``."""
    parts, prev = [], 0.0
    for lv in levels:
        parts.append(np.linspace(prev, lv, 6)[1:])
        parts.append(np.full(int(hold_s * FS) - 5, float(lv)))
        prev = lv
    u = np.concatenate(parts)
    return np.arange(u.size) / FS, u


def _context(rec: Recording) -> FitContext:
    tr, te, _ = split_masks([rec], None, None)
    return FitContext([rec], tr, te)


def test_each_block_of_a_hold_is_compared_with_the_block_at_half_its_time() -> None:
    t, u = _staircase()
    rec = Recording(t, u, u.copy(), "staircase")
    ctx = _context(rec)
    sig = hold_signature(ctx)
    assert sig is not None and sig.previous is not None and sig.beyond_history
    assert EFFECTS["creep"].signature(ctx).words == sig.words  # how creep is judged
    # the bank's fastest lag (10 ms at 1 kHz): ten rows
    assert sig.block == (max(1, round(HOLD_BLOCK_SHARE * min(bank_taus(ctx)) * FS)),) == (10,)
    assert sig.noise_factor == pytest.approx(0.2)
    m, prev = sig.masks[0], sig.previous[0]
    holds = ctx.coords[0].holds
    assert len(holds) == 7  # every level after the first change
    for h0, n, _ in holds:
        rows = np.flatnonzero(m[h0 : h0 + n]) + h0
        assert rows.size == n // 10 - 1  # every block but the first
        k = (rows - h0 + 1) // 10 - 1  # the block's number in the hold
        np.testing.assert_array_equal(rows - h0, 10 * k + 9)  # its last row
        np.testing.assert_array_equal(prev[rows] - h0, 10 * (k // 2) + 9)
        assert np.all(np.diff(u[h0 : h0 + n]) == 0)  # inside the hold: the input rests
    # nothing outside the holds
    inside = np.zeros(u.size, dtype=bool)
    for h0, n, _ in holds:
        inside[h0 : h0 + n] = True
    assert not np.any(m & ~inside)


def test_blocks_are_as_long_as_the_fastest_lag_and_their_means_are_compared() -> None:
    fs = 10_000.0
    _, u = _staircase(hold_s=6.0)  # 6000 rows a level: 0.6 s holds at 10 kHz
    t = np.arange(u.size) / fs
    rng = np.random.default_rng(4)
    y = u + rng.standard_normal(u.size)
    rec = Recording(t, u, y, "fast")
    ctx = _context(rec)
    sig = hold_signature(ctx)
    assert sig is not None
    assert sig.block == (100,) and sig.noise_factor == pytest.approx(0.02)  # 10 ms: 100 rows
    m, prev = sig.masks[0], sig.previous[0]
    rows = np.flatnonzero(m)
    # each compared row ends a block that lies inside its hold, as does its reference
    for h0, n, _ in ctx.coords[0].holds:
        r = rows[(rows >= h0) & (rows < h0 + n)]
        assert np.all((r - h0 + 1) % 100 == 0) and np.all(prev[r] - h0 >= 99)
    # the compared values: the means of the residual over the two blocks, subtracted
    e = y - u
    got = ctx.signature_res(_Pred(u), sig)[0]
    w = m & ctx.test[0]
    ref = np.array([e[i - 99 : i + 1].mean() - e[prev[i] - 99 : prev[i] + 1].mean()
                    for i in np.flatnonzero(w)])
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    # white noise of unit variance: their mean square is the floor 2 / block
    assert got.size > 150
    assert np.mean(got**2) == pytest.approx(floor_mse(1.0, sig.noise_factor), rel=0.25)


def test_each_recording_has_blocks_of_its_own_rate() -> None:
    """A staircase at 1 kHz beside one at 10 kHz: the bank's fastest lag is 10 ms in both,
    ten rows of the first and a hundred of the second; the floor of the pooled changes is
    the mean of their own, 2 / 10 and 2 / 100, over the compared rows."""
    t, u = _staircase()
    slow = Recording(t, u, u.copy(), "1 kHz")
    _, uf = _staircase(hold_s=6.0)
    fast = Recording(np.arange(uf.size) / 10_000.0, uf, uf.copy(), "10 kHz")
    tr, te, _ = split_masks([slow, fast], None, None)
    sig = hold_signature(FitContext([slow, fast], tr, te))
    assert sig is not None and sig.block == (10, 100)
    n = [int(m.sum()) for m in sig.masks]
    assert sig.noise_factor == pytest.approx((0.2 * n[0] + 0.02 * n[1]) / sum(n))


class _Pred:
    """A stand-in fit whose prediction is ``p`` (only ``pred`` is read)."""

    def __init__(self, p: np.ndarray) -> None:
        self.pred = [p]


def test_block_means_are_the_means_over_the_rows_ending_at_each() -> None:
    e = np.arange(10.0) ** 2
    got = block_means(e, 3)
    assert got[0] == 0.0 and got[1] == 0.5  # over the rows there are
    np.testing.assert_allclose(got[2:], [(e[i - 2] + e[i - 1] + e[i]) / 3 for i in range(2, 10)])
    assert block_means(e, 1) is e


def test_no_hold_or_explicit_windows_judge_creep_elsewhere() -> None:
    t = np.arange(0, 6, 1 / FS)
    u = 60 + 50 * np.sin(2 * np.pi * t)
    ctx = _context(Recording(t, u, u.copy(), "sine"))
    assert hold_signature(ctx) is None
    t, u = _staircase()
    ctx = _context(Recording(t, u, u.copy(), "staircase"))
    ctx.strict = True
    assert hold_signature(ctx) is None


def _plant(u: np.ndarray, creep: float) -> np.ndarray:
    """A rate-independent loop the PI base misses (a cubic on top of a play) plus a
    logarithmic creep of ``creep`` of each step per decade (lags 0.05, 0.5 and 5 s)."""
    from core.pi import PIModel
    from core.stages import Creep

    base = PIModel(0.3, [10.0, 30.0], [0.4, 0.3])(u) + 2e-5 * (u - 60.0) ** 3
    taus = np.array([0.05, 0.5, 5.0])
    return Creep(taus, np.full(3, creep))(base, dt=1 / FS) if creep else base


def test_creep_judged_in_the_holds_is_named_and_a_base_misfit_is_not_creep() -> None:
    """Two staircases and a sine through a plant whose loops the PI base misses (a cubic
    bend, 4 % of range), with and without a creep of 2 % of a step per decade. Inside the
    holds the base's misfit does not change: with creep, creep is named from the changes
    there; without, nothing is named, although the misfit changes with time along the
    sine and the staircases."""
    rng = np.random.default_rng(11)
    recs = []
    for creep in (0.02, 0.0):
        out = []
        for k, levels in enumerate(((0, 40, 80, 120, 60, 20, 100, 0),
                                    (0, 110, 30, 90, 10, 70, 0))):
            t, u = _staircase(levels)
            y = _plant(u, creep) + 0.05 * rng.standard_normal(u.size)
            out.append(Recording(t, u, y, f"staircase {k}"))
        t = np.arange(0, 4, 1 / FS)
        u = 60 - 60 * np.cos(2 * np.pi * t)
        out.append(Recording(t, u, _plant(u, creep) + 0.05 * rng.standard_normal(u.size),
                             "sine"))
        recs.append(out)
    res = diagnose(recs[0], effects=["creep", "drift"], base="pi", n_operators=10,
                   auto_resolution=False)
    assert [e.name for e in res.effects] == ["creep"]
    assert "inside the" in res.effects[0].evidence and "hold" in res.effects[0].evidence
    null = diagnose(recs[1], effects=["creep", "drift"], base="pi", n_operators=10,
                    auto_resolution=False)
    assert null.effects == []
