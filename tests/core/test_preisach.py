"""The level-dependent Preisach model: a plain numpy reference, the PI identity, the exact
inverse, validation, JSON, and the initial-memory wrapper."""

from __future__ import annotations

import json

import numpy as np
import pytest

from core.base import model_from_dict
from core.exceptions import NotInvertibleError, ParameterError
from core.paramset import ParameterSet, ParameterSetError, load_parameter_set
from core.pi import PIModel
from core.preisach import (
    PreisachInverse,
    PreisachModel,
    RateDependentPreisach,
    level_segments,
)
from core.stages import InitialMemory
from tests.core.model_zoo import PREISACH, turning_points


def _walk(n: int, seed: int, scale: float = 3.0) -> np.ndarray:
    """Piecewise-linear input through random turning points in [-scale, scale]."""
    rng = np.random.default_rng(seed)
    out, total, a = [], 0, 0.0
    while total < n:
        b = float(rng.uniform(-scale, scale))
        m = int(rng.integers(5, 80))
        out.append(np.linspace(a, b, m, endpoint=False))
        total, a = total + m, b
    return np.concatenate(out)[:n]


def _reference(u, r, e, W, z0):
    """Plain numpy: play recursion, then the segment functions written out case by case."""
    z = np.array(z0, dtype=float)
    y = np.empty(len(u))
    m = W.shape[1]
    for k, x in enumerate(u):
        z = np.minimum(np.maximum(z, x - r), x + r)
        total = 0.0
        for i in range(len(r)):
            for j in range(m):
                if m == 1:
                    s = z[i]
                elif j == 0:
                    s = min(z[i], e[0])
                elif j == m - 1:
                    s = max(z[i], e[m - 2]) - e[m - 2]
                else:
                    s = min(max(z[i], e[j - 1]), e[j]) - e[j - 1]
                total += W[i, j] * s
        y[k] = total
    return y, z


def _random_model(seed: int, m: int = 4) -> PreisachModel:
    rng = np.random.default_rng(seed)
    r = np.concatenate(([0.0], np.sort(rng.uniform(0.05, 2.0, 5))))
    e = np.sort(rng.uniform(-2.0, 2.0, m - 1))
    W = rng.uniform(0.0, 1.0, (r.size, m))
    W[0] += 0.1
    return PreisachModel(r, W, e, rng.uniform(-0.2, 0.2, r.size))


@pytest.mark.parametrize("m", [2, 3, 5])
def test_level_segments_equal_the_case_by_case_formula_bit_for_bit(m: int) -> None:
    """The compiled level segments (the diagnosis levels whole play banks with them) against
    the segment functions written out per value, including the knots themselves, signed
    zeros, infinities and NaN."""
    rng = np.random.default_rng(m)
    e = np.sort(rng.uniform(-2.0, 2.0, m - 1))
    z = np.concatenate((rng.uniform(-3.0, 3.0, 500), e, [0.0, -0.0, np.inf, -np.inf, np.nan]))
    got = level_segments(z, e)
    want = np.empty((z.size, m))
    for k, v in enumerate(z):
        want[k, 0] = np.minimum(v, e[0])
        for j in range(1, m - 1):
            want[k, j] = np.minimum(np.maximum(v, e[j - 1]), e[j]) - e[j - 1]
        want[k, m - 1] = np.maximum(v, e[m - 2]) - e[m - 2]
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(np.signbit(got), np.signbit(want))
    fin = np.isfinite(z)
    np.testing.assert_allclose(got[fin].sum(axis=1), z[fin], rtol=0, atol=1e-12)  # rows sum to z


