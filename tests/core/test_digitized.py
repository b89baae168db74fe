"""Digitized PI and dead-zone representation (paper 000 sections 2.1-2.4).

Paper 000 prints no numeric tables, so the 2- and 3-operator reference values below are
derived by hand from eq. 6-10 with the shifted indices corrected (shared/notes/seed-notes.md):
Δx_k = 2 (r_k - r_(k-1)) for k < n, Δx_n = 2 (u_A - r_(n-1)), grad_k = p0 + p_1 + ... + p_(k-1),
Δy_k = grad_k Δx_k. The printed eq. (4) grad_1 = 0 and (9) Δy_1 = 0 are the case without a
linear term; with p0 > 0 the first slope is p0. The printed "ΔX_BT" in eq. (16)/(17) is X_BT.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.base import Chain, model_from_dict
from core.digitized import DigitizedPI, DigitizedState, as_digits, digit_string
from core.digitized_deadzone import (
    DigitizedDeadZone,
    DigitizedModifiedPI,
    deadzone_output,
)
from core.exceptions import NotInvertibleError, ParameterError
from core.pi import PIModel

# ----------------------------------------------------------------------------- fixtures


def two_op() -> tuple[PIModel, DigitizedPI]:
    # p0 = 0.5, one play r1 = 1 with p1 = 1, range [-3, 3] (u_A = 3): n = 2 digits.
    pi = PIModel(0.5, [1.0], [1.0])
    return pi, DigitizedPI.from_pi(pi, (-3.0, 3.0))


def three_op(shift: bool = True) -> tuple[PIModel, DigitizedPI]:
    # p0 = 0.4, r = (0.5, 1.5), p = (0.6, 1.0), range [0, 10] (u_A = 5): n = 3 digits.
    pi = PIModel(0.4, [0.5, 1.5], [0.6, 1.0])
    return pi, DigitizedPI.from_pi(pi, (0.0, 10.0), shift=shift)


def ramp(points: list[float], per: int = 9) -> np.ndarray:
    """Piecewise-linear input through ``points`` (each point sampled exactly once)."""
    segs = [np.linspace(a, b, per)[:-1] for a, b in zip(points[:-1], points[1:], strict=True)]
    return np.concatenate(segs + [np.array([points[-1]])])


def random_pi(rng: np.random.Generator, m: int) -> PIModel:
    r = np.sort(rng.uniform(0.05, 2.0, m))
    while np.any(np.diff(r) <= 1e-3):
        r = np.sort(rng.uniform(0.05, 2.0, m))
    return PIModel(rng.uniform(0.1, 1.0), r, rng.uniform(0.05, 1.0, m))


def lower_extreme(pi: PIModel, u_min: float) -> PIModel:
    """The classical model started at the lower extreme of the major loop (plays at u_min + r)."""
    return PIModel(pi.p0, pi.thresholds, pi.weights, u_min + pi.thresholds)


# ----------------------------------------------------------------------------- paper cases


def test_two_operators_paired_properties_and_states() -> None:
    _, d = two_op()
    # Δx_1 = 2 r1 = 2, Δx_2 = 2 (u_A - r1) = 4; grad = (p0, p0 + p1) = (0.5, 1.5);
    # Δy = (1, 6). Origin: X0 = u_min = -3, Y0 = S_2 u_min + p1 r1 = -4.5 + 1 = -3.5.
    np.testing.assert_allclose(d.H, [[2.0, 4.0], [1.0, 6.0]], rtol=0, atol=1e-15)
    assert (d.x0, d.y0) == (-3.0, -3.5)
    g = d.state_graph()
    # Fig. 3: 2 operators -> 4 states. By hand: 00 (-3, -3.5), 01 (-1, -2.5),
    # 10 (1, 2.5), 11 (3, 3.5) (symmetric loop: Y_11 = -Y_00).
    assert g.strings == ["00", "01", "10", "11"]
    np.testing.assert_allclose(g.x, [-3.0, -1.0, 1.0, 3.0], atol=1e-15)
    np.testing.assert_allclose(g.y, [-3.5, -2.5, 2.5, 3.5], atol=1e-15)
    # Up = set the lowest 0, down = clear the lowest 1 (eq. 12-15).
    assert g.up.tolist() == [[0, 1, 1], [1, 3, 2], [2, 3, 1]]
    assert g.down.tolist() == [[1, 0, 1], [2, 0, 2], [3, 2, 1]]


def test_two_operators_sweeps_and_shifted_loop() -> None:
    pi, d = two_op()
    tr = d.trace(ramp([-3.0, 3.0, -3.0], per=7))
    assert tr.strings == ["00", "01", "11", "10", "00"]
    # transitions at the samples that reach X = -1, 3, 1, -3 (step 1 on a 7-point ramp)
    assert tr.sample.tolist() == [0, 2, 6, 8, 12]
    assert tr.flip.tolist() == [0, 1, 2, -1, -2]
    # paper Fig. 2 shifts the loop into the positive quadrant
    s = DigitizedPI.from_pi(pi, (-3.0, 3.0), shift=True)
    assert (s.x0, s.y0) == (0.0, 0.0)
    np.testing.assert_allclose(s.state_graph().y, [0.0, 1.0, 6.0, 7.0], atol=1e-15)
    u = ramp([-3.0, 3.0, -1.5, 2.0, -3.0])
    np.testing.assert_allclose(s(u + 3.0), d(u) + 3.5, atol=1e-12)


def test_three_operators_states_and_sequences() -> None:
    _, d = three_op()
    # Δx = (2*0.5, 2*(1.5-0.5), 2*(5-1.5)) = (1, 2, 7); grad = (0.4, 1.0, 2.0);
    # Δy = (0.4, 2, 14). Shifted origin (0, 0).
    np.testing.assert_allclose(d.H, [[1.0, 2.0, 7.0], [0.4, 2.0, 14.0]], atol=1e-15)
    g = d.state_graph()
    # Fig. 4: 3 operators -> 8 states; X_B, Y_B = Σ b_k Δx_k, Σ b_k Δy_k by hand.
    assert g.codes.tolist() == list(range(8))
    np.testing.assert_allclose(g.x, [0, 1, 2, 3, 7, 8, 9, 10], atol=1e-15)
    np.testing.assert_allclose(g.y, [0, 0.4, 2, 2.4, 14, 14.4, 16, 16.4], atol=1e-14)
    assert g.up.shape == g.down.shape == (7, 3)
    # up sweep 000 -> 001 -> 011 -> 111, down sweep 111 -> 110 -> 100 -> 000
    assert d.trace(ramp([0.0, 10.0])).strings == ["000", "001", "011", "111"]
    assert d.trace(ramp([10.0, 0.0]), state="111").strings == ["111", "110", "100", "000"]
    # zigzag 0 -> 3 -> 2 -> 2.5 -> 10 -> 8 -> 0: at 2.5 the state stays 010 (inside the
    # segment of b1), at 8 it stays 110 (on the lower segment of b2, between X = 7 and 9).
    tr = d.trace(ramp([0.0, 3.0, 2.0, 2.5, 10.0, 8.0, 0.0]))
    assert tr.strings == ["000", "001", "011", "010", "011", "111", "110", "100", "000"]
    y = d(ramp([0.0, 3.0, 2.0, 2.5]))
    assert y[-1] == pytest.approx(2.0 + 0.4 * 0.5, abs=1e-14)  # Y_010 + grad_1 * 0.5
    # rows and codes agree, b1 in column 0
    assert tr.codes.tolist() == [0, 1, 3, 2, 3, 7, 6, 4, 0]
    assert tr.digits[2].tolist() == [1, 1, 0]


def test_three_operators_unshifted_origin_is_classical_lower_extreme() -> None:
    pi, d = three_op(shift=False)
    # Y0 = S_3 u_min + Σ p_i r_i = 0 + 0.6*0.5 + 1.0*1.5 = 1.8
    assert d.y0 == pytest.approx(1.8, abs=1e-15)
    assert d.y_range[1] == pytest.approx(1.8 + 16.4, abs=1e-13)
    # reversals at state points only: 111 (10), 100 (7), 101 (8)
    u = ramp([0.0, 10.0, 7.0, 8.0, 0.0], per=41)
    np.testing.assert_allclose(d(u), lower_extreme(pi, 0.0)(u), rtol=0, atol=1e-12)


# ----------------------------------------------------------------------------- classical


def test_from_pi_to_pi_recovers_parameters() -> None:
    rng = np.random.default_rng(7)
    for m in (1, 3, 6):
        pi = random_pi(rng, m)
        d = DigitizedPI.from_pi(pi, (-3.0, 2.5))
        c = d.to_pi()
        np.testing.assert_allclose(c.thresholds, pi.thresholds, rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(c.weights, pi.weights, rtol=1e-12, atol=1e-14)
        assert c.p0 == pytest.approx(pi.p0, rel=1e-14)
        np.testing.assert_allclose(c.state0, -3.0 + pi.thresholds, atol=1e-14)
        assert abs(d.classical_offset) < 1e-13
        # refining adds zero-weight plays: the same classical model
        f = DigitizedPI.from_pi(pi, (-3.0, 2.5), refine=3)
        assert f.n == 3 * (m + 1)
        u = ramp([-3.0, 2.5, -1.0, 0.3, -3.0], per=30)
        np.testing.assert_allclose(f.to_pi()(u), c(u), atol=1e-12)


def test_play_state_matches_classical_history() -> None:
    # z_i = X_B - Σ_{k<=i} b_k Δx_k + r_i must be the play state the classical model reaches
    # when driven from the lower extreme along the grid to B.
    rng = np.random.default_rng(3)
    pi = random_pi(rng, 4)
    d = DigitizedPI.from_pi(pi, (-2.5, 2.5))
    c0 = lower_extreme(pi, -2.5)
    walk = grid_walk(d, rng, 40)
    tr = d.trace(walk)
    for j in range(1, tr.sample.size):
        k = tr.sample[j]
        assert walk[k] == pytest.approx(tr.x_b[j], abs=1e-12)  # sampled at the state point
        z = c0.simulate(walk[: k + 1]).state
        np.testing.assert_allclose(d.play_state(tr.digits[j]), z, atol=1e-12)


def grid_walk(d: DigitizedPI, rng: np.random.Generator, moves: int, per: int = 5) -> np.ndarray:
    """Input that reverses at state points only (runs of random up/down moves from state0).

    Every state point passed is sampled exactly; between them the input is a ramp.
    """
    digits = np.array(d.state0)
    points = [d.state_point()[0]]
    for _ in range(moves):
        up = rng.random() < 0.5
        for _ in range(int(rng.integers(1, 4))):
            if up and digits.min() == 0:
                digits[np.flatnonzero(digits == 0)[0]] = 1
            elif not up and digits.max() == 1:
                digits[np.flatnonzero(digits == 1)[0]] = 0
            points.append(d.state_point(digits)[0])
    return ramp(points, per)


@pytest.mark.parametrize("seed", range(6))
def test_equals_classical_when_reversals_are_on_state_points(seed: int) -> None:
    # Paper 000 section 3.3: "equal mathematically". True along every path whose reversals
    # happen at state points (including every monotone path from an extreme).
    rng = np.random.default_rng(seed)
    pi = random_pi(rng, int(rng.integers(1, 6)))
    u_a = float(pi.thresholds[-1]) + rng.uniform(0.1, 1.0)
    d = DigitizedPI.from_pi(pi, (-u_a, u_a), refine=int(rng.integers(1, 3)))
    u = grid_walk(d, rng, 60)
    np.testing.assert_allclose(d(u), lower_extreme(pi, -u_a)(u), rtol=0, atol=1e-12)
    # from any reached state, to_pi(state) continues identically
    st = d.simulate(u).state
    v = grid_walk(DigitizedPI(d.dx, d.dy, d.x0, d.y0, st), rng, 20)
    np.testing.assert_allclose(d.simulate(v, state=st).y, d.to_pi(st)(v), atol=1e-12)


def test_monotone_path_from_extreme_to_any_point() -> None:
    rng = np.random.default_rng(11)
    pi = random_pi(rng, 5)
    d = DigitizedPI.from_pi(pi, (-3.0, 3.0))
    c = lower_extreme(pi, -3.0)
    for target in rng.uniform(-3.0, 3.0, 20):
        u = np.linspace(-3.0, target, 57)
        np.testing.assert_allclose(d(u), c(u), atol=1e-12)
    # and down from the upper extreme
    top = PIModel(pi.p0, pi.thresholds, pi.weights, 3.0 - pi.thresholds)
    for target in rng.uniform(-3.0, 3.0, 20):
        u = np.linspace(3.0, target, 57)
        np.testing.assert_allclose(d.simulate(u, state=2**d.n - 1).y, top(u), atol=1e-12)


def test_interior_reversal_not_remembered_single_bound() -> None:
    _, d = three_op(shift=False)
    pi = d.to_pi()
    # up from the lower extreme into segment 3 (between X_011 = 3 and X_111 = 10) by
    # d = 2.5, reverse, and go back to the lower extreme.
    u = ramp([0.0, 5.5, 0.0], per=221)
    e = pi(u) - d(u)  # classical branch (slope p0) stays above the retraced segment
    k, travel = 3, 2.5
    bound = (d.slopes[k - 1] - d.slopes[0]) * travel  # (grad_3 - p0) d = 1.6 * 2.5 = 4.0
    assert np.max(np.abs(e)) <= bound + 1e-12
    assert np.max(e) > 0.5  # the reversal is really forgotten (not a vacuous bound)
    # by hand at X_011 = 3 on the way down: classical y(5.5) - F(2.5) with F the reversal
    # curve (slope 0.4 for 1, 1.0 for 1.5) = y(5.5) - 1.9; digitized Y_011 = 1.8 + 2.4.
    i3 = np.flatnonzero(np.isclose(u, 3.0))[-1]
    y55 = 1.8 + 2.4 + 2.0 * 2.5
    assert pi(u)[i3] == pytest.approx(y55 - 1.9, abs=1e-12)
    assert d(u)[i3] == pytest.approx(1.8 + 2.4, abs=1e-12)
    assert e[i3] == pytest.approx((y55 - 1.9) - 4.2, abs=1e-12)
    # wiping out: back at the lower extreme both agree again
    assert abs(e[-1]) < 1e-12
    assert np.all(d.single_reversal_bound() >= 0)


def random_reversal_input(rng: np.random.Generator, u_a: float) -> np.ndarray:
    ext = np.clip(np.cumsum(rng.normal(0.0, 0.4 * u_a, 80)), -u_a, u_a)
    return np.concatenate(([-u_a], ramp([-u_a, *ext.tolist()], per=6)))


def test_reversal_error_bound_on_random_inputs_and_refinement() -> None:
    rng = np.random.default_rng(2024)
    pi = random_pi(rng, 5)
    u_a = float(pi.thresholds[-1]) + 0.5
    c = lower_extreme(pi, -u_a)
    inputs = [random_reversal_input(rng, u_a) for _ in range(20)]
    errs, bounds = [], []
    for s in (1, 2, 4, 8):
        d = DigitizedPI.from_pi(pi, (-u_a, u_a), refine=s)
        # the single-reversal bound max_k (grad_k - p0) Δx_k is not enough with many
        # reversals; reversal_error_bound (per play) is, and it is >= the single one
        assert d.reversal_error_bound() >= d.single_reversal_bound().max() - 1e-15
        e = max(float(np.max(np.abs(d(u) - c(u)))) for u in inputs)
        assert e <= d.reversal_error_bound() + 1e-12
        errs.append(e)
        bounds.append(d.reversal_error_bound())
    np.testing.assert_allclose(np.array(bounds[0]) / bounds, [1, 2, 4, 8], rtol=1e-12)
    assert errs[0] > 0.05 * bounds[0]  # the error is real...
    assert errs[-1] < errs[0] / 3  # ...and it shrinks with finer segments


def test_beyond_range_continues_with_outer_slope() -> None:
    pi, d = two_op()
    c = lower_extreme(pi, -3.0)
    u = np.linspace(-3.0, 5.0, 33)  # monotone beyond u_max = 3
    np.testing.assert_allclose(d(u), c(u), atol=1e-12)
    y = d(np.array([-3.0, 3.0, 4.0]))
    assert y[2] - y[1] == pytest.approx(1.5, abs=1e-12)  # outer slope grad_2
    y = d(np.array([-5.0]))
    assert y[0] == pytest.approx(-3.5 - 2 * 1.5, abs=1e-12)


def test_digitized_inverse_equals_classical_inverse_paper001_example1() -> None:
    # Paper 001 Example 1: r_i = 0.45 i, p0 = 0.72, p = (0.6, 0.48, 0.36, 0.24, 0.12, 0.012).
    # Swapping Δx and Δy (paper 000 eq. 22) gives the inverse's thresholds
    # r'_k = Σ Δy / 2 = z_k and weights 1/grad_(k+1) - 1/grad_k = q_k (paper 001 eq. 36-37).
    pi = PIModel(0.72, 0.45 * np.arange(1, 7), [0.6, 0.48, 0.36, 0.24, 0.12, 0.012])
    d = DigitizedPI.from_pi(pi, (-4.0, 4.0))
    inv = d.inverse().to_pi()
    # printed z_i and q0 (they match the recomputation exactly, see seed notes)
    np.testing.assert_allclose(inv.thresholds, [0.324, 0.918, 1.728, 2.7, 3.78, 4.914], atol=1e-12)
    assert inv.p0 == pytest.approx(1.3889, abs=5e-5)
    np.testing.assert_allclose(
        inv.weights, [-0.6313, -0.2020, -0.0926, -0.0463, -0.0198, -0.0019], atol=6e-5
    )
    ref = pi.inverse()
    np.testing.assert_allclose(inv.weights, ref.weights, rtol=1e-12)
    np.testing.assert_allclose(inv.thresholds, ref.thresholds, rtol=1e-12)
    # inverse state point of 0...0 is the swapped origin
    assert (d.inverse().x0, d.inverse().y0) == (d.y0, d.x0)


def test_not_invertible() -> None:
    with pytest.raises(NotInvertibleError, match="grad_1 = p0"):
        DigitizedPI([1.0, 2.0], [0.0, 3.0]).inverse()
    with pytest.raises(NotInvertibleError, match="Δy_2"):
        DigitizedPI([1.0, 2.0], [1.0, -3.0]).inverse()
    # classical p0 = 0 (paper 000 eq. 4 grad_1 = 0): no digitized inverse
    d = DigitizedPI.from_pi(PIModel(0.0, [1.0], [1.0]), (-2.0, 2.0))
    assert not d.is_invertible
    with pytest.raises(NotInvertibleError, match="p0"):
        d.inverse()
    with pytest.raises(NotInvertibleError, match="Δy_1"):
        DigitizedDeadZone([1.0, 1.0], [-1.0, 1.0]).inverse()


# ----------------------------------------------------------------------------- properties

dig_params = st.integers(1, 7).flatmap(
    lambda n: st.tuples(
        st.lists(st.floats(0.05, 3.0), min_size=n, max_size=n),
        st.lists(st.floats(0.05, 5.0), min_size=n, max_size=n),
        st.floats(-5.0, 5.0),
        st.floats(-5.0, 5.0),
        st.integers(0, 2**n - 1),
    )
)


def make_input(seed: int, lo: float, hi: float, n: int = 300) -> np.ndarray:
    rng = np.random.default_rng(seed)
    span = hi - lo
    ext = rng.uniform(lo - 0.2 * span, hi + 0.2 * span, 30)
    return ramp(ext.tolist(), per=max(2, n // 30))


@settings(max_examples=60, deadline=None)
@given(dig_params, st.integers(0, 2**32 - 1))
def test_pi_inverse_round_trips(params, seed) -> None:
    dx, dy, x0, y0, code = params
    d = DigitizedPI(dx, dy, x0, y0, code)
    inv = d.inverse()
    u = make_input(seed, *d.x_range)
    scale = max(1.0, float(np.max(np.abs(u))))
    np.testing.assert_allclose(inv(d(u)), u, rtol=0, atol=1e-9 * scale)
    w = make_input(seed + 1, *d.y_range)
    np.testing.assert_allclose(d(inv(w)), w, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(w))))


@settings(max_examples=60, deadline=None)
@given(dig_params, st.integers(0, 2**32 - 1))
def test_deadzone_inverse_round_trips(params, seed) -> None:
    dx, dy, x0, y0, code = params
    s = DigitizedDeadZone(dx, dy, x0, y0, 1 + code % len(dx))
    u = make_input(seed, *s.breakpoints[0, [0, -1]])
    np.testing.assert_allclose(
        s.inverse()(s(u)), u, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(u)))
    )
    # memoryless: agrees with linear interpolation/extrapolation through the breakpoints
    X, Y = s.breakpoints
    ref = np.interp(u, X, Y)
    ref = np.where(u < X[0], Y[0] + s.slopes[0] * (u - X[0]), ref)
    ref = np.where(u > X[-1], Y[-1] + s.slopes[-1] * (u - X[-1]), ref)
    np.testing.assert_allclose(s(u), ref, rtol=1e-12, atol=1e-12 * max(1.0, np.max(np.abs(ref))))


@settings(max_examples=50, deadline=None)
@given(dig_params, dig_params, st.integers(0, 2**32 - 1))
def test_modified_pi_inverse_round_trips(p1, p2, seed) -> None:
    h = DigitizedPI(*p1)
    dx, dy, x0, y0, code = p2
    s = DigitizedDeadZone(dx, dy, x0, y0, 1 + code % len(dx))
    m = DigitizedModifiedPI(h, s)
    u = make_input(seed, *h.x_range)
    np.testing.assert_allclose(
        m.inverse()(m(u)), u, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(u)))
    )
    w = make_input(seed + 1, *s(np.array(h.y_range)))
    np.testing.assert_allclose(
        m(m.inverse()(w)), w, rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(w)))
    )


@settings(max_examples=50, deadline=None)
@given(dig_params, st.integers(0, 2**32 - 1), st.integers(1, 299))
def test_chunked_equals_one_call(params, seed, k) -> None:
    d = DigitizedPI(*params)
    u = make_input(seed, *d.x_range)
    k = k % u.size
    full = d.simulate(u)
    a = d.simulate(u[:k])
    b = d.simulate(u[k:], state=a.state)
    assert np.array_equal(np.concatenate((a.y, b.y)), full.y)
    assert np.array_equal(b.state.digits, full.state.digits)
    assert b.state.segment == full.state.segment
    # trace records the same output and final state
    tr = d.trace(u)
    assert np.array_equal(tr.y, full.y) and tr.state.code == full.state.code
    # dead zone and modified PI carry their state too
    s = DigitizedDeadZone(params[0], params[1], params[2], params[3])
    m = DigitizedModifiedPI(d, s)
    a2 = m.simulate(u[:k])
    b2 = m.simulate(u[k:], state=a2.state)
    assert np.array_equal(np.concatenate((a2.y, b2.y)), m(u))


def test_trace_final_state_consistent_with_rows() -> None:
    _, d = three_op()
    u = ramp([0.0, 9.5, 2.2, 6.0, 1.0], per=13)
    tr = d.trace(u)
    assert tr.state.code == tr.codes[-1]
    np.testing.assert_allclose(tr.x_b[-1], tr.state.x_b)
    assert np.all(np.diff(tr.sample) >= 0)
    # every transition flips exactly the digit it names
    for j in range(1, tr.sample.size):
        changed = np.flatnonzero(tr.digits[j] != tr.digits[j - 1])
        assert changed.tolist() == [abs(int(tr.flip[j])) - 1]
    # a long record with many transitions exceeds the initial event buffer and is re-run
    long = np.tile(ramp([0.0, 10.0, 0.0], per=3), 50)
    assert d.trace(long).sample.size == 1 + 50 * 6


# ----------------------------------------------------------------------------- dead zone


def test_deadzone_from_classical_superposition() -> None:
    # paper 001 Example 4 positive branch (mirrored), rounded weights as printed
    rho_p = np.array([0.4, 0.75, 1, 1.25, 1.5, 1.75, 2, 2.25, 2.5, 2.75, 3])
    eta_p = np.array(
        [-1.128, -1.116, -0.793, -0.598, -0.413, -0.271, -0.172, -0.106, -0.066, -0.041, -0.025]
    )
    rho = np.concatenate((-rho_p[::-1], [0.0], rho_p))
    eta = np.concatenate((eta_p[::-1], [4.765], eta_p))
    s = DigitizedDeadZone.from_deadzone(rho, eta)
    assert s.m == 23 - 1 + 2 - 1  # 22 nonzero thresholds -> 23 segments
    v = np.linspace(-8.0, 8.0, 801)
    np.testing.assert_allclose(s(v), deadzone_output(v, rho, eta), atol=1e-12)
    # slope of the first positive segment is η0 (ρ in (0, 0.4)), then η0 + η1, ...
    X, _ = s.breakpoints
    i0 = int(np.flatnonzero(np.isclose(X, 0.4))[0])
    assert s.slopes[i0 - 1] == pytest.approx(4.765, abs=1e-12)
    assert s.slopes[i0] == pytest.approx(4.765 - 1.128, abs=1e-12)
    # the partial slopes stay positive, so the swap (eq. 23) is the exact inverse
    w = deadzone_output(v, rho, eta)
    np.testing.assert_allclose(s.inverse()(w), v, atol=1e-9)
    # a narrow range is exact inside it only (outer segments extended)
    n = DigitizedDeadZone.from_deadzone(rho, eta, (-1.0, 1.0))
    inside = np.linspace(-1.0, 1.0, 101)
    np.testing.assert_allclose(n(inside), deadzone_output(inside, rho, eta), atol=1e-12)
    assert abs(n(np.array([3.0]))[0] - deadzone_output([3.0], rho, eta)[0]) > 0.1


def test_modified_pi_equals_classical_chain_on_grid_paths() -> None:
    rng = np.random.default_rng(5)
    pi = random_pi(rng, 3)
    rho, eta = np.array([-1.0, 0.0, 0.5, 1.5]), np.array([0.3, 1.0, 0.4, -0.2])
    m = DigitizedModifiedPI.from_classical(pi, (-2.5, 2.5), rho, eta)
    u = grid_walk(m.pi, rng, 30)
    y_classical = deadzone_output(lower_extreme(pi, -2.5)(u), rho, eta)
    np.testing.assert_allclose(m(u), y_classical, atol=1e-12)
    np.testing.assert_allclose(m.as_chain()(u), m(u), atol=0)
    assert isinstance(m.inverse(), Chain)


# ----------------------------------------------------------------------------- serialisation


def test_to_dict_round_trip() -> None:
    _, d = three_op(shift=False)
    d2 = DigitizedPI(d.dx, d.dy, d.x0, d.y0, "101")
    s = DigitizedDeadZone([1.0, 2.0], [0.5, 3.0], -1.0, 2.0, 2)
    m = DigitizedModifiedPI(d2, s)
    u = ramp([0.0, 9.0, 4.0, 6.0])
    for model in (d2, s, m, d2.inverse(), Chain.of(d2, s)):
        doc = json.loads(json.dumps(model.to_dict()))
        back = model_from_dict(doc)
        assert type(back) is type(model)
        assert back.to_dict() == model.to_dict()
        np.testing.assert_array_equal(back(u), model(u))
    assert d2.to_dict()["state0"] == "101"
    assert d2.to_dict()["type"] == "digitized"
    assert s.to_dict()["type"] == "digitized-deadzone"


# ----------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"dx": [1.0, 0.0], "dy": [1.0, 1.0]}, r"dx\[1\] = 0 is not positive"),
        ({"dx": [1.0, -2.0], "dy": [1.0, 1.0]}, r"dx\[1\] = -2 is not positive"),
        ({"dx": [1.0, np.nan], "dy": [1.0, 1.0]}, r"dx\[1\] = nan is not finite"),
        ({"dx": [1.0, 2.0], "dy": [1.0, np.inf]}, r"dy\[1\] = inf is not finite"),
        ({"dx": [1.0, 2.0], "dy": [1.0]}, r"dy must have length 2"),
        ({"dx": [], "dy": []}, r"dx must have at least 1"),
        ({"dx": [1.0], "dy": [1.0], "x0": np.nan}, r"x0 = nan is not finite"),
        ({"dx": [1.0, 2.0], "dy": [1.0, 1.0], "state0": "012"}, r"state0 = '012'"),
        ({"dx": [1.0, 2.0], "dy": [1.0, 1.0], "state0": "1"}, r"exactly 2 characters"),
        ({"dx": [1.0, 2.0], "dy": [1.0, 1.0], "state0": 4}, r"0 <= code < 2\*\*2"),
        ({"dx": [1.0, 2.0], "dy": [1.0, 1.0], "state0": [1, 2]}, r"each be 0 or 1"),
        ({"dx": [1.0, 2.0], "dy": [1.0, 1.0], "state0": [1, 0, 1]}, r"must hold 2 digits"),
    ],
)
def test_invalid_digitized_pi(kwargs, match) -> None:
    with pytest.raises(ParameterError, match=match):
        DigitizedPI(**kwargs)


def test_invalid_other() -> None:
    with pytest.raises(ParameterError, match=r"H must have shape \(2, n\)"):
        DigitizedPI.from_H(np.ones((3, 2)))
    with pytest.raises(ParameterError, match=r"S must have shape \(2, m\)"):
        DigitizedDeadZone.from_S(np.ones(4))
    with pytest.raises(ParameterError, match="initial segment = 3 must be a segment number"):
        DigitizedDeadZone([1.0, 1.0], [1.0, 1.0], state0=3)
    with pytest.raises(ParameterError, match="dx must have at least 1"):
        DigitizedDeadZone([], [])
    with pytest.raises(ParameterError, match="must exceed the largest threshold"):
        DigitizedPI.from_pi(PIModel(0.5, [1.0, 2.0], [1.0, 1.0]), (-2.0, 2.0))
    with pytest.raises(ParameterError, match="u_min < u_max"):
        DigitizedPI.from_pi(PIModel(0.5, [1.0], [1.0]), (3.0, -3.0))
    with pytest.raises(ParameterError, match="refine"):
        DigitizedPI.from_pi(PIModel(0.5, [1.0], [1.0]), (-3.0, 3.0), refine=0)
    with pytest.raises(ParameterError, match="must contain ρ_0 = 0"):
        DigitizedDeadZone.from_deadzone([-1.0, 1.0], [1.0, 1.0])
    with pytest.raises(ParameterError, match="thresholds must be strictly increasing"):
        DigitizedDeadZone.from_deadzone([0.0, 1.0, 1.0], [1.0, 1.0, 1.0])
    with pytest.raises(ParameterError, match="n >= 2 digits"):
        DigitizedPI([1.0], [1.0]).to_pi()
    d = DigitizedPI(np.ones(13), np.ones(13))
    with pytest.raises(ParameterError, match="n = 13 digits exceeds the limit"):
        d.state_graph()
    with pytest.raises(ParameterError, match="state must hold 13 digits"):
        d.simulate([0.0], state=[0, 1])
    with pytest.raises(ParameterError, match="pair"):
        DigitizedModifiedPI(DigitizedPI([1.0], [1.0]), DigitizedDeadZone([1.0], [1.0])).simulate(
            [0.0], state=(1,)
        )
    with pytest.raises(ParameterError, match="missing field"):
        model_from_dict({"type": "digitized", "dx": [1.0]})


def test_digit_conventions() -> None:
    # strings are written like the paper (b_n ... b_1), sequences list b_1 first
    assert as_digits("011", 3).tolist() == [1, 1, 0]
    assert as_digits([1, 1, 0], 3).tolist() == [1, 1, 0]
    assert as_digits(3, 3).tolist() == [1, 1, 0]
    assert digit_string([1, 1, 0]) == "011"
    st0 = DigitizedState(as_digits("011", 3))
    assert st0.code == 3 and st0.string == "011"
    d = DigitizedPI([1.0, 2.0, 7.0], [0.4, 2.0, 14.0], state0="011")
    assert d.state_point() == pytest.approx((3.0, 2.4))
    assert d.default_state().code == 3


def test_deadzone_map_interop() -> None:
    # a second implementation: core.deadzone.DeadZoneMap (searchsorted evaluation and the
    # analytic inverse of paper 001 eq. 53-54) against the digitized walk and swap (eq. 23)
    from core.deadzone import DeadZoneMap

    g = DeadZoneMap.symmetric([0.5, 1.2, 2.0], 1.5, [-0.4, -0.3, 0.6])
    s = DigitizedDeadZone.from_deadzone_map(g)
    v = np.linspace(-6.0, 6.0, 1201)
    np.testing.assert_allclose(s(v), g(v), atol=1e-12)
    w = g(v)
    np.testing.assert_allclose(s.inverse()(w), g.inverse()(w), atol=1e-12)
    with pytest.raises(ParameterError, match="no thresholds/weights"):
        DigitizedDeadZone.from_deadzone_map(object())


def test_modified_pi_against_core_gpi() -> None:
    # second implementation: core.gpi.ModifiedPI (classical S[P[v]]) started at the lower
    # extreme equals the digitized modified PI on paths reversing at state points
    from core.deadzone import DeadZoneMap
    from core.gpi import ModifiedPI

    pi = PIModel(0.4, [0.5, 1.5], [0.6, 1.0], 0.0 + np.array([0.5, 1.5]))
    g = DeadZoneMap([-1.0, 0.0, 5.0, 12.0], [0.2, 1.0, 0.3, -0.6])
    classical = ModifiedPI(pi, g)
    m = DigitizedModifiedPI.from_modified_pi(classical, (0.0, 10.0))
    u = ramp([0.0, 10.0, 7.0, 8.0, 0.0, 3.0, 2.0, 10.0], per=23)
    np.testing.assert_allclose(m(u), classical(u), atol=1e-12)
    with pytest.raises(ParameterError, match="not a modified PI"):
        DigitizedModifiedPI.from_modified_pi(pi, (0.0, 10.0))


@settings(max_examples=50, deadline=None)
@given(dig_params, st.integers(0, 2**32 - 1))
def test_inverse_round_trip_on_state_points(params, seed) -> None:
    # inputs that hit state points exactly (and reverse there) are the delicate case for the
    # snapping rule: forward and inverse must change state on the same samples
    d = DigitizedPI(*params)
    rng = np.random.default_rng(seed)
    u = grid_walk(d, rng, 25, per=3)
    inv = d.inverse()
    scale = max(1.0, float(np.max(np.abs(u))))
    np.testing.assert_allclose(inv(d(u)), u, rtol=0, atol=1e-9 * scale)
    assert np.array_equal(inv.simulate(d(u)).state.digits, d.simulate(u).state.digits)


def test_negative_weights_still_equal_on_state_points() -> None:
    # the up/down rules and play_state are geometric: they hold for any weight signs
    pi = PIModel(0.8, [0.4, 1.0, 1.7], [0.5, -0.3, 0.4])
    d = DigitizedPI.from_pi(pi, (-2.0, 2.0))
    rng = np.random.default_rng(9)
    u = grid_walk(d, rng, 50)
    np.testing.assert_allclose(d(u), lower_extreme(pi, -2.0)(u), atol=1e-12)


def test_trace_codes_for_many_digits() -> None:
    d = DigitizedPI(np.full(70, 0.1), np.linspace(0.01, 1.0, 70))
    tr = d.trace(np.array([0.0, 7.0, 6.85]))  # down by more than Δx_1 = 0.1
    assert tr.codes.dtype == object
    assert tr.codes[-2] == 2**70 - 1  # all digits set at the top of the range
    assert tr.codes[-1] == 2**70 - 2  # the first move down clears b1
    assert tr.strings[-1] == "1" * 69 + "0"


def test_deadzone_to_classical_round_trip() -> None:
    rho = np.array([-2.5, -1.0, 0.0, 0.7, 2.0])
    eta = np.array([0.4, -0.2, 1.1, 0.3, -0.5])
    s = DigitizedDeadZone.from_deadzone(rho, eta)
    r2, e2, off = s.to_deadzone()
    np.testing.assert_allclose(r2, rho, atol=1e-15)
    np.testing.assert_allclose(e2, eta, atol=1e-13)
    assert off == pytest.approx(0.0, abs=1e-13)
    # a digitized map with an offset and no threshold at 0
    t = DigitizedDeadZone([1.0, 2.0, 1.5], [2.0, 1.0, 3.0], x0=-1.5, y0=0.25)
    r3, e3, off3 = t.to_deadzone()
    v = np.linspace(-4.0, 5.0, 181)
    np.testing.assert_allclose(off3 + deadzone_output(v, r3, e3), t(v), atol=1e-12)
    with pytest.raises(ParameterError, match="ends exactly at v = 0"):
        DigitizedDeadZone([1.0, 1.0], [1.0, 2.0], x0=-1.0).to_deadzone()


def test_hypercube_layout() -> None:
    _, d = three_op()
    g = d.state_graph()
    e = g.hypercube_edges()
    assert e.shape == (3 * 2**2, 3)  # n 2**(n-1) edges of the 3-cube
    # every up/down neighbour edge of the model is an edge of the cube
    cube = {(int(a), int(b)) for a, b, _ in e}
    assert all((min(a, b), max(a, b)) in cube for a, b, _ in np.vstack((g.up, g.down)))
    xy = g.hypercube_xy()
    assert xy.shape == (8, 2)
    assert len({tuple(np.round(p, 9)) for p in xy}) == 8  # distinct positions
    big = DigitizedPI(np.ones(12), np.ones(12)).state_graph().hypercube_xy()
    assert len({tuple(np.round(p, 9)) for p in big}) == 2**12


@settings(max_examples=50, deadline=None)
@given(dig_params, st.integers(0, 2**32 - 1))
def test_any_digitized_model_equals_its_classical_form(params, seed) -> None:
    # any H, origin and state: to_pi(state) + classical_offset reproduces the digitized
    # output along paths that reverse at state points (play_state is the classical memory)
    d = DigitizedPI(*params)
    if d.n < 2:
        return
    rng = np.random.default_rng(seed)
    st0 = d.default_state()
    c = d.to_pi(st0)
    v = grid_walk(d, rng, 20)
    assert v[0] == st0.x_b  # starts at the state point of state0
    scale = max(1.0, float(np.max(np.abs(d.y_range))))
    np.testing.assert_allclose(
        d.simulate(v, state=st0).y, c(v) + d.classical_offset, rtol=0, atol=1e-11 * scale
    )
