"""Classical PI identification: parameter recovery, invertibility, streaming equivalence."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from core.exceptions import FitWarning, NotFittedError, ParameterError
from core.fitting.gram import Segment, solve_constrained, stream_gram, stream_tsqr
from core.fitting.pi import PIRegressor, fit_linear_pi
from core.fitting.thresholds import place_thresholds, reversal_indices
from core.operators import play_bank
from core.pi import PIModel


def _tapered(n: int = 6000, amp: float = 2.0, cycles: float = 12.0) -> np.ndarray:
    """Sine with a decaying then growing amplitude: nested reversals of many sizes."""
    t = np.linspace(0.0, 1.0, n)
    env = 0.25 + 0.75 * np.abs(np.cos(np.pi * t))
    return amp * env * np.sin(2 * np.pi * cycles * t)


def _design(u: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Dense design [1, u, Z] with plays relaxed at u[0] (independent of the streaming code)."""
    Z, _ = play_bank(u, r, np.full(r.size, u[0]))
    return np.column_stack((np.ones(u.size), u, Z))


TRUE = PIModel(0.6, [0.3, 0.6, 0.9, 1.2, 1.5], [0.5, 0.3, 0.0, 0.2, 0.1])


def test_recovers_weights_and_offset_within_standard_errors(rng):
    u = _tapered()
    y_clean = PIModel(TRUE.p0, TRUE.thresholds, TRUE.weights, np.full(5, u[0]))(u) + 0.7
    sigma = 0.01  # 0.25 % of the output range
    y = y_clean + sigma * rng.normal(size=u.size)
    est = PIRegressor(thresholds=TRUE.thresholds, validation=0.0).fit(u, y)
    # tolerance: 5 standard errors of the unconstrained least-squares estimate
    A = _design(u, TRUE.thresholds)
    se = sigma * np.sqrt(np.diag(np.linalg.inv(A.T @ A)))
    got = np.concatenate(([est.offset_, est.p0_], est.weights_))
    want = np.concatenate(([0.7, TRUE.p0], TRUE.weights))
    assert np.all(np.abs(got - want) <= 5 * se + 1e-12), (got, want, se)
    assert est.report_.train.rmse == pytest.approx(sigma, rel=0.1)
    assert est.model_.is_invertible


def test_noise_free_exact_recovery_and_predict():
    u = _tapered(3000)
    m = PIModel(TRUE.p0, TRUE.thresholds, TRUE.weights, np.full(5, u[0]))
    est = PIRegressor(thresholds=TRUE.thresholds).fit(u, m(u) - 2.0)
    np.testing.assert_allclose(est.weights_, TRUE.weights, atol=1e-9)
    assert est.p0_ == pytest.approx(TRUE.p0, abs=1e-9)
    assert est.offset_ == pytest.approx(-2.0, abs=1e-9)
    np.testing.assert_allclose(est.predict(u), m(u) - 2.0, atol=1e-9)
    assert est.report_.test is not None and est.report_.test.rmse < 1e-9


def test_selects_number_of_operators_sensibly(rng):
    u = _tapered(8000)
    r10 = place_thresholds([u], 10, "uniform")
    w = 0.4 * np.exp(-np.arange(10) / 4.0)
    true = PIModel(0.3, r10, w, np.full(10, u[0]))
    y = true(u) + 0.002 * rng.normal(size=u.size)
    est = PIRegressor(thresholds="uniform").fit(u, y)
    scores = est.cv_scores_
    # n = 5 misses most of the true thresholds: clearly worse than the best
    assert scores[5] > 1.05 * min(s for s in scores.values() if s is not None)
    # the smallest adequate n is the true one (20, 30, 40 contain the same thresholds)
    assert est.n_operators_ == 10
    assert est.report_.extra["cv_rmse"][10] == pytest.approx(scores[10])


