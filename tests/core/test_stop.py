"""The stop-operator PI (Maxwell-slip): a second implementation, its play-type inverse, JSON."""

from __future__ import annotations

import numpy as np
import pytest

from core.base import model_from_dict
from core.exceptions import NotInvertibleError
from core.pi import PIModel
from core.stop import StopPIModel
from tests.core.model_zoo import turning_points


def _stop_direct(u: np.ndarray, r: float, s0: float) -> np.ndarray:
    """Paper 001 eq. 4: Xi[k] = min(r, max(-r, u[k] - u[k-1] + Xi[k-1])), from Xi = s0."""
    out = np.empty(u.size)
    prev_u, prev = u[0], s0
    for k, x in enumerate(u):
        prev = min(r, max(-r, x - prev_u + prev))
        prev_u = x
        out[k] = prev
    return out


def test_the_model_is_the_weighted_sum_of_stop_operators() -> None:
    u = turning_points(3, 4000)
    m = StopPIModel(0.3, [0.25, 0.6, 1.2], [1.5, 0.8, 0.4])
    # virgin sliders at 0 with u[0] = 0: each stop starts at 0
    ref = 0.3 * u + sum(w * _stop_direct(u, r, 0.0)
                        for r, w in zip(m.thresholds, m.weights, strict=True))
    np.testing.assert_allclose(m(u), ref, atol=1e-12)
    assert m.friction_plateau == pytest.approx(0.25 * 1.5 + 0.6 * 0.8 + 1.2 * 0.4)


def test_loops_run_clockwise_and_saturate_at_the_plateau() -> None:
    m = StopPIModel(0.0, [0.5], [2.0])
    u = np.concatenate((np.linspace(0, 3, 300), np.linspace(3, -3, 600)))
    y = m(u)
    assert y.max() == pytest.approx(1.0) and y.min() == pytest.approx(-1.0)
    # the output leads: right after the top reversal it falls at once (slope 2)
    assert y[301] < y[299]


def test_the_inverse_is_a_play_type_pi_and_undoes_the_model() -> None:
    m = StopPIModel(0.3, [0.25, 0.6, 1.2], [1.5, 0.8, 0.4], state0=[0.1, -0.2, 0.3])
    inv = m.inverse()
    assert isinstance(inv, PIModel) and (inv.weights > 0).all() and inv.p0 > 0
    y = 2.0 * turning_points(5, 5000)
    np.testing.assert_allclose(m(inv(y)), y, atol=1e-9)
    u = turning_points(6, 5000)
    m0 = StopPIModel(0.3, [0.25, 0.6, 1.2], [1.5, 0.8, 0.4])
    np.testing.assert_allclose(m0.inverse()(m0(u)), u, atol=1e-9)


def test_no_parallel_spring_has_no_inverse_and_says_why() -> None:
    with pytest.raises(NotInvertibleError, match="friction plateau"):
        StopPIModel(0.0, [0.5], [2.0]).inverse()


def test_json_round_trip_and_chunked_simulation() -> None:
    m = StopPIModel(0.3, [0.25, 0.6], [1.5, -0.2], state0=[0.1, -0.2])
    back = model_from_dict(m.to_dict())
    u = turning_points(8, 2000)
    np.testing.assert_array_equal(back(u), m(u))
    r1 = m.simulate(u[:700])
    r2 = m.simulate(u[700:], state=r1.state)
    np.testing.assert_allclose(np.concatenate((r1.y, r2.y)), m(u), atol=1e-12)