@pytest.mark.parametrize("m", [1, 2, 4])
def test_matches_a_plain_numpy_reference_and_runs_in_chunks(m: int) -> None:
    model = _random_model(m, m)
    u = _walk(3000, 10 + m)
    y_ref, z_ref = _reference(u, model.thresholds, model.knots, model.weights, model.state0)
    res = model.simulate(u)
    np.testing.assert_allclose(res.y, y_ref, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(res.state, z_ref)
    a = model.simulate(u[:1234])
    b = model.simulate(u[1234:], state=a.state)
    np.testing.assert_array_equal(np.concatenate((a.y, b.y)), res.y)


def test_equal_weights_on_every_segment_is_the_pi_model() -> None:
    rng = np.random.default_rng(3)
    pi = PIModel(0.7, [0.3, 0.8, 1.4, 2.0], rng.uniform(0.05, 0.5, 4),
                 state0=[0.1, -0.2, 0.3, 0.0])
    knots = [-1.5, -0.2, 0.9]
    p = np.concatenate(([pi.p0], pi.weights))
    model = PreisachModel(np.concatenate(([0.0], pi.thresholds)), np.tile(p[:, None], 4),
                          knots, np.concatenate(([5.0], pi.state0)))
    u = rng.normal(size=4000).cumsum() * 0.05
    np.testing.assert_allclose(model(u), pi(u), rtol=0, atol=1e-12)
    # chunked, with the state carried over, in both models
    sp, sq = None, None
    for part in np.array_split(u, 7):
        a = model.simulate(part, state=sp)
        b = pi.simulate(part, state=sq)
        np.testing.assert_allclose(a.y, b.y, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(a.state[1:], b.state)
        sp, sq = a.state, b.state
    assert PreisachModel.from_pi(pi, knots).to_dict()["weights"][1] == [pi.weights[0]] * 4


def minor_loop_width(model, bias: float, amp: float = 0.6, top: float = 3.0) -> float:
    """Width at ``u = bias`` of the closed minor loop ``bias ± amp`` after a major sweep."""
    lo, hi = bias - amp, bias + amp
    u = np.concatenate((np.linspace(0, top, 300), np.linspace(top, -top, 600),
                        np.linspace(-top, hi, 300), np.linspace(hi, lo, 300),
                        np.linspace(lo, hi, 401), np.linspace(hi, lo, 401)))
    y = model(u)
    up = y[-802:-401][200]  # at u = bias on the rising branch of the minor loop
    down = y[-401:][200]  # and on the falling branch
    return float(down - up)


def test_minor_loops_at_two_biases_differ_only_with_a_level_dependent_density() -> None:
    width = minor_loop_width
    w_lo, w_hi = width(PREISACH, -1.8), width(PREISACH, 1.8)
    assert w_hi > 2 * w_lo > 0
    flat = PreisachModel.from_pi(PIModel(0.8, [0.5, 1.0, 1.5], [0.2, 0.1, 0.05]), [-1.0, 1.0])
    assert width(flat, -1.8) == pytest.approx(width(flat, 1.8), rel=1e-9)


def test_inverse_is_exact_chunked_and_its_inverse_is_the_model() -> None:
    model = _random_model(7, 4)
    inv = model.inverse()
    assert isinstance(inv, PreisachInverse) and inv.inverse() is model
    rng = np.random.default_rng(8)
    y = rng.normal(size=5000).cumsum() * 0.1  # every output is reachable (a bijection)
    u = inv(y)
    np.testing.assert_allclose(model(u), y, rtol=0, atol=1e-9 * np.ptp(y))
    a = inv.simulate(y[:999])
    b = inv.simulate(y[999:], state=a.state)
    np.testing.assert_array_equal(np.concatenate((a.y, b.y)), u)
    np.testing.assert_array_equal(b.state, model.simulate(u).state)


def test_inverse_of_the_pi_form_matches_the_pi_inverse() -> None:
    pi = PIModel(0.6, [0.4, 0.9, 1.5], [0.3, 0.2, 0.1])
    model = PreisachModel.from_pi(pi, [-1.0, 0.0, 1.0])
    y = 2.5 * np.sin(np.linspace(0, 12 * np.pi, 4000)) * np.linspace(0.2, 1.0, 4000)
    np.testing.assert_allclose(model.inverse()(y), pi.inverse()(y), rtol=0, atol=1e-12)


def test_inverse_rules_are_named() -> None:
    with pytest.raises(NotInvertibleError, match=r"r0 = 0.1 must be 0"):
        PreisachModel([0.1, 0.5], [[1.0], [1.0]]).inverse()
    with pytest.raises(NotInvertibleError, match=r"W0,1 = 0 must be > 0"):
        PreisachModel([0.0, 0.5], [[1.0, 0.0], [1.0, 1.0]], [0.0]).inverse()
    assert not PreisachModel([0.0, 0.5], [[1.0, 0.0], [1.0, 1.0]], [0.0]).is_invertible
    assert PREISACH.is_invertible


def test_output_bound_holds_from_any_state() -> None:
    u = _walk(5000, 4, 2.5)
    assert np.max(np.abs(PREISACH(u))) <= PREISACH.output_bound(2.5)


def test_parameters_are_validated_with_named_rules() -> None:
    with pytest.raises(ParameterError, match=r"weights\[1\]\[2\] = -0.1 is negative; weights "
                                             r"must be >= 0"):
        PreisachModel([0.0, 1.0], [[1.0, 1.0, 1.0], [1.0, 1.0, -0.1]], [0.0, 1.0])
    with pytest.raises(ParameterError, match=r"weights must have shape \(2, 3\)"):
        PreisachModel([0.0, 1.0], [[1.0, 1.0], [1.0, 1.0]], [0.0, 1.0])
    with pytest.raises(ParameterError, match="knots must be strictly increasing"):
        PreisachModel([0.0, 1.0], [[1.0] * 3] * 2, [1.0, 0.0])
    with pytest.raises(ParameterError, match=r"thresholds\[0\] = -1 is negative"):
        PreisachModel([-1.0, 1.0], [[1.0], [1.0]])
    with pytest.raises(ParameterError, match="two-dimensional"):
        PreisachModel([0.0], [1.0])


def test_json_round_trip_and_json_path_errors() -> None:
    for model in (PREISACH, PREISACH.inverse(), PreisachModel([0.0, 1.0], [[1.0], [0.5]])):
        text = ParameterSet.from_model(model).to_json()
        back = load_parameter_set(text).model
        assert back.to_dict() == model.to_dict()
        u = _walk(500, 1)
        np.testing.assert_array_equal(back(u), model(u))
    assert "knots" not in PreisachModel([0.0, 1.0], [[1.0], [0.5]]).to_dict()
    doc = json.loads(ParameterSet.from_model(PREISACH).to_json())
    doc["model"]["weights"][1][2] = -0.5
    with pytest.raises(ParameterSetError, match=r"^model\.weights\[1\]\[2\] = -0.5 is negative"):
        load_parameter_set(doc)
    doc["model"]["weights"][1] = [0.1, 0.2]
    with pytest.raises(ParameterSetError, match=r"^model\.weights\[1\]: has 2 number\(s\) but "
                                                r"model\.weights\[0\] has 3"):
        load_parameter_set(doc)
    doc["model"]["weights"][1] = [0.1, "x", 0.2]
    with pytest.raises(ParameterSetError, match=r"^model\.weights\[1\]\[1\]: must be a number"):
        load_parameter_set(doc)
    doc = json.loads(ParameterSet.from_model(PREISACH.inverse()).to_json())
    doc["model"]["model"]["weights"][0][0] = 0.0
    with pytest.raises(NotInvertibleError, match=r"W0,0 = 0 must be > 0"):
        load_parameter_set(doc)


def test_initial_memory_wraps_a_preisach_model() -> None:
    history = [2.5, -1.5, 0.7]
    mem = InitialMemory(PREISACH, history)
    started = mem.with_state()
    assert isinstance(started, PreisachModel)
    assert started.to_dict()["knots"] == PREISACH.to_dict()["knots"]
    u = _walk(2000, 5)
    # the same as running the virtual history first, then the record
    full = PREISACH(np.concatenate((history, u)))
    np.testing.assert_allclose(mem(u), full[len(history):], rtol=0, atol=1e-14)
    np.testing.assert_array_equal(mem.play_state, PREISACH.simulate(history).state)
    y = 0.9 * mem(u)
    np.testing.assert_allclose(mem(mem.inverse()(y)), y, rtol=0, atol=1e-9 * np.ptp(y))
    back = load_parameter_set(ParameterSet.from_model(mem).to_json()).model
    np.testing.assert_array_equal(back(u), mem(u))


# ----------------------------------------------------------------------------- rate-dependent
def _rd_reference(u: np.ndarray, r: np.ndarray, e: np.ndarray, W: np.ndarray, beta_s: float,
                  dt: float, z0: np.ndarray) -> np.ndarray:
    """Plain Python reference: plays of threshold r_i + beta |u_k - u_(k-1)| / dt (r_i > 0;
    r_i = 0 is the identity), each summed through its level segments."""
    z = np.array(z0, dtype=float)
    out = np.empty(u.size)
    for k in range(u.size):
        extra = beta_s * abs(u[k] - u[k - 1]) / dt if k else 0.0
        acc = 0.0
        for i in range(r.size):
            if r[i] == 0:
                z[i] = u[k]
            else:
                ri = r[i] + extra
                z[i] = min(max(z[i], u[k] - ri), u[k] + ri)
            acc += float(level_segments([z[i]], e)[0] @ W[i])
        out[k] = acc
    return out


def test_rate_dependent_preisach_matches_a_reference_in_chunks_and_inverts() -> None:
    """The rate-dependent Preisach (relay thresholds widened by beta |du/dt|, the reversible
    play untouched) against a plain loop; beta = 0 is the Preisach model; the bisection
    inverse recovers the input; a non-monotone per-sample map is refused by name."""
    m = RateDependentPreisach(PREISACH.thresholds, PREISACH.weights, 2e-4, PREISACH.knots,
                              PREISACH.state0)
    dt = 1e-3
    u = turning_points(3, 1500)
    ref = _rd_reference(u, m.thresholds, m.knots, m.weights, m.beta_s, dt, m.state0)
    y = m(u, dt=dt)
    np.testing.assert_allclose(y, ref, atol=1e-12)
    a = m.simulate(u[:700], dt=dt)
    b = m.simulate(u[700:], dt=dt, state=a.state)
    np.testing.assert_allclose(np.r_[a.y, b.y], y, atol=1e-12)
    # the rate widens the loops: the output differs from the static Preisach
    assert np.max(np.abs(y - PREISACH(u))) > 1e-3
    still = RateDependentPreisach(PREISACH.thresholds, PREISACH.weights, 0.0, PREISACH.knots,
                                  PREISACH.state0)
    np.testing.assert_allclose(still(u, dt=dt), PREISACH(u), atol=1e-12)
    np.testing.assert_allclose(m.inverse()(y, dt=dt), u, atol=1e-9)
    with pytest.raises(NotInvertibleError, match="beta_s/dt"):
        m.inverse()(y, dt=1e-4)  # beta/dt = 2: a play moves against the input
    back = model_from_dict(json.loads(json.dumps(m.inverse().to_dict())))
    np.testing.assert_allclose(back(y, dt=dt), u, atol=1e-9)
    with pytest.raises(ParameterError, match="beta_s"):
        RateDependentPreisach(PREISACH.thresholds, PREISACH.weights, -1e-4, PREISACH.knots)
