"""The stop-operator PI (Maxwell-slip): a second implementation, its play-type inverse, JSON."""

from __future__ import annotations

import numpy as np
import pytest

from core.base import model_from_dict
from core.exceptions import NotInvertibleError, ParameterError
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


# --------------------------------------------------------------------- backlash gap in series
def _gap_reference(u: np.ndarray, m: StopPIModel, sub: int = 400) -> np.ndarray:
    """The loose joint stepped by hand on an input refined ``sub`` times: in contact the bank
    follows ``u -/+ b/2`` unless that would turn its force against the contact, which opens
    the joint (no zero search: the force is held where it was); open, it closes on the side
    the input reaches."""
    h = 0.5 * m.gap
    z = np.array(m.state0, float)
    v, side, out = float(np.mean(z)), 0, np.empty(u.size)

    def force(v: float, z: np.ndarray) -> float:
        return m.k * v + float(m.weights @ (v - z))

    prev = u[0]
    for k, target in enumerate(u):
        for x in np.linspace(prev, target, sub + 1)[1:]:
            if side == 0 and abs(x - v) >= h:
                side = 1 if x > v else -1
            if side != 0:
                vt = x - side * h
                zt = np.clip(z, vt - m.thresholds, vt + m.thresholds)
                if force(vt, zt) * side >= 0:
                    v, z = vt, zt
                else:
                    side = 0
        prev = target
        out[k] = force(v, z) if side != 0 else 0.0
    return out


GAP = StopPIModel(0.3, [0.05, 0.1, 0.2], [10.0, 5.0, 2.0], gap=0.1)


def test_a_gap_holds_the_force_at_zero_while_the_input_crosses_it() -> None:
    # from a full plateau (every element slips) the branch comes down to zero force, then the
    # input travels the gap's width with no force at all, wherever the reversal was
    u = 0.5 * np.sin(np.linspace(0, 8 * np.pi, 8001))
    y = GAP(u)
    flat = np.flatnonzero(y == 0.0)
    runs = np.split(flat, np.flatnonzero(np.diff(flat) > 1) + 1)
    travel = [np.ptp(u[run]) for run in runs if run[0] > 0]
    assert len(travel) == 8
    # the crossings of the gap are sampled at most one input step (<= 0.002) off each end
    np.testing.assert_allclose(travel, 0.1, atol=4e-3)
    ref = StopPIModel(0.3, [0.05, 0.1, 0.2], [10.0, 5.0, 2.0])(u)
    assert np.count_nonzero(ref == 0.0) <= 1  # the bank alone passes zero in one sample


def test_the_gap_matches_a_joint_stepped_by_hand() -> None:
    u = 0.4 * turning_points(3, 1500) / 3.0
    m = StopPIModel(0.3, [0.05, 0.1, 0.2], [10.0, 5.0, 2.0], state0=[0.01, -0.02, 0.0],
                    gap=0.08)
    y, ref = m(u), _gap_reference(u, m)
    # the hand-stepped joint opens up to 1/400 of an input step late
    step = float(np.max(np.abs(np.diff(u))))
    assert np.max(np.abs(y - ref)) <= 17.3 * step / 400 * 2 + 1e-9


def test_the_gap_inverse_undoes_the_model_and_crosses_the_gap_in_one_sample() -> None:
    u = 0.4 * turning_points(5, 3000) / 3.0
    y = GAP(u)
    inv = GAP.inverse()
    assert inv.type_name == "stop-pi-gap-inverse"
    u2 = inv(y)
    np.testing.assert_allclose(GAP(u2), y, rtol=0, atol=1e-12)
    # away from zero force the input is recovered; at zero force it sits at a gap's side
    loaded = np.abs(y) > 0
    np.testing.assert_allclose(u2[loaded], u[loaded], atol=1e-12)
    back = inv.inverse()
    assert back.gap == GAP.gap
    np.testing.assert_allclose(back.weights, GAP.weights, rtol=1e-12)


def test_gap_json_chunks_and_bad_values() -> None:
    m = StopPIModel(0.3, [0.05, 0.1], [10.0, -0.2], state0=[0.01, 0.0], gap=0.05)
    assert m.to_dict()["gap"] == 0.05
    assert "gap" not in StopPIModel(0.3, [0.05], [1.0]).to_dict()
    u = 0.3 * turning_points(9, 2000) / 3.0
    np.testing.assert_array_equal(model_from_dict(m.to_dict())(u), m(u))
    inv = m.inverse()
    np.testing.assert_array_equal(model_from_dict(inv.to_dict())(m(u)), inv(m(u)))
    r1 = m.simulate(u[:700])
    r2 = m.simulate(u[700:], state=r1.state)
    np.testing.assert_array_equal(np.concatenate((r1.y, r2.y)), m(u))
    with pytest.raises(ParameterError, match="gap must be >= 0"):
        StopPIModel(0.3, [0.05], [1.0], gap=-0.1)
