"""Acceptance rule 16 (issue 30): with one recording at one excitation rate, an output
dynamics stage is named only for what a rate-independent loop-shape misfit of the base
cannot explain (:func:`core.diagnosis.lookalikes.beyond_loop_shape`)."""

from __future__ import annotations

import numpy as np

from core.boucwen import BoucWenModel
from core.diagnosis import diagnose, judge
from core.diagnosis import lookalikes as lk
from core.diagnosis.acceptance import RULE, beyond_loop_shape_ok
from core.diagnosis.lookalikes import LOOP_SHAPE_KNOTS, loop_shape_basis
from core.diagnosis.stats import HeldOut
from core.recordings import Recording

FS = 2000.0


def test_the_loop_shape_basis_does_not_see_time() -> None:
    """The columns depend on the input values only: a hold repeats its row (nothing can
    follow a transient at a constant input), and the same cycle run at another rate gives
    the same rows at the same phases."""
    t = np.arange(0, 2.0, 1 / FS)
    u = 75.0 - 75.0 * np.cos(2 * np.pi * t)
    held = np.concatenate([u[:1500], np.full(400, u[1499]), u[1500:]])
    B, Bh = loop_shape_basis(u), loop_shape_basis(held)
    assert B.shape == (u.size, 6 * LOOP_SHAPE_KNOTS)
    np.testing.assert_array_equal(Bh[1500:1900], np.repeat(Bh[1499:1500], 400, axis=0))
    np.testing.assert_array_equal(Bh[1900:], B[1500:])
    slow = loop_shape_basis(75.0 - 75.0 * np.cos(np.pi * np.arange(0, 4.0, 1 / FS)))
    np.testing.assert_allclose(slow[::2], B, atol=1e-12)
    # each row: the hats on the input sum to 1 in the block of its direction of motion
    rising = np.gradient(u) > 0
    k = LOOP_SHAPE_KNOTS
    np.testing.assert_allclose(B[rising, :k].sum(axis=1), 1.0)
    np.testing.assert_allclose(B[~rising & (np.abs(np.gradient(u)) > 1e-3), k : 2 * k]
                               .sum(axis=1), 1.0)
    assert not loop_shape_basis(np.zeros(50)).any()


def test_a_long_recording_removes_the_same_loop_shape_block_by_block(monkeypatch) -> None:
    """Issue 31: the loop-shape part of a long recording's residual is solved on row blocks
    (no more than a block of its columns formed); with blocks of 997 rows it equals the one
    solve on all the columns, which are rank deficient here (a sine reverses at two values
    only, so the last reversal's square is a constant)."""
    rng = np.random.default_rng(5)
    t = np.arange(0, 12.0, 1 / FS)
    u = 60.0 - 50.0 * np.cos(2 * np.pi * 1.3 * t)
    e = 0.3 * np.sin(u / 9.0) + 0.05 * rng.standard_normal(t.size)
    train = (np.arange(t.size) // 3000) % 2 == 0
    whole = lk._without_loop_shape(u, e, train, ~train)
    monkeypatch.setattr(lk, "LOOP_SHAPE_BLOCK", 997)
    blocks = lk._without_loop_shape(u, e, train, ~train)
    np.testing.assert_allclose(blocks, whole, rtol=0, atol=1e-8 * float(np.abs(e).max()))
    F = loop_shape_basis(u)[train]
    assert np.linalg.matrix_rank(F) < F.shape[1]
    assert np.std(whole) < 0.5 * np.std(e[~train])  # the loop shape is really removed


def test_a_lag_on_one_sine_is_a_function_of_the_loop_position() -> None:
    """Why the rule exists: at one rate a lag's residual -tau dy/dt is a function of where
    the input is on the loop, which the basis reproduces (an analytic identity for a
    periodic input; not exactly: the hats are piecewise linear)."""
    t = np.arange(0, 3.0, 1 / FS)
    u = 75.0 - 75.0 * np.cos(2 * np.pi * t)
    e = -0.004 * np.gradient(np.sin(u / 40.0) * 10.0 + 0.3 * u, 1 / FS)
    B = loop_shape_basis(u)
    fit = B @ np.linalg.lstsq(B, e, rcond=None)[0]
    assert np.var(e - fit) < 0.02 * np.var(e)


def test_rule_16_needs_a_significant_gain_beyond_the_loop_shape() -> None:
    # measured: the Bouc-Wen slow sine alone (development set) and the shipped piezo
    assert not beyond_loop_shape_ok(HeldOut(1.0, 0.943, 0.057, 1.17, 0.033, 40))
    assert beyond_loop_shape_ok(HeldOut(1.0, 0.81, 0.19, 4.4, 6e-5, 40))
    assert not beyond_loop_shape_ok(HeldOut(1.0, 0.97, 0.03, 9.0, 1e-9, 40))  # too small
    assert not beyond_loop_shape_ok(HeldOut(1.0, 1.1, -0.1, -0.7, 1e-6, 40))
    assert RULE.min_gain == 0.05 and RULE.min_z == 3.0


def _bouc_wen_slow_sine() -> Recording:
    t = np.arange(0, 3.0, 1 / FS)
    u = 75.0 - 75.0 * np.cos(2 * np.pi * t)
    y = BoucWenModel.from_classical(1.0, [-0.4], [0.03], [0.01], [1.0])(u, dt=1 / FS)
    y = y + 0.001 * float(np.ptp(y)) * np.random.default_rng(5).standard_normal(y.size)
    return Recording(t=t, u=u, y=y, name="slow")


def test_a_rate_independent_plant_on_one_sine_gets_no_dynamic_name(monkeypatch) -> None:
    """A Bouc-Wen plant (rate-independent, nothing hidden), one 1 Hz sine: the base's
    loop-shape misfit made `lag` pass every other rule; rule 16 leaves it suggestive."""
    rec = _bouc_wen_slow_sine()
    res = diagnose(rec, effects=["delay", "lag", "resonance"])
    assert res.effects == []
    row = next(r for r in res.rounds if r.effect == "lag")
    assert "loop-shape" in row.reasons[0] and "several rates" in row.reasons[0]
    assert "lag" in [s["effect"] for s in res.suggestive]
    monkeypatch.setattr(judge, "beyond_loop_shape_ok", lambda h: True)  # without rule 16
    assert [e.name for e in diagnose(rec, effects=["delay", "lag", "resonance"]).effects] == [
        "lag"]
