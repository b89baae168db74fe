"""The Menegotto-Pinto bank: against the exact stop operators, the benchmark's independent
stress-strain law and Masing's rule; its inverse, state and JSON."""

from __future__ import annotations

import re

import numpy as np
import pytest

from benchmarks.diagnosis.families import MenegottoPinto
from core.base import model_from_dict
from core.exceptions import NotInvertibleError, ParameterError
from core.nonmasing import MenegottoPintoInverse, MenegottoPintoModel
from core.stop import StopPIModel
from tests.core.model_zoo import turning_points

R = [0.25, 0.6, 1.2]
W = [1.5, 0.8, 0.4]


def _bank(k: float, w: list[float], r0: float, c1: float, c2: float = 0.15,
          r: list[float] = R) -> MenegottoPintoModel:
    n = len(r)
    return MenegottoPintoModel(k, r, w, [r0] * n, [c1] * n, [c2] * n)


def test_a_sharp_knee_without_rounding_is_the_stop_bank() -> None:
    u = turning_points(3, 4000)
    m = _bank(0.3, W, 1e6, 0.0)
    ref = StopPIModel(0.3, R, W)(u)
    np.testing.assert_allclose(m(u), ref, rtol=0, atol=1e-6 * np.ptp(ref))


def test_one_element_is_the_benchmark_steel_law() -> None:
    """``k = b``, ``w = 1 - b``, ``r = eps_y``: the stress over E0 of the independent
    implementation, on a bipolar strain history of growing amplitude with partial
    reversals (inner loops)."""
    mp = MenegottoPinto()
    ey = mp.fy / mp.e0
    t = np.linspace(0.0, 1.0, 6000)
    eps = 0.01 * t * np.sin(2 * np.pi * 6 * t) + 0.0007 * np.sin(2 * np.pi * 41 * t)
    sig = mp.stress(eps)
    m = MenegottoPintoModel(mp.b, [ey], [1.0 - mp.b], [mp.r0], [mp.cr1], [mp.cr2])
    np.testing.assert_allclose(m(eps) * mp.e0, sig, rtol=0, atol=1e-9 * np.ptp(sig))


