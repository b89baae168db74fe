"""The rate condition of :func:`core.diagnosis.periodic.same_history`'s pairing (issue 30):
two branches of one input history are grouped when they move at the same rate over their
common stretch (from the reversal to the shorter one's end), not only when their whole
lengths agree.

Before, a growing cyclic protocol at one input rate (a triangle whose amplitude steps up
every two cycles) had its rising branch from each negative peak in two groups: the second
visit goes on to the next, larger peak, so it is longer, and it was never compared with the
first although both run from the same history at the same rate. A drift in such a
recording went untested."""

from __future__ import annotations

import numpy as np

from core.diagnosis.periodic import HISTORY_TOL, _history_pairs, _memory_keys, same_history
from core.fitting.thresholds import reversal_indices
from core.pi import PIModel
from core.recordings import Recording

FS = 1000.0  # Hz
#: A piezo-like plant: 8 plays, exponentially decaying weights (rate-independent).
PLANT = PIModel(0.0, [10.0 * i for i in range(1, 9)], [0.12 * np.exp(-0.2 * i)
                                                       for i in range(1, 9)])


def _legs(targets: list[float], rates: list[float]) -> tuple[np.ndarray, list[int]]:
    """From 0 V, straight legs to ``targets`` (V) at ``rates`` (V/s) each, sampled at
    :data:`FS`: the input, shape (n,), and the sample of each leg's end."""
    parts, ends, prev, n = [np.zeros(1)], [], 0.0, 1
    for tg, r in zip(targets, rates, strict=True):
        m = int(round(abs(tg - prev) / r * FS))
        parts.append(np.linspace(prev, tg, m + 1)[1:])
        n += m
        ends.append(n - 1)
        prev = tg
    return np.concatenate(parts), ends


def _growing(amps: tuple[float, ...], second_rate: float = 200.0
             ) -> tuple[np.ndarray, list[int]]:
    """Two triangle cycles at each amplitude of ``amps``, then back to 0 V, at 200 V/s,
    except the rise from the second negative peak of each amplitude (towards the next
    amplitude) at ``second_rate``; the input and the sample of each leg's end."""
    targets, rates = [], []
    for a in amps:
        targets += [a, -a, a, -a]
        rates += [200.0, 200.0, 200.0, 200.0]
    targets.append(0.0)
    rates.append(200.0)
    # the legs leaving the second negative peak of each amplitude: 5, 9, ... (1-based 4k+5)
    for i in range(4, len(targets), 4):
        rates[i] = second_rate
    return _legs(targets, rates)


def _rise_pairs(u: np.ndarray, ends: list[int], amps: tuple[float, ...]
                ) -> list[tuple[int, int, float]]:
    """Per amplitude ``a`` but the last: the samples of the two negative peaks ``-a`` (the
    first rise from them ends at ``+a``, the second goes on to the next amplitude)."""
    return [(ends[4 * i + 1], ends[4 * i + 3], a) for i, a in enumerate(amps[:-1])]


def test_a_growing_triangle_at_one_rate_compares_each_rise_with_the_one_before() -> None:
    """Both rises from ``-a`` leave the same history (the extrema ``+a, -a``, the reversal
    ``+a`` before) at the same rate: the second, up to ``+a``, is compared with the first
    row for row at the same input value and the same time since the reversal (by
    construction the row one cycle of ``4 a / rate`` earlier), and the rate-independent
    plant gives the same output on both. Fails before: the second rise, longer, started a
    group of its own."""
    amps = (40.0, 80.0, 120.0)
    u, ends = _growing(amps)
    t = np.arange(u.size) / FS
    sig = same_history([Recording(t=t, u=u, y=PLANT(u), name="growing triangle")])
    assert sig is not None and sig.previous is not None
    m, prev = sig.masks[0], sig.previous[0]
    tol = HISTORY_TOL * float(np.ptp(u))
    y = PLANT(u)
    for first, second, a in _rise_pairs(u, ends, amps):
        rows = np.arange(second + 1, second + 1 + int(round(2 * a / 200.0 * FS)))
        assert np.allclose(u[rows], u[rows - (second - first)])  # the same input
        inside = rows[u[rows] <= a - tol]
        assert m[inside].all(), a
        np.testing.assert_array_equal(prev[inside], inside - (second - first))
        # beyond the first rise's peak there is nothing to compare with
        beyond = np.arange(second + 1, u.size)[u[second + 1:] > a + tol]
        beyond = beyond[beyond < second + int(round(3 * a / 200.0 * FS))]
        assert beyond.size > 0 and not m[beyond].any(), a
        assert np.max(np.abs(y[inside] - y[prev[inside]])) < 1e-9 * np.ptp(y)


def _pairs(u: np.ndarray) -> tuple[list[tuple[int, int]], list[int]]:
    """``_history_pairs`` of ``u`` as :func:`same_history` forms them, and the branches'
    reversal samples."""
    span = float(np.ptp(u))
    rv = reversal_indices(u, 0.1 * span)
    bounds = [*rv.tolist(), u.size - 1]
    keys = _memory_keys(u, rv, HISTORY_TOL * span)
    branches = [u[bounds[k]:bounds[k + 1] + 1] for k in range(len(keys))]
    return _history_pairs(keys, branches, HISTORY_TOL * span), bounds


def test_the_same_history_at_another_rate_is_not_paired() -> None:
    """The same growing triangle, but each second rise from ``-a`` at twice the rate: the
    same history, its common stretch with the first rise travelled in half the samples, so
    the two are not paired and none of its rows is compared with a row of the first."""
    amps = (40.0, 80.0, 120.0)
    u, ends = _growing(amps, second_rate=400.0)
    pairs, bounds = _pairs(u)
    rises = _rise_pairs(u, ends, amps)
    for first, second, _ in rises:
        j, k = bounds.index(first), bounds.index(second)
        assert (j, k) not in pairs
    t = np.arange(u.size) / FS
    sig = same_history([Recording(t=t, u=u, y=PLANT(u), name="two rates")])
    if sig is not None:
        assert sig.previous is not None
        for first, second, a in rises:
            rows = np.arange(second + 1, second + 1 + int(round(2 * a / 400.0 * FS)))
            hit = sig.masks[0][rows]
            assert not np.any((sig.previous[0][rows][hit] > first)
                              & (sig.previous[0][rows][hit] <= first + 2 * a / 200.0 * FS))
