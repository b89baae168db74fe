"""The searches over nonlinear parameters read a prefix of a long record (issue 31): enough
training rows, input events and input range to rank the parameters as the whole record
does, the whole record where it has too few, and the report says which part was read."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.generator import truth_pi
from core.datasets import load_dataset
from core.diagnosis import diagnose
from core.diagnosis import screening as sc
from core.diagnosis.data import split_masks
from core.recordings import Recording
from core.stages import Delay


def _sine(n: int, cycles: float, amplitude: np.ndarray | float = 1.0) -> Recording:
    t = np.arange(n) * 1e-4
    u = amplitude * np.sin(2 * np.pi * cycles * np.arange(n) / n)
    return Recording(t, u, u.copy(), "sine")


def _reversals_in(u: np.ndarray, mask: np.ndarray) -> int:
    """Peaks and troughs of a clean sine that fall on training rows (a second count of the
    events, from the sign changes of the slope)."""
    d = np.sign(np.diff(u))
    turns = np.flatnonzero(d[1:] != d[:-1]) + 1
    return int(mask[turns].sum())


def test_records_up_to_the_span_are_read_whole() -> None:
    """The shipped piezo recording and a 100,000-sample record are never cut: their
    diagnoses are unchanged by the prefix."""
    rec = load_dataset("piezo-150V-1Hz")
    assert isinstance(rec, Recording)
    train, _, _ = split_masks([rec])
    assert sc.ranking_span(rec, train[0]) == rec.n_samples
    r = _sine(sc.RANKING_SPAN, 200)
    assert sc.ranking_span(r, split_masks([r])[0][0]) == r.n_samples


def test_a_long_periodic_record_is_read_in_a_prefix_that_holds_what_the_search_needs() -> None:
    """400,000 samples of 100 sine periods: the prefix ends well before the record does and
    holds the training rows, the events and the input range the rule asks for."""
    rec = _sine(400_000, 100)
    (m,), _, _ = split_masks([rec])
    k = sc.ranking_span(rec, m)
    assert sc.RANKING_SPAN <= k < rec.n_samples // 2
    pre = m.copy()
    pre[k:] = False
    assert pre.sum() >= sc.RANKING_TRAIN_ROWS
    assert _reversals_in(rec.u, pre) >= sc.RANKING_EVENTS
    assert np.ptp(rec.u[pre]) >= sc.RANKING_RANGE_SHARE * np.ptp(rec.u[m])


def test_an_input_that_reaches_its_range_late_is_read_until_it_does() -> None:
    """An amplitude that grows over the record: a prefix of the events alone would search
    a loop shape on part of the input's range; the search reads on into the last training
    block, where the input reaches its range."""
    n = 400_000
    rec = _sine(n, 100, amplitude=np.linspace(0.1, 1.0, n))
    (m,), _, _ = split_masks([rec])
    k = sc.ranking_span(rec, m)
    last = int(np.flatnonzero(m)[-1])
    assert k > last - 50_000  # inside the last training block (of 50,000 samples)
    assert np.ptp(rec.u[:k][m[:k]]) >= sc.RANKING_RANGE_SHARE * np.ptp(rec.u[m])


def test_few_events_are_read_whole() -> None:
    """Ten reversals in 400,000 samples: too few events for a prefix."""
    rec = _sine(400_000, 5)
    (m,), _, _ = split_masks([rec])
    assert sc.ranking_span(rec, m) == rec.n_samples


def test_a_fold_without_early_training_rows_reads_further() -> None:
    """A cross-fitting fold that leaves out the first training block: its prefix runs on
    until it holds its own training rows, not the left-out ones."""
    rec = _sine(400_000, 100)
    (m,), _, _ = split_masks([rec])
    fold = m.copy()
    fold[:50_000] = False
    k, k_fold = sc.ranking_span(rec, m), sc.ranking_span(rec, fold)
    assert k_fold > k
    assert fold[:k_fold].sum() >= sc.RANKING_TRAIN_ROWS


@pytest.fixture(scope="module")
def long_delayed() -> Recording:
    """The benchmark's PI behind a 1.5 ms dead time, 60,000 samples of a periodic two-tone
    input (60 periods), 0.2 % noise."""
    rng = np.random.default_rng(11)
    dt = 1e-4
    t = np.arange(60_000) * dt
    u = 5 + 2.5 * np.sin(2 * np.pi * 10 * t) + 2.0 * np.sin(2 * np.pi * 20 * t + 1.0)
    y = (truth_pi() >> Delay(1.5e-3)).simulate(u, dt=dt).y
    return Recording(t, u, y + 0.002 * float(np.ptp(y)) * rng.standard_normal(y.size), "long")


def test_a_diagnosis_read_in_a_prefix_finds_the_delay_and_says_so(long_delayed,
                                                                   monkeypatch) -> None:
    """With the span scaled down to a fifth of this record, the delay is still named and
    recovered within 25 % of the truth, and the split says which part the searches read."""
    monkeypatch.setattr(sc, "RANKING_SPAN", 12_000)
    monkeypatch.setattr(sc, "RANKING_TRAIN_ROWS", 6_000)
    res = diagnose([long_delayed])
    assert "read only the first" in res.split
    (f,) = [e for e in res.effects if e.name == "delay"]
    assert f.parameters["delay_s"] == pytest.approx(1.5e-3, rel=0.25)


def test_a_long_record_scores_a_bounded_spread_of_its_events_on_test_rows() -> None:
    """Rule 14 refits twice per held-out event window: on a long record at most
    MAX_HELD_OUT_EVENTS windows, evenly spread, each with enough test rows (the fits never
    saw them, so they are scored there without refits); with no test rows (an explicit
    training window alone) as many windows, refitted; a record of the span's size holds
    out every window."""
    from core.diagnosis.events import event_windows
    from core.diagnosis.judge import MAX_HELD_OUT_EVENTS, MIN_EVENT_ROWS, held_out_windows

    rec = _sine(400_000, 100)
    (m,), (te,), _ = split_masks([rec])
    every = [(a, b) for a, b in event_windows(rec) if b - a >= MIN_EVENT_ROWS]
    assert len(every) > 4 * MAX_HELD_OUT_EVENTS
    wins, scored = held_out_windows(rec, te)
    assert scored and len(wins) == MAX_HELD_OUT_EVENTS
    assert all(te[a:b].sum() >= MIN_EVENT_ROWS for a, b in wins)
    with_test = [w for w in every if te[w[0]:w[1]].sum() >= MIN_EVENT_ROWS]
    assert wins[0] == with_test[0] and wins[-1] == with_test[-1]
    gaps = np.diff([with_test.index(w) for w in wins])
    assert gaps.max() - gaps.min() <= 1
    refit, scored = held_out_windows(rec, np.zeros(rec.n_samples, dtype=bool))
    assert not scored and len(refit) == MAX_HELD_OUT_EVENTS
    assert refit[0] == every[0] and refit[-1] == every[-1]
    short = _sine(sc.RANKING_SPAN, 100)
    assert held_out_windows(short, split_masks([short])[1][0]) == (
        [(a, b) for a, b in event_windows(short) if b - a >= MIN_EVENT_ROWS], False)


def test_the_base_sensitivity_of_a_long_record_is_fitted_on_its_prefix(long_delayed,
                                                                        monkeypatch) -> None:
    """The alternative bases of the parameter honesty check are fitted on the prefix the
    searches read (their banks and simulations bounded by it), against the final structure
    refitted there; a record within the span keeps its context and fit."""
    from core.diagnosis.context import FitContext
    from core.diagnosis.data import split_masks
    from core.diagnosis.misspecification import _on_prefix
    from core.diagnosis.structure import Structure

    rec = long_delayed
    train, test, _ = split_masks([rec])
    ctx = FitContext([rec], train, test)
    cur = ctx.fit(Structure((0.5, 1.0, 2.0, 3.0), ((),)))
    assert _on_prefix(ctx, cur) == (ctx, cur)
    monkeypatch.setattr(sc, "RANKING_SPAN", 12_000)
    monkeypatch.setattr(sc, "RANKING_TRAIN_ROWS", 6_000)
    sub, ref = _on_prefix(ctx, cur)
    k = sc.ranking_span(rec, train[0])
    assert k < rec.n_samples
    assert sub.records[0].n_samples == k
    np.testing.assert_array_equal(sub.records[0].y, rec.y[:k])
    assert ref.structure == cur.structure and ref.pred[0].size == k