def test_several_recordings_restart_operator_states():
    t = np.linspace(0, 1, 2000)
    u1 = 1.5 * np.sin(2 * np.pi * 3 * t)
    u2 = 1.0 + 0.8 * np.sin(2 * np.pi * 5 * t + 1.0)  # starts elsewhere: new relaxed state
    ys = [PIModel(TRUE.p0, TRUE.thresholds, TRUE.weights, np.full(5, x[0]))(x) for x in (u1, u2)]
    est = PIRegressor(thresholds=TRUE.thresholds).fit([u1, u2], ys)
    np.testing.assert_allclose(est.weights_, TRUE.weights, atol=1e-9)
    pred = est.predict([u1, u2])
    assert isinstance(pred, list) and len(pred) == 2
    np.testing.assert_allclose(pred[1], ys[1], atol=1e-9)
    # one concatenated record would carry the state across the join: a different problem
    joined = PIRegressor(thresholds=TRUE.thresholds).fit(np.r_[u1, u2], np.r_[ys[0], ys[1]])
    assert joined.report_.train.rmse > 1e-6


def test_streaming_gram_matches_dense_and_chunk_size_does_not_matter(rng):
    u = _tapered(20000) + 0.01 * rng.normal(size=20000)
    y = TRUE(u) + 0.01 * rng.normal(size=u.size)
    r = TRUE.thresholds
    A = np.column_stack((_design(u, r), y))
    G_dense = A.T @ A
    for chunk in (1000, 8192, 50000):
        G = stream_gram([Segment(u, y)], r, chunk=chunk)[0]
        # same columns [1, u, z_1..z_n, y]
        np.testing.assert_allclose(G, G_dense, rtol=1e-12, atol=1e-9)
    R = stream_tsqr([Segment(u, y)], r, chunk=3000)
    np.testing.assert_allclose(R.T @ R, G_dense, rtol=1e-10, atol=1e-7)


def test_streamed_solution_equals_dense_nnls(rng):
    import scipy.optimize

    u = _tapered(30000)
    y = TRUE(np.asarray(u)) + 0.02 * rng.normal(size=u.size)
    r = np.linspace(0.2, 1.8, 9)
    eps = 1e-3
    est = PIRegressor(thresholds=r, include_offset=False, min_slope=eps, validation=0.0)
    est.fit(u, y)
    # dense reference: p0 = eps + p0', everything non-negative, no offset
    A = _design(u, r)[:, 1:]
    x, _ = scipy.optimize.nnls(A, y - eps * u)
    ref = np.concatenate(([x[0] + eps], x[1:]))
    got = np.concatenate(([est.p0_], est.weights_))
    np.testing.assert_allclose(got, ref, rtol=1e-8, atol=1e-8 * np.abs(ref).max())
    np.testing.assert_allclose(est.predict(u), A @ ref, rtol=0, atol=1e-8)
    # Gram path and TSQR path of the solver agree as well
    G = stream_gram([Segment(u, y)], r)[0]
    lower = np.r_[-np.inf, eps, np.zeros(r.size)]
    a = solve_constrained(lower, gram=G)
    b = solve_constrained(lower, factor=stream_tsqr([Segment(u, y)], r))
    np.testing.assert_allclose(a.theta, b.theta, rtol=1e-8, atol=1e-9)
    assert a.sse == pytest.approx(b.sse, rel=1e-8)


def test_slope_constraint_fits_saturating_loops():
    """Negative weights (concave loading curve) with positive slopes: still invertible."""
    u = _tapered(4000)
    sat = PIModel(1.0, [0.3, 0.6, 0.9], [-0.3, -0.3, -0.2], np.full(3, u[0]))
    assert sat.is_invertible
    y = sat(u)
    est = PIRegressor(thresholds=sat.thresholds, constraint="slopes").fit(u, y)
    np.testing.assert_allclose(est.weights_, sat.weights, atol=1e-9)
    # the loop runs clockwise (concave branches), so the non-negative rule is applied to stop
    # operators (k = 0.2, w = 0.3, 0.3, 0.2 >= 0): it fits the same weights
    hard = PIRegressor(thresholds=sat.thresholds, constraint="nonnegative").fit(u, y)
    assert hard.orientation_.clockwise and hard.constraint_ == "stop"
    np.testing.assert_allclose(hard.weights_, sat.weights, atol=1e-9)
    # play operators with p_i >= 0 (the counter-clockwise rule) cannot follow it
    fit = fit_linear_pi([Segment(u, y)], sat.thresholds, min_slope=hard.min_slope_,
                        constraint="nonnegative")
    assert np.sqrt(fit.sse / u.size) > 100 * est.report_.train.rmse + 1e-6


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 2**31 - 1),
    n=st.integers(1, 12),
    constraint=st.sampled_from(["nonnegative", "slopes"]),
)
def test_any_data_gives_an_invertible_model(seed, n, constraint):
    g = np.random.default_rng(seed)
    N = 300
    u = np.cumsum(g.normal(size=N))
    y = g.normal(size=N) * g.uniform(0.1, 10) + g.normal() * u
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        est = PIRegressor(n_operators=n, constraint=constraint).fit(u, y)
    m = est.model_
    assert m.p0 > 0 and m.is_invertible
    assert np.all(m.slopes >= est.min_slope_ * (1 - 1e-9))
    # driving the model through its own inverse reproduces the target to round-off
    scale = float(np.max(np.abs(y - est.offset_))) + 1.0
    assert est.report_.compensation_max_abs <= 1e-8 * scale * max(1.0, 1.0 / m.p0)
    yd = y[:50]
    np.testing.assert_allclose(
        est.predict(est.compensate(yd)), yd, atol=1e-8 * scale * max(1.0, 1.0 / m.p0)
    )


