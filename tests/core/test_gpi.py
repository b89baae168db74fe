"""Generalized PI models of paper 001 (Examples 4-6), Kuhnen's modified PI, and their inverses."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from core.base import Chain, model_from_dict
from core.deadzone import DeadZoneMap
from core.exceptions import ClippedInputWarning, ParameterError
from core.gpi import (
    DeadZoneGPI,
    ModifiedPI,
    TanhEnvelope,
    TanhEnvelopeInverse,
    TanhGPI,
    paper001_example4,
    paper001_example4_pi,
    paper001_example6,
)
from core.pi import PIModel
from core.reference import pi_output_reference

# ----------------------------------------------------------------------------- strategies
pos = st.floats(0.05, 2.0)


@st.composite
def pi_models(draw: st.DrawFn) -> PIModel:
    n = draw(st.integers(1, 6))
    r = np.cumsum([draw(st.floats(0.05, 1.0)) for _ in range(n)])
    p0 = draw(st.floats(0.1, 2.0))
    # weights may be negative as long as every slope stays positive
    slopes = np.array([p0] + [draw(st.floats(0.1, 3.0)) for _ in range(n)])
    w = np.diff(slopes)
    state0 = draw(st.sampled_from([None, 0.3, -0.7]))
    return PIModel(p0, r, w, state0)


@st.composite
def deadzone_maps(draw: st.DrawFn) -> DeadZoneMap:
    m_neg, m_pos = draw(st.integers(0, 4)), draw(st.integers(0, 4))
    pos_r = np.cumsum([draw(pos) for _ in range(m_pos)])
    neg_r = -np.cumsum([draw(pos) for _ in range(m_neg)])
    s0 = draw(st.floats(0.1, 4.0))
    s_pos = np.array([s0] + [draw(st.floats(0.05, 4.0)) for _ in range(m_pos)])
    s_neg = np.array([s0] + [draw(st.floats(0.05, 4.0)) for _ in range(m_neg)])
    return DeadZoneMap(
        np.concatenate((neg_r[::-1], [0.0], pos_r)),
        np.concatenate((np.diff(s_neg)[::-1], [s0], np.diff(s_pos))),
    )


@st.composite
def envelope_params(draw: st.DrawFn) -> tuple[float, float, float, float]:
    sign = draw(st.sampled_from([1.0, -1.0]))  # a0, a1 share a sign: kappa increasing
    return (
        sign * draw(st.floats(0.5, 8.0)),
        sign * draw(st.floats(0.1, 1.5)),
        draw(st.floats(-0.5, 0.5)),
        draw(st.floats(-2.0, 2.0)),
    )


signals = st.lists(st.floats(-6, 6, allow_nan=False), min_size=1, max_size=60)


def tol(x: np.ndarray) -> float:
    return 1e-9 * max(1.0, float(np.max(np.abs(x))))


def reversal_samples(x: np.ndarray, d0: int = 1) -> np.ndarray:
    """Indices where the direction of ``x`` differs from the previous direction (d0 before x)."""
    d = np.sign(np.diff(x, prepend=x[0]))
    d[0] = d0
    for k in range(1, d.size):  # a repeated sample keeps the direction
        if d[k] == 0:
            d[k] = d[k - 1]
    prev = np.concatenate(([d0], d[:-1]))
    return np.flatnonzero(d != prev)


# ----------------------------------------------------------------------------- paper 001 Ex. 4
def test_example4_inverse_pi_printed_values() -> None:
    """Inverse PI of Example 4 (eq. 36-37) against the printed z_i, q0, q_i.

    Misprint: the paper prints p_i = 0.65 exp(+7.75e-4 r_i); its own printed inverse values
    need the NEGATIVE exponent (seed-notes). With the printed sign z6 would be 6.146 and
    q1 -0.7694, outside the rounding of the printed 6.139 and -0.7691.
    """
    inv = paper001_example4_pi().inverse()
    z = [0.293, 0.877, 1.755, 2.924, 4.386, 6.139]
    q = [-0.7691, -0.2564, -0.1282, -0.0769, -0.0513, -0.0366]
    assert inv.p0 == pytest.approx(1.5385, abs=0.5e-4)
    # z5 = 4.38546 is printed 4.386: double rounding (4.38546 -> 4.3855 -> 4.386), so allow
    # half a unit of the third decimal plus half a unit of the fourth.
    np.testing.assert_allclose(inv.thresholds, z, rtol=0, atol=0.55e-3 + 1e-12)
    np.testing.assert_allclose(inv.weights, q, rtol=0, atol=0.5e-4 + 1e-12)
    # the printed (positive) exponent does not reproduce the printed values
    r = 0.45 * np.arange(7)
    p = 0.65 * np.exp(+7.75e-4 * r)
    wrong = PIModel(p[0], r[1:], p[1:]).inverse()
    assert abs(wrong.thresholds[-1] - 6.139) > 0.55e-3
    assert abs(wrong.weights[0] - (-0.7691)) > 0.5e-4


def test_example4_forward_matches_second_implementation() -> None:
    m = paper001_example4()
    t = np.linspace(0, 1, 801)
    v = 5 * np.sin(2 * np.pi * t)
    # independent: literal dead-zone superposition (41) fed to the numpy PI oracle
    w = m.deadzone.operator_outputs(v) @ m.deadzone.weights
    y_ref, _ = pi_output_reference(w, m.pi.thresholds, m.pi.weights, m.pi.p0, np.zeros(6))
    np.testing.assert_allclose(m(v), y_ref, rtol=0, atol=1e-12)
    # w saturates at gamma(5) = tau_11 + 0.036 * (5 - 3)
    assert w.max() == pytest.approx(m.deadzone.inverse().thresholds[-1] + 0.036 * 2, abs=1e-12)


def test_example4_compensation_is_exact() -> None:
    m = paper001_example4()
    t = np.linspace(0, 1, 1001)
    u = 15 * np.sin(2 * np.pi * t)
    inv = m.inverse()
    assert isinstance(inv, Chain)
    assert [type(s) for s in inv.stages] == [PIModel, DeadZoneMap]
    np.testing.assert_allclose(m(inv(u)), u, rtol=0, atol=1e-9 * 15)


# ----------------------------------------------------------------------------- paper 001 Ex. 6
def test_example6_inverse_envelope_is_printed_formula() -> None:
    """kappa_R^-1 = kappa_L^-1 = 2.5 atanh(x / 6) (Example 6, eq. 58)."""
    m = paper001_example6()
    kinv = m.envelope.inverse()
    x = np.concatenate((np.linspace(-5.9, 5.9, 200), np.linspace(5.9, -5.9, 200)))
    np.testing.assert_allclose(kinv(x), 2.5 * np.arctanh(x / 6), rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(kinv.kappa_r_inv(x), 2.5 * np.arctanh(x / 6), rtol=1e-13)
    v = np.linspace(-5, 5, 11)
    np.testing.assert_allclose(m.envelope(v), 6 * np.tanh(0.4 * v), rtol=1e-15)


def test_example6_compensation() -> None:
    m = paper001_example6()
    t = np.linspace(0, 1, 1001)
    u = 10 * np.sin(2 * np.pi * t)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ClippedInputWarning)  # u = 10 sin stays in the domain
        v = m.inverse()(u)
    np.testing.assert_allclose(m(v), u, rtol=0, atol=1e-9 * 10)


# ----------------------------------------------------------------------------- identities
@settings(max_examples=60, deadline=None)
@given(pi_models(), deadzone_maps(), signals)
def test_deadzone_gpi_inverse_is_two_sided(pi: PIModel, g: DeadZoneMap, u: list[float]) -> None:
    x = np.asarray(u)
    m = DeadZoneGPI(pi, g)
    inv = m.inverse()
    np.testing.assert_allclose(m(inv(x)), x, rtol=0, atol=tol(x))
    np.testing.assert_allclose(inv(m(x)), x, rtol=0, atol=tol(x))


@settings(max_examples=60, deadline=None)
@given(pi_models(), deadzone_maps(), signals)
def test_modified_pi_inverse_is_two_sided(pi: PIModel, g: DeadZoneMap, u: list[float]) -> None:
    x = np.asarray(u)
    m = ModifiedPI(pi, g)
    inv = m.inverse()
    assert [type(s) for s in inv.stages] == [DeadZoneMap, PIModel]
    np.testing.assert_allclose(m(inv(x)), x, rtol=0, atol=tol(x))
    np.testing.assert_allclose(inv(m(x)), x, rtol=0, atol=tol(x))


@settings(max_examples=40, deadline=None)
@given(pi_models(), deadzone_maps(), signals)
def test_cascade_orders(pi: PIModel, g: DeadZoneMap, u: list[float]) -> None:
    """Paper 001 order P[gamma[v]] versus Kuhnen's order S[P[v]]."""
    x = np.asarray(u)
    np.testing.assert_allclose(DeadZoneGPI(pi, g)(x), pi(g(x)), rtol=0, atol=1e-12 * 50)
    np.testing.assert_allclose(ModifiedPI(pi, g)(x), g(pi(x)), rtol=0, atol=1e-12 * 50)