def _first_loading_and_branch(c1: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One element (r = 1, R0 = 20): first loading 0 -> 3, then down to -3; the branch's
    drop from the reversal and twice the first loading at half the travel (Masing)."""
    m = _bank(0.0, [1.0], 20.0, c1, r=[1.0])
    up = np.linspace(0.0, 3.0, 301)
    down = np.linspace(3.0, -3.0, 601)[1:]
    y = m(np.concatenate((up, down)))
    travel = 3.0 - down
    first = _bank(0.0, [1.0], 20.0, c1, r=[1.0])(travel / 2.0)
    return travel, y[300] - y[301:], 2.0 * first


def test_without_rounding_branches_follow_masing_and_with_it_they_do_not() -> None:
    _, drop, masing = _first_loading_and_branch(0.0)
    np.testing.assert_allclose(drop, masing, rtol=0, atol=1e-8)
    _, drop, masing = _first_loading_and_branch(0.925)
    assert np.abs(drop - masing).max() > 0.05  # 5 % of the 2 r rise: a rounder knee
    assert np.all(drop <= masing + 1e-12)  # rounder: below the doubled first loading


def test_loops_run_clockwise_with_positive_moduli_and_counter_clockwise_with_negative() -> None:
    u = np.concatenate((np.linspace(0, 2, 200), np.linspace(2, -2, 400),
                        np.linspace(-2, 2, 400)))
    for w, sign in ((W, 1.0), ([-x / 4 for x in W], -1.0)):
        y = _bank(1.0, w, 10.0, 0.5)(u)
        # signed area of the last closed loop (-2 -> 2 -> -2): positive for clockwise
        # (the rising branch above the falling one)
        area = np.trapezoid(y[600:], u[600:]) - np.trapezoid(y[200:600][::-1],
                                                            u[200:600][::-1])
        assert sign * area > 0


@pytest.mark.parametrize("k, w", [(0.3, W), (0.05, W), (1.0, [-0.3, -0.2, -0.1])])
def test_inverse_round_trip(k: float, w: list[float]) -> None:
    u = turning_points(5, 5000)
    m = MenegottoPintoModel(k, R, w, [20.0, 8.0, 3.0], [0.9, 0.5, 0.2], [0.15, 0.5, 1.0])
    y = m(u)
    inv = m.inverse()
    assert isinstance(inv, MenegottoPintoInverse)
    np.testing.assert_allclose(inv(y), u, rtol=0, atol=1e-9 * np.ptp(u))
    # the inverse keeps the forward model's state: a desired output in two halves
    first = inv.simulate(y[:2000])
    rest = inv.simulate(y[2000:], state=first.state)
    np.testing.assert_allclose(np.concatenate((first.y, rest.y)), u, rtol=0,
                               atol=1e-9 * np.ptp(u))
    assert inv.inverse() is m


def test_not_invertible_without_a_positive_slope() -> None:
    with pytest.raises(NotInvertibleError, match=r"k = 0 must be > 0.*plateau"):
        _bank(0.0, W, 20.0, 0.5).inverse()
    with pytest.raises(NotInvertibleError, match=r"smallest branch slope.*-0.2"):
        _bank(0.4, [-0.3, -0.2, -0.1], 20.0, 0.5).inverse()


def test_state_continues_a_record() -> None:
    u = turning_points(7, 3000)
    m = _bank(0.2, W, 12.0, 0.7)
    a = m.simulate(u[:1234])
    b = m.simulate(u[1234:], state=a.state)
    np.testing.assert_array_equal(np.concatenate((a.y, b.y)), m(u))
    s = m.element_outputs(u)
    np.testing.assert_allclose(0.2 * u + s @ np.asarray(W), m(u), atol=1e-12)
    assert np.all(np.abs(s) < np.asarray(R))


def test_json_round_trip() -> None:
    u = turning_points(9, 2000)
    m = MenegottoPintoModel(0.3, R, W, [20.0, 8.0, 3.0], [0.9, 0.5, 0.0], [0.15, 0.5, 1.0])
    back = model_from_dict(m.to_dict())
    np.testing.assert_array_equal(back(u), m(u))
    inv = model_from_dict(m.inverse().to_dict())
    np.testing.assert_array_equal(inv(m(u)), m.inverse()(m(u)))


@pytest.mark.parametrize("kw, msg", [
    ({"curvature_drop": [1.0, 0.0, 0.0]}, "curvature_drop.*< 1"),
    ({"curvature": [0.0, 1.0, 1.0]}, "curvature"),
    ({"curvature_scale": [1.0, -1.0, 1.0]}, "curvature_scale"),
    ({"thresholds": [0.5, -1.0, 1.0]}, "thresholds"),
])
def test_bad_parameters_are_refused(kw: dict, msg: str) -> None:
    args = {"k": 0.3, "thresholds": R, "weights": W, "curvature": [20.0] * 3,
            "curvature_drop": [0.5] * 3, "curvature_scale": [0.15] * 3} | kw
    with pytest.raises(ParameterError, match=msg):
        MenegottoPintoModel(**args)


def test_a_history_sets_the_starting_memory() -> None:
    """``history`` is the record's virtual past: the model with it is the model without it
    continued from the state the history leaves."""
    hist = np.array([0.0, 2.5, -1.0, 0.7])
    u = turning_points(11, 1500)
    plain = _bank(0.2, W, 12.0, 0.7)
    m = MenegottoPintoModel(0.2, R, W, [12.0] * 3, [0.7] * 3, [0.15] * 3, history=hist)
    after = plain.simulate(hist).state
    np.testing.assert_array_equal(m(u), plain.simulate(u, state=after).y)
    np.testing.assert_array_equal(model_from_dict(m.to_dict())(u), m(u))
    np.testing.assert_allclose(m.inverse()(m(u)), u, rtol=0, atol=1e-9 * np.ptp(u))


def test_a_state_with_a_curvature_of_zero_or_an_output_past_the_yield_is_refused() -> None:
    """A state supplied by hand is checked before the kernel runs it: a curvature of 0 (the
    kernel divides by it) or an element's output beyond its yield level is refused with the
    entry named, not raised from inside the compiled loop."""
    m = MenegottoPintoModel(0.1, [1.0, 2.0], [0.5, 0.5], [20.0, 20.0], [0.9, 0.9],
                            [0.15, 0.15])
    good = m.default_state()
    for entry, value, words in ((3 + 5 + 4, 0.0, "curvature (entry 12)"),
                                (3, 1.5, "output (entry 3)")):
        st = np.array(good, dtype=float)
        st[entry] = value
        with pytest.raises(ParameterError, match=re.escape(words)):
            m.simulate(np.linspace(0.0, 1.0, 5), state=st)
    m.simulate(np.linspace(0.0, 1.0, 5), state=good)