def test_report_is_json_ready_and_states_ranges():
    u = _tapered(3000)
    est = PIRegressor(n_operators=5).fit(u, TRUE(u))
    d = est.report_.to_dict()
    json.dumps(d)
    assert d["model_type"] == "pi"
    assert d["test"]["output_range"] > 0 and d["train"]["n_samples"] == 2400
    assert "RMSE" in est.report_.summary()


def test_warns_when_slope_hits_its_bound(rng):
    u = _tapered(3000)
    y = PIModel(1e-9, [0.5, 1.0], [1.0, 0.5])(u)  # p0 ~ 0: true model barely invertible
    with pytest.warns(FitWarning, match="lower bound"):
        est = PIRegressor(thresholds=[0.5, 1.0]).fit(u, y)
    assert est.p0_ == pytest.approx(est.min_slope_)


@pytest.mark.parametrize(
    ("u", "y", "match"),
    [
        (np.arange(100.0), np.arange(99.0), "100 samples but y has 99"),
        (np.arange(10.0), np.arange(10.0), "too few training samples"),
        (np.ones(200), np.arange(200.0), "u is constant"),
        (np.r_[np.arange(100.0), np.nan], np.arange(101.0), r"u\[100\] = nan"),
        (np.sin(np.arange(200.0)), np.ones(200), "y is constant"),
        ([np.arange(50.0)], np.arange(50.0), "recording"),
    ],
)
def test_bad_inputs_name_the_problem(u, y, match):
    with pytest.raises(ParameterError, match=match):
        PIRegressor(n_operators=3).fit(u, y)


def test_bad_settings_and_not_fitted():
    u = _tapered(1000)
    with pytest.raises(NotFittedError):
        PIRegressor().predict(u)
    with pytest.raises(ParameterError, match="strictly increasing"):
        PIRegressor(thresholds=[0.5, 0.2]).fit(u, TRUE(u))
    with pytest.raises(ParameterError, match="uniform"):
        PIRegressor(n_operators=3, thresholds="log").fit(u, TRUE(u))
    with pytest.raises(ParameterError, match="constraint"):
        PIRegressor(n_operators=3, constraint="free").fit(u, TRUE(u))
    with pytest.raises(ParameterError, match="overlap"):
        m = np.ones(u.size, dtype=bool)
        PIRegressor(n_operators=3).fit(u, TRUE(u), train=m, test=m)


def test_threshold_placement_rules():
    t = np.linspace(0, 4, 4000)
    sine = 2.0 * np.cos(2 * np.pi * t)  # starts at a peak: every travel is 4
    r_u = place_thresholds([sine], 8, "uniform")
    np.testing.assert_allclose(r_u, 0.9 * 2.0 * np.arange(1, 9) / 8, rtol=1e-3)
    # constant amplitude: quantiles of the travel mixture are uniform on [0, A]
    r_q = place_thresholds([sine], 8, "quantile")
    np.testing.assert_allclose(r_q, 2.0 * np.arange(1, 9) / 9, rtol=2e-3)
    # tapered record: more small loops, so quantile thresholds crowd at small r
    r_t = place_thresholds([_tapered()], 8, "quantile")
    assert np.all(np.diff(r_t) > 0) and r_t[3] < 0.5 * r_t[-1]
    # reversal detection ignores noise smaller than the tolerance
    noisy = sine + 1e-4 * np.random.default_rng(0).normal(size=sine.size)
    assert reversal_indices(noisy, 1e-2).size == 8  # start (a peak) + 7 inner turning points