def test_the_two_orders_differ() -> None:
    pi = paper001_example4_pi()
    g = DeadZoneMap.symmetric([1.0], 1.0, [-0.5])
    v = 3 * np.sin(np.linspace(0, 2 * np.pi, 200))
    assert np.max(np.abs(DeadZoneGPI(pi, g)(v) - ModifiedPI(pi, g)(v))) > 0.5


@settings(max_examples=60, deadline=None)
@given(pi_models(), envelope_params(), st.lists(st.floats(-1, 1), min_size=1, max_size=60))
def test_tanh_gpi_equal_branches_two_sided(pi: PIModel, a: tuple, s: list[float]) -> None:
    """kappa_R = kappa_L: both identities hold at every sample."""
    env = TanhEnvelope(a, a)
    m = TanhGPI(pi, env)
    inv = m.inverse()
    # envelope inputs with |a1 v + a2| <= 3 (atanh stays well conditioned)
    v = (3 * np.asarray(s) - a[2]) / a[1]
    v = np.clip(v, (-3 - a[2]) / abs(a[1]), (3 - a[2]) / abs(a[1]))
    np.testing.assert_allclose(inv(m(v)), v, rtol=0, atol=tol(v) * 10)
    # references u inside the image: u = P[x] with x in the inverse envelope's domain
    x = a[3] + 0.95 * abs(a[0]) * np.asarray(s)
    u = pi(x)
    np.testing.assert_allclose(m(inv(u)), u, rtol=0, atol=tol(u))


