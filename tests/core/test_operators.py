"""Play, stop and dead-zone operators (paper 001 eq. 1-6, 24, 26-28, 42).

The independent oracle here is the two-mass backlash of paper 001 Fig. 2, written as
"mass B follows mass A only when the gap exceeds a": a different formula from the clamp
``max(u - r, min(u + r, z))`` used by the kernels.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.exceptions import ParameterError
from core.operators import dead_zone, play, play_bank, stop

SETTINGS = settings(max_examples=60, deadline=None)


def backlash_oracle(u: np.ndarray, a: float, x2: float) -> np.ndarray:
    """Fig. 2: mass B (x2) is dragged by mass A (x1 = u) through a gap of half-width a."""
    out = np.empty(len(u))
    for k, x1 in enumerate(u):
        if x1 - x2 > a:
            x2 = x1 - a
        elif x2 - x1 > a:
            x2 = x1 + a
        out[k] = x2
    return out


@st.composite
def signals(draw, min_size: int = 1, max_size: int = 300) -> np.ndarray:
    n = draw(st.integers(min_size, max_size))
    seed = draw(st.integers(0, 2**31 - 1))
    scale = draw(st.floats(0.01, 10.0))
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.standard_normal(n)) * scale


def test_docstring_example_and_initial_condition_eq2() -> None:
    Y, z = play_bank([0.0, 1.0, 0.0], [0.5])
    assert Y[:, 0].tolist() == [0.0, 0.5, 0.5] and z.tolist() == [0.5]
    # eq. (2): Γ(0) = max(v(0) - r, min(v(0) + r, M0))
    assert play([2.0], 0.5, state0=0.0)[0] == 1.5
    assert play([2.0], 0.5, state0=1.8)[0] == 1.8
    assert play([2.0], 0.5, state0=9.0)[0] == 2.5


@SETTINGS
@given(u=signals(), r=st.floats(0.0, 5.0), m0=st.floats(-5.0, 5.0))
def test_play_matches_two_mass_backlash(u: np.ndarray, r: float, m0: float) -> None:
    assert np.array_equal(play(u, r, m0), backlash_oracle(u, r, m0))


@SETTINGS
@given(u=signals(), m0=st.floats(-5.0, 5.0))
def test_play_with_zero_threshold_is_identity(u: np.ndarray, m0: float) -> None:
    assert np.array_equal(play(u, 0.0, m0), u)


@SETTINGS
@given(u=signals(), r=st.floats(0.0, 5.0), m0=st.floats(-5.0, 5.0))
def test_play_stop_identity_and_bounds_eq26_27(u: np.ndarray, r: float, m0: float) -> None:
    g = play(u, r, m0)
    ulp = 4 * np.finfo(float).eps * max(1.0, float(np.max(np.abs(u))) + r)
    assert np.all(np.abs(u - g) <= r + ulp)  # eq. (27), up to the rounding of u - (u - r)
    s0 = float(np.clip(u[0] - m0, -r, r))  # stop state matching the play state M0
    xi = stop(u, r, s0)
    assert np.allclose(xi + g, u, rtol=0, atol=1e-12 * max(1.0, np.max(np.abs(u))))  # (26)
    assert np.all(np.abs(xi) <= r + ulp)
    # eq. (28): |Γ| <= v_max + r (M0 is clamped into [v(0) - r, v(0) + r] by eq. 2)
    assert np.all(np.abs(g) <= np.max(np.abs(u)) + r + ulp)


@SETTINGS
@given(u1=signals(min_size=50, max_size=50), u2=signals(min_size=50, max_size=50),
       r=st.floats(0.0, 3.0), m0=st.floats(-3.0, 3.0))
def test_play_lipschitz_in_input_eq3(u1: np.ndarray, u2: np.ndarray, r: float, m0: float) -> None:
    d = np.abs(play(u1, r, m0) - play(u2, r, m0))
    ulp = 8 * np.finfo(float).eps * (float(max(np.max(np.abs(u1)), np.max(np.abs(u2)))) + 6.0)
    assert np.max(d) <= np.max(np.abs(u1 - u2)) + ulp


@SETTINGS
@given(u=signals(), r1=st.floats(0.0, 3.0), r2=st.floats(0.0, 3.0))
def test_play_lipschitz_in_threshold(u: np.ndarray, r1: float, r2: float) -> None:
    # "Γ_r[v](t) as a function of r is Lipschitz continuous with constant one" (virgin state)
    d = np.abs(play(u, r1) - play(u, r2))
    ulp = 8 * np.finfo(float).eps * (float(np.max(np.abs(u))) + 3.0)
    assert np.max(d) <= abs(r1 - r2) + ulp


@SETTINGS
@given(knots=st.lists(st.floats(-5.0, 5.0), min_size=2, max_size=12),
       reps=st.lists(st.integers(1, 9), min_size=11, max_size=11),
       r=st.floats(0.0, 3.0))
def test_play_rate_independence_eq24(knots: list[float], reps: list[int], r: float) -> None:
    """Resampling monotone segments (time reparametrisation ψ) keeps turning-point values."""
    k = np.asarray(knots)
    coarse = play(k, r)
    # insert m-1 intermediate points on each (monotone) segment, plus holds (dwell)
    pieces, idx, pos = [k[:1]], [0], 0
    for i in range(k.size - 1):
        seg = np.linspace(k[i], k[i + 1], reps[i] + 1)[1:]
        pieces.append(seg)
        pos += seg.size
        idx.append(pos)
        hold = np.full(reps[-1 - i] % 3, k[i + 1])
        pieces.append(hold)
        pos += hold.size
    fine_u = np.concatenate(pieces)
    fine = play(fine_u, r)
    assert np.array_equal(fine_u[idx], k)
    assert np.array_equal(fine[idx], coarse)


def test_play_bank_state_carry_and_any_threshold_order() -> None:
    u = np.random.default_rng(3).standard_normal(200).cumsum()
    r = np.array([1.0, 0.2, 0.6])
    Y, z = play_bank(u, r, [0.1, -0.1, 0.0])
    Y1, z1 = play_bank(u[:77], r, [0.1, -0.1, 0.0])
    Y2, z2 = play_bank(u[77:], r, z1)
    assert np.array_equal(np.vstack((Y1, Y2)), Y) and np.array_equal(z2, z)
    for i in range(3):
        assert np.array_equal(Y[:, i], play(u, r[i], [0.1, -0.1, 0.0][i]))


def test_dead_zone_eq42() -> None:
    u = np.array([-2.0, -0.5, 0.0, 0.5, 2.0])
    assert dead_zone(u, 1.0).tolist() == [0.0, 0.0, 0.0, 0.0, 1.0]
    assert dead_zone(u, -1.0).tolist() == [-1.0, 0.0, 0.0, 0.0, 0.0]
    assert dead_zone(u, 0.0).tolist() == u.tolist()


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: play_bank([0.0, 1.0], [-0.5]), "thresholds\\[0\\] = -0.5 is negative"),
        (lambda: play_bank([0.0, 1.0], [np.nan]), "thresholds\\[0\\] = nan is not finite"),
        (lambda: play_bank([0.0, 1.0], []), "thresholds must have at least 1 element"),
        (lambda: play_bank([0.0, 1.0], [0.5, 1.0], [0.0]), "state0 must have length 2"),
        (lambda: play_bank([0.0, np.inf], [0.5]), "u\\[1\\] = inf is not finite"),
        (lambda: play_bank(np.zeros((2, 2)), [0.5]), "u must be one-dimensional"),
        (lambda: stop([0.0], 0.5, 0.7), "stop state0 = 0.7 must satisfy \\|state0\\| <= r"),
    ],
)
def test_invalid_arguments_name_the_parameter(call, match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        call()
