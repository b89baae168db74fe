"""A misfit that depends on the input's state and history, against one that depends on time
(acceptance rule 17, core/diagnosis/history.py; issue 30, round 4)."""

from __future__ import annotations

import numpy as np
import pytest

from core.diagnosis import diagnose
from core.diagnosis.acceptance import beyond_history_ok
from core.diagnosis.history import history_basis, says_time
from core.diagnosis.stats import HeldOut


def _residual_of_span(F: np.ndarray, e: np.ndarray) -> float:
    """RMS of ``e`` left outside the span of the columns ``F``, relative to RMS(e)."""
    c = np.linalg.lstsq(F, e, rcond=None)[0]
    return float(np.sqrt(np.mean((e - F @ c) ** 2)) / np.sqrt(np.mean(e**2)))


def test_equal_state_and_history_give_equal_rows() -> None:
    # 0 -> 100 -> 20 -> 100 -> 20 -> 100 -> 20 (80 samples a leg): the second and third
    # descents share value, direction and last two reversals; the first (after 0) does not
    nodes = [0.0, 100.0, 20.0, 100.0, 20.0, 100.0, 20.0]
    u = np.concatenate([np.linspace(a, b, 81)[:-1] for a, b in zip(nodes[:-1], nodes[1:],
                                                                   strict=True)] + [[20.0]])
    F = history_basis(u, 0.0, 100.0)
    first_down, second_down = 80 + 40, 3 * 80 + 40  # 60 on the way down
    assert u[first_down] == pytest.approx(u[second_down])
    third_down = 5 * 80 + 40
    np.testing.assert_allclose(F[second_down], F[third_down])
    assert not np.allclose(F[first_down], F[second_down])  # another earlier reversal (0)
    # the first loading from rest has columns of its own
    virgin, later = 40, 2 * 80 + 30  # 50 on the first loading and on a later ascent
    assert u[virgin] == pytest.approx(u[later])
    assert not np.any(F[virgin] * F[later])
    # rows asked for alone are the same rows
    rows = np.array([3, 120, 300])
    np.testing.assert_array_equal(history_basis(u, 0.0, 100.0, rows), F[rows])


def test_time_trend_under_a_repeated_cycle_is_outside_the_span_amplitude_misfit_inside() -> None:
    fs = 200.0
    t = np.arange(int(8 * fs)) / fs
    periodic = 50.0 - 50.0 * np.cos(2 * np.pi * t)
    decaying = 50.0 - 50.0 * np.exp(-t / 3.0) * np.cos(2 * np.pi * t)
    drift = t / t[-1]
    # a linear drift under an identical repeated cycle is not a function of state and history
    assert _residual_of_span(history_basis(periodic, 0.0, 100.0), drift - drift.mean()) > 0.5
    # under a decaying sine, a misfit that grows with the last reversal's distance from mid
    # range (the loop's amplitude) is, although it also changes with time
    down = np.r_[0.0, np.diff(decaying)] < 0
    amp = np.maximum.accumulate(np.abs(decaying - 50.0)[::-1])[::-1] / 50.0
    misfit = amp**2 * np.sin(np.pi * decaying / 100.0) * np.where(down, 1.0, -1.0)
    assert _residual_of_span(history_basis(decaying, 0.0, 100.0), misfit) < 0.2
    # and a drift under it is largely inside the span too: the time name is not testable
    assert _residual_of_span(history_basis(decaying, 0.0, 100.0), drift - drift.mean()) < 0.2


def test_the_rule_applies_to_time_and_rate_names_only() -> None:
    assert {n for n in ("drift", "creep", "rate", "initial-memory") if says_time(n)} == {
        "drift", "creep", "rate", "initial-memory"}
    assert not any(says_time(n) for n in ("delay", "lag", "resonance", "asymmetry", "offset"))
    assert beyond_history_ok(HeldOut(1.0, 0.8, 0.2, 4.0, 0.5, 20))
    assert not beyond_history_ok(HeldOut(1.0, 0.97, 0.03, 9.0, 1e-6, 20))  # too small
    assert not beyond_history_ok(HeldOut(1.0, 0.8, 0.2, 1.0, 0.2, 20))  # not significant


@pytest.fixture(scope="module")
def steel_with_a_mode() -> list:
    """A Menegotto-Pinto steel (non-Masing: the PI family cannot follow its loops) with a
    200 Hz mode after it, the benchmark's four recordings (development seed 500)."""
    from benchmarks.diagnosis.families import make_family

    return make_family("menegotto-pinto", "resonance", "large", seed=500).records


@pytest.mark.slow
def test_a_virgin_curve_the_base_misses_is_not_named_initial_memory(steel_with_a_mode,
                                                                   monkeypatch) -> None:
    """Measured on the development set before rule 17: `resonance` then `initial-memory`
    (held-out MSE -26 %, DM z 5.0) on this plant, which starts every recording from rest.
    Its four first loadings share one virgin curve the base misses; nothing differs between
    them that a memory before the record would explain. The Menegotto-Pinto base now
    follows that curve (it is chosen here and no later round tries the memory), so the rule
    is checked on the base chosen before it existed, the stop bank, which misses it."""
    import core.diagnosis.basechoice as basechoice

    effects = ["resonance", "initial-memory"]
    assert diagnose(steel_with_a_mode, effects=effects).base_choice.kind == "menegotto-pinto"
    monkeypatch.setattr(basechoice, "_menegotto_pinto_base", lambda *a, **k: None)
    res = diagnose(steel_with_a_mode, effects=effects)
    assert res.base_choice.kind == "stop-pi"
    assert [e.name for e in res.effects] == ["resonance"]
    row = next(r for r in res.rounds if r.effect == "initial-memory" and r.round == 2)
    assert not row.passes
    assert any("state and history alone" in w for w in row.reasons or ())
    # without the rule the same diagnosis names it: the rule is what refuses it
    import core.diagnosis.judge as judge

    monkeypatch.setattr(judge, "history_refusal", lambda *a, **k: None)
    assert [e.name for e in diagnose(steel_with_a_mode, effects=effects).effects] == [
        "resonance", "initial-memory"]