@st.composite
def ordered_envelopes(draw: st.DrawFn) -> tuple[tuple, tuple]:
    """(lower, upper) branches with lower(v) <= upper(v) for every v."""
    c0, c1 = draw(st.floats(1.0, 8.0)), draw(st.floats(0.1, 1.5))
    c2, c3 = draw(st.floats(-0.5, 0.5)), draw(st.floats(-2.0, 2.0))
    d2, d3 = draw(st.floats(0.0, 0.5)), draw(st.floats(0.0, 0.4))
    assume(d2 + d3 > 1e-3)
    lower = (c0, c1, c2, c3)
    upper = (c0, c1, c2 + d2, c3 + d3 * c0)
    return lower, upper


@settings(max_examples=60, deadline=None)
@given(pi_models(), ordered_envelopes(), st.lists(st.floats(-1, 1), min_size=2, max_size=60))
def test_tanh_gpi_counterclockwise_envelope(pi: PIModel, env: tuple, s: list[float]) -> None:
    """kappa_R <= kappa_L: Pi o Pi^-1 = id at every sample; Pi^-1 o Pi = id except at reversals."""
    lower, upper = env
    m = TanhGPI(pi, TanhEnvelope(lower, upper))
    inv = m.inverse()
    c0, c1, c2, c3 = lower
    # x inside both inverse domains: (c3 + d3 - c0, c3 + c0)
    lo, hi = max(lower[3], upper[3]) - c0, min(lower[3], upper[3]) + c0
    x = 0.5 * (lo + hi) + 0.45 * (hi - lo) * np.asarray(s)
    u = pi(x)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ClippedInputWarning)
        vv = inv(u)
    np.testing.assert_allclose(m(vv), u, rtol=0, atol=tol(u))

    v = (2.5 * np.asarray(s) - c2) / c1
    # held inputs after a reversal keep the mismatch; steps below the rounding level of the
    # envelope (e.g. 1e-63 after 0) make the direction of the envelope output undefined
    assume(np.all(np.abs(np.diff(v)) > 1e-9 * (1 + np.abs(v[1:]))))
    with warnings.catch_warnings():
        # at a mismatched reversal kappa_R^-1 may see kappa_L(v) outside its domain
        warnings.simplefilter("ignore", ClippedInputWarning)
        back = inv(m(v))
    ok = np.ones(v.size, dtype=bool)
    ok[reversal_samples(v)] = False
    np.testing.assert_allclose(back[ok], v[ok], rtol=0, atol=tol(v) * 10)