def test_too_few_samples_for_cross_validation_falls_back_with_warning():
    u = _tapered(33)  # 26 training samples: fits n = 5, too few for 5-block CV
    with pytest.warns(FitWarning, match="cross-validation"):
        est = PIRegressor().fit(u, TRUE(u))
    assert est.n_operators_ == 5 and est.model_.is_invertible


def test_full_model_json_round_trip_reproduces_predictions(rng):
    from core.base import model_from_dict

    u = _tapered(3000)
    y = TRUE(u) + 0.5 + 0.01 * rng.normal(size=u.size)
    est = PIRegressor(n_operators=8).fit(u, y)
    doc = json.loads(json.dumps(est.full_model_.to_dict()))
    assert [s["type"] for s in doc["stages"]] == ["pi", "offset"]
    loaded = model_from_dict(doc)
    np.testing.assert_allclose(loaded(u), est.predict(u), atol=1e-12)
    np.testing.assert_allclose(loaded(loaded.inverse()(y)), y, atol=1e-9)


def test_blocked_cv_scores_equal_refits_on_transformed_columns(rng):
    """``_cv_sse`` against its definition: for each block, solve on the other blocks' rows
    with the columns transformed (``X T``: loop-segment slopes) and score the left-out rows;
    the batched ``T^T G_b T`` must give the same sum (a 4-block, 6-operator problem)."""
    from core.fitting.pi import _cv_sse, constraint_transform

    n, blocks = 6, 4
    T, lower = constraint_transform(n, 0, 1e-3, "slopes")
    Xs = []
    for _ in range(blocks):
        X = np.column_stack([np.ones(50), rng.normal(size=(50, n + 1)), rng.normal(size=50)])
        X[:, -1] += X[:, 1:-1].sum(axis=1)  # an output the columns explain, plus noise
        Xs.append(X)
    gram = np.stack([X.T @ X for X in Xs] + [np.zeros((n + 3, n + 3))])
    ref = 0.0
    for b in range(blocks):
        A = np.vstack([X for j, X in enumerate(Xs) if j != b]) @ T
        theta = solve_constrained(lower, gram=A.T @ A).theta
        r = (Xs[b] @ T)[:, :-1] @ theta - Xs[b][:, -1]
        ref += float(r @ r)
    assert _cv_sse(gram, blocks, lower, T) == pytest.approx(ref, rel=1e-9)


@pytest.mark.parametrize("n_operators", [None, 6])
def test_the_fit_streams_no_gram_of_its_held_out_rows_and_finds_the_same(n_operators, rng,
                                                                          monkeypatch):
    """The weights are solved on the training blocks' Gram matrices only, so the fit no longer
    streams one for the held-out label (its rows are scored by simulation). Against the
    fit that streams it too (every ``stream_gram`` call given one label more, the computation
    before): bit for bit the same model, cross-validation scores and report, by
    cross-validation (``None``) and with a fixed number of operators."""
    import core.fitting.pi as pi

    u = _tapered(9000) + 0.01 * rng.normal(size=9000)
    y = TRUE(u) + 0.01 * rng.normal(size=u.size)
    test = np.arange(u.size) >= 6000
    streamed: list[int] = []
    original = pi.stream_gram

    def counted(*args, n_labels, **kwargs):
        streamed.append(n_labels)
        return original(*args, n_labels=n_labels, **kwargs)

    monkeypatch.setattr(pi, "stream_gram", counted)
    fast = PIRegressor(n_operators=n_operators).fit(u, y, train=~test, test=test)
    k = 1 if n_operators else fast.cv_blocks  # the training labels 0..k-1; k is held out
    assert streamed and set(streamed) == {k}

    def with_held_out(*args, n_labels, **kwargs):
        return original(*args, n_labels=n_labels + 1, **kwargs)

    monkeypatch.setattr(pi, "stream_gram", with_held_out)
    before = PIRegressor(n_operators=n_operators).fit(u, y, train=~test, test=test)
    assert json.dumps(fast.full_model_.to_dict()) == json.dumps(before.full_model_.to_dict())
    assert fast.cv_scores_ == before.cv_scores_
    assert json.dumps(fast.report_.to_dict(), sort_keys=True) == json.dumps(
        before.report_.to_dict(), sort_keys=True)
