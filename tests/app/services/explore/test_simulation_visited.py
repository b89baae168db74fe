"""The visited states of a digitized trace (the views beyond three digits)."""

from __future__ import annotations

import numpy as np

from app.services.explore.config import Config
from app.services.explore.simulation import compute, state_text, visited_path


def test_visited_path_by_hand() -> None:
    rows = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [1, 0, 0], [0, 0, 0], [1, 0, 0]])
    states, up, down, first = visited_path(rows)
    assert states.tolist() == [[0, 0, 0], [1, 0, 0], [1, 1, 0]]
    assert up.tolist() == [[0, 1], [1, 2]] and down.tolist() == [[1, 0], [2, 1]]
    assert first.tolist() == [0, 1, 2]
    assert [state_text(s) for s in states] == ["000", "001", "011"]  # b_n ... b_1


def test_example1_visits_few_of_its_128_states() -> None:
    d = compute(Config(), views={"digitized"}).digitized
    states, up, down, first = visited_path(d.trace.digits)
    assert d.model.n == 7
    # every distinct row once (np.unique is a second way to count them)
    assert len(states) == len(np.unique(d.trace.digits.astype(int), axis=0)) < 2 ** 7
    # each move changes digits in one direction only: set (rising) or cleared (falling)
    for a, b in up:
        assert np.all(states[b] >= states[a])
    for a, b in down:
        assert np.all(states[b] <= states[a])
    assert (d.trace.digits[first] == states).all()