@settings(max_examples=60, deadline=None)
@given(pi_models(), ordered_envelopes(), st.lists(st.floats(-1, 1), min_size=2, max_size=60))
def test_tanh_gpi_clockwise_envelope(pi: PIModel, env: tuple, s: list[float]) -> None:
    """kappa_R >= kappa_L: Pi^-1 o Pi = id everywhere; kappa o kappa^-1 = id except at
    reversals, so Pi o Pi^-1 is exact up to the first reversal of x = P^-1[u]."""
    lower, upper = env
    envelope = TanhEnvelope(upper, lower)  # rising branch above the falling one
    m = TanhGPI(pi, envelope)
    inv = m.inverse()
    c0, c1, c2, c3 = lower
    v = (2.5 * np.asarray(s) - c2) / c1
    # steps below the rounding level of the envelope (e.g. 5.6e-16 after 0) make the
    # direction of the envelope output undefined (as in the test above)
    assume(np.all(np.abs(np.diff(v)) > 1e-9 * (1 + np.abs(v[1:]))))
    np.testing.assert_allclose(inv(m(v)), v, rtol=0, atol=tol(v) * 10)

    lo, hi = max(lower[3], upper[3]) - c0, min(lower[3], upper[3]) + c0
    x = 0.5 * (lo + hi) + 0.45 * (hi - lo) * np.asarray(s)
    assume(np.all(np.diff(x) != 0))
    rev = reversal_samples(x)
    ok = np.ones(x.size, dtype=bool)
    ok[rev] = False
    np.testing.assert_allclose(envelope(envelope.inverse()(x))[ok], x[ok], rtol=0, atol=tol(x))
    u = pi(x)
    first = rev[0] if rev.size else u.size
    np.testing.assert_allclose(m(inv(u))[:first], u[:first], rtol=0, atol=tol(u))


def test_counterclockwise_mismatch_happens_exactly_at_reversals() -> None:
    """The documented failure is real: with kappa_L = kappa_R + 1, Pi^-1 o Pi is wrong at the
    two reversals of one sine period and exact everywhere else."""
    k = (6.0, 0.4, 0.0, 0.0)
    m = TanhGPI(paper001_example4_pi(), TanhEnvelope((6.0, 0.4, 0.0, -0.5), (6.0, 0.4, 0.0, 0.5)))
    t = np.linspace(0, 1, 1000, endpoint=False)
    v = 5 * np.sin(2 * np.pi * t)
    # at the two mismatched reversals kappa_R^-1 sees kappa_L(v) ~ 6.28, outside its domain
    with pytest.warns(ClippedInputWarning, match=r"2 of 1000 samples"):
        back = m.inverse()(m(v))
    bad = np.flatnonzero(np.abs(back - v) > 1e-9)
    np.testing.assert_array_equal(bad, reversal_samples(v))
    assert bad.size == 2
    # the compensator itself is exact in this (counter-clockwise) case
    u = 10 * np.sin(2 * np.pi * t)
    np.testing.assert_allclose(m(m.inverse()(u)), u, rtol=0, atol=1e-8)
    # with equal branches there is no mismatch at all
    m2 = TanhGPI(paper001_example4_pi(), TanhEnvelope(k, k))
    np.testing.assert_allclose(m2.inverse()(m2(v)), v, rtol=0, atol=1e-9)


def test_clockwise_compensation_error_starts_at_first_reversal_and_persists() -> None:
    """kappa_R = kappa_L + 1: the wrong h at the reversal enters the PI memory."""
    pi = paper001_example4_pi()
    m = TanhGPI(pi, TanhEnvelope((6.0, 0.4, 0.0, 0.5), (6.0, 0.4, 0.0, -0.5)))
    t = np.linspace(0, 1, 1000, endpoint=False)
    u = 10 * np.sin(2 * np.pi * t)
    err = np.abs(m(m.inverse()(u)) - u)
    rev = reversal_samples(pi.inverse()(u))
    bad = np.flatnonzero(err > 1e-9)
    assert bad[0] == rev[0]
    assert bad.size > 100  # not just the reversal samples: the PI remembers the jump
    assert err.max() > 1.0


# ----------------------------------------------------------------------------- envelope
def test_envelope_switches_on_input_direction_and_holds() -> None:
    env = TanhEnvelope((1.0, 1.0, 0.0, 0.0), (1.0, 1.0, 0.0, 0.5))
    v = np.array([0.0, 1.0, 1.0, 0.5, 0.5, 0.7])
    h = env(v)
    kr, kl = np.tanh(v), np.tanh(v) + 0.5
    # sample 0: no history, direction0 = +1 -> kappa_R; samples 2 and 4 are held
    expected = np.array([kr[0], kr[1], kr[2], kl[3], kl[4], kr[5]])
    np.testing.assert_allclose(h, expected, rtol=1e-15)
    env_down = TanhEnvelope(env.a, env.b, direction0=-1)
    assert env_down([0.0])[0] == pytest.approx(0.5)


@pytest.mark.parametrize(
    "model",
    [
        paper001_example4(),
        ModifiedPI(paper001_example4_pi(), DeadZoneMap.symmetric([2.0, 5.0], 1.0, [-0.3, -0.4])),
        paper001_example6(),
        TanhGPI(paper001_example4_pi(), TanhEnvelope((6, 0.4, 0, -0.5), (6, 0.4, 0.1, 0.5))),
        TanhEnvelope((6, 0.4, 0, -0.5), (6, 0.4, 0.1, 0.5)),
    ],
    ids=["gpi-deadzone", "mpi", "gpi-tanh", "gpi-tanh-asym", "tanh-envelope"],
)
# the noisy input makes the asymmetric inverse clip at mismatched reversals; clipping is
# deterministic per sample, so chunking must still reproduce it exactly
@pytest.mark.filterwarnings("ignore::core.exceptions.ClippedInputWarning")
def test_chunked_simulation_equals_one_call(model, rng: np.random.Generator) -> None:
    t = np.linspace(0, 2, 700)
    v = 4 * np.sin(2 * np.pi * t) * np.exp(-0.3 * t) + 0.3 * rng.standard_normal(t.size)
    v[100:110] = v[100]  # a held stretch
    full = model.simulate(v)
    inv = model.inverse()
    u = full.y
    for model_, signal in ((model, v), (inv, u)):
        whole = model_(signal)
        state = None
        parts = []
        for a, b in ((0, 1), (1, 233), (233, 233), (233, 600), (600, 700)):
            r = model_.simulate(signal[a:b], state=state)
            parts.append(r.y)
            state = r.state
        np.testing.assert_array_equal(np.concatenate(parts), whole)


# ----------------------------------------------------------------------------- serialisation
@pytest.mark.parametrize(
    "model",
    [
        paper001_example4(),
        ModifiedPI(PIModel(0.5, [0.3, 1.0], [0.2, -0.1], 0.4), DeadZoneMap([-1, 0, 2], [1, 2, -1])),
        paper001_example6(),
        TanhGPI(paper001_example4_pi(), TanhEnvelope((-6, -0.4, 0, 1), (6, 0.3, 0.1, 0.5), -1)),
        TanhEnvelopeInverse((6, 0.4, 0, 0), (5, 0.4, 0, 0), -1, 1e-6),
    ],
    ids=["gpi-deadzone", "mpi", "gpi-tanh", "gpi-tanh-asym", "tanh-inverse"],
)
def test_to_dict_round_trip(model) -> None:
    d = json.loads(json.dumps(model.to_dict()))
    assert d["type"] == model.type_name
    back = model_from_dict(d)
    assert type(back) is type(model)
    assert back.to_dict() == model.to_dict()
    v = np.linspace(-3, 3, 41)
    v = np.concatenate((v, v[::-1]))
    np.testing.assert_array_equal(back(v), model(v))


# ----------------------------------------------------------------------------- errors
@pytest.mark.parametrize(
    ("a", "b", "match"),
    [
        ((6, 0.4, 0), (6, 0.4, 0, 0), r"a must hold 4 numbers"),
        ((6, 0.4, 0, 0), (6, 0.4, 0, 0, 1), r"b must hold 4 numbers"),
        ((0, 0.4, 0, 0), (6, 0.4, 0, 0), r"a0 = 0 makes kappa_R constant"),
        ((6, 0.4, 0, 0), (6, 0, 0, 0), r"b1 = 0 makes kappa_L constant"),
        ((6, -0.4, 0, 0), (6, 0.4, 0, 0), r"kappa_R must be increasing: a0 \* a1 = -2.4"),
        ((6, 0.4, 0, 0), (-6, 0.4, 0, 0), r"kappa_L must be increasing: b0 \* b1"),
        ((6, np.nan, 0, 0), (6, 0.4, 0, 0), r"a\[1\] = nan is not finite"),
        ((), (6, 0.4, 0, 0), r"a must have at least 1"),
    ],
)
def test_bad_tanh_parameters(a: tuple, b: tuple, match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        TanhEnvelope(a, b)
    with pytest.raises(ParameterError, match=match):
        TanhEnvelopeInverse(a, b)


def test_bad_direction_margin_and_state() -> None:
    k = (6, 0.4, 0, 0)
    with pytest.raises(ParameterError, match="initial direction must be"):
        TanhEnvelope(k, k, direction0=0)
    with pytest.raises(ParameterError, match="clip_margin = 1 must be < 1"):
        TanhEnvelopeInverse(k, k, clip_margin=1.0)
    with pytest.raises(ParameterError, match="clip_margin = 0 must be > 0"):
        TanhEnvelopeInverse(k, k, clip_margin=0.0)
    with pytest.raises(ParameterError, match=r"state must be \(previous input, direction"):
        TanhEnvelope(k, k).simulate([1.0], state=3.0)


def test_bad_cascade_parts() -> None:
    pi = paper001_example4_pi()
    g = DeadZoneMap.symmetric([1.0], 1.0, [-0.5])
    env = TanhEnvelope((6, 0.4, 0, 0), (6, 0.4, 0, 0))
    with pytest.raises(ParameterError, match=r"gpi-deadzone.deadzone must be a DeadZoneMap"):
        DeadZoneGPI(pi, env)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"mpi.pi must be a PIModel"):
        ModifiedPI(g, g)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"gpi-tanh.envelope must be a TanhEnvelope"):
        TanhGPI(pi, g)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"gpi-tanh model is missing field 'envelope'"):
        model_from_dict({"type": "gpi-tanh", "pi": pi.to_dict()})
    with pytest.raises(ParameterError, match=r"gpi-deadzone.deadzone must be a DeadZoneMap"):
        model_from_dict({"type": "gpi-deadzone", "pi": pi.to_dict(), "deadzone": pi.to_dict()})


# ----------------------------------------------------------------------------- clipping
def test_inverse_envelope_clips_outside_domain_and_warns() -> None:
    kinv = TanhEnvelopeInverse((6, 0.4, 0, 1), (6, 0.4, 0, 1))  # domain -5 < x < 7
    x = np.array([0.0, 6.9, 7.0, 9.0, 3.0, -5.0])
    with pytest.warns(ClippedInputWarning, match=r"3 of 6 samples.*-5 < x < 7") as rec:
        v = kinv(x)
    assert "rising branch" in str(rec[0].message) and "falling branch" in str(rec[0].message)
    assert np.all(np.isfinite(v))
    edge = np.arctanh(1 - 1e-9) / 0.4
    np.testing.assert_allclose(v[[2, 3]], edge, rtol=1e-12)
    assert v[5] == pytest.approx(-edge, rel=1e-12)
    np.testing.assert_allclose(v[[0, 1, 4]], np.arctanh((x[[0, 1, 4]] - 1) / 6) / 0.4, rtol=1e-12)


def test_gpi_inverse_warns_when_reference_is_out_of_reach() -> None:
    m = paper001_example6()  # kappa saturates at +-6, so P[kappa] is bounded
    u = np.array([0.0, 10.0, 60.0, 0.0])
    with pytest.warns(ClippedInputWarning, match=r"1 of 4 samples"):
        m.inverse()(u)
