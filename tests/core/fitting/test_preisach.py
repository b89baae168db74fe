"""PreisachRegressor: the level-dependent density is recovered where the PI fit cannot follow."""

from __future__ import annotations

import numpy as np
import pytest

from core.exceptions import NotFittedError, ParameterError
from core.fitting import PIRegressor, PreisachRegressor
from core.models import estimator_class, fit_kinds
from core.pi import PIModel
from core.preisach import PreisachModel
from tests.core.test_preisach import _walk, minor_loop_width

#: Measurement noise of the synthetic recording (output units).
SIGMA = 0.005


@pytest.fixture(scope="module")
def tilted() -> tuple[PreisachModel, np.ndarray, np.ndarray]:
    """A plant whose relay density grows along (alpha+beta)/2, and a noisy recording of it."""
    rr = np.linspace(0.25, 2.5, 10)
    lev = np.array([-1.0, -1 / 3, 1 / 3, 1.0])
    W = np.concatenate(([0.6], 0.3 * np.exp(-rr)))[:, None] * np.ones((11, 4))
    W[1:] *= 1 + 0.8 * lev
    truth = PreisachModel(np.concatenate(([0.0], rr)), W, [-1.5, 0.0, 1.5])
    u = _walk(40_000, 3)
    y = truth(u) + SIGMA * np.random.default_rng(1).normal(size=u.size)
    return truth, u, y


def test_predict_before_fit_raises() -> None:
    with pytest.raises(NotFittedError, match="not fitted yet"):
        PreisachRegressor().predict(np.zeros(10))


def test_reaches_the_noise_floor_where_the_pi_fit_does_not(tilted) -> None:
    truth, u, y = tilted
    pre = PreisachRegressor(n_thresholds=20).fit(u, y)  # 4 uniform levels (default)
    pi = PIRegressor(n_operators=20).fit(u, y)  # the same threshold resolution
    assert isinstance(pre.model_, PreisachModel) and pre.model_.is_invertible
    assert pre.model_.n == 21 and pre.model_.n_segments == 4
    assert (pre.weights_ >= 0).all() and (pre.weights_[0] >= pre.min_slope_).all()
    rmse_pre, rmse_pi = pre.report_.test.rmse, pi.report_.test.rmse
    assert rmse_pre < 1.3 * SIGMA  # the noise floor, up to the grid mismatch
    assert rmse_pi > 10 * rmse_pre
    assert pre.report_.compensation_max_abs < 1e-9 * np.ptp(y)
    # the minor loops at low and high bias differ in width as in the truth; PI's cannot
    w_true = [minor_loop_width(truth, b) for b in (-1.8, 1.8)]
    w_pre = [minor_loop_width(pre.model_, b) for b in (-1.8, 1.8)]
    w_pi = [minor_loop_width(pi.model_, b) for b in (-1.8, 1.8)]
    assert w_true[1] > 2 * w_true[0]
    np.testing.assert_allclose(w_pre, w_true, rtol=0.1)
    assert w_pi[1] == pytest.approx(w_pi[0], rel=1e-9)
    # predict adds the offset and starts relaxed at u[0], like the PI estimator
    np.testing.assert_allclose(pre.predict(u[:500]), pre.full_model_(u[:500]), atol=1e-12)


def test_one_level_segment_is_the_pi_fit() -> None:
    t = np.linspace(0, 3, 3000)
    u = 2 * np.sin(2 * np.pi * t) * np.minimum(1, t)
    y = PIModel(0.5, [0.4, 0.8, 1.2], [0.3, 0.2, 0.1])(u) + 1.0
    est = PreisachRegressor(thresholds=[0.4, 0.8, 1.2], n_levels=1).fit(u, y)
    assert est.offset_ == pytest.approx(1.0, abs=1e-9)
    np.testing.assert_allclose(est.weights_[:, 0], [0.5, 0.3, 0.2, 0.1], atol=1e-9)


def test_is_a_fit_kind_with_named_option_errors() -> None:
    assert "preisach" in fit_kinds() and estimator_class("preisach") is PreisachRegressor
    u = _walk(3000, 2)
    y = PIModel(0.6, [0.5, 1.0], [0.3, 0.2])(u)
    assert PreisachRegressor(n_operators=3).fit(u, y).n_thresholds_ == 3
    with pytest.raises(ParameterError, match="constraint must be 'nonnegative' or 'slopes'"):
        PreisachRegressor(constraint="free").fit(u, y)
    same = PreisachRegressor(n_thresholds=4, constraint="slopes").fit(u, y)
    np.testing.assert_array_equal(same.weights_, PreisachRegressor(n_thresholds=4).fit(u, y)
                                  .weights_)
    with pytest.raises(ParameterError, match="n_levels must be a positive integer"):
        PreisachRegressor(n_levels=0).fit(u, y)
    with pytest.raises(ParameterError, match="knots must be 'uniform', 'quantile'"):
        PreisachRegressor(knots="log").fit(u, y)
    est = PreisachRegressor(n_thresholds=4, knots="quantile").fit(u, y)
    assert est.knots_.size == 3 and np.all(np.diff(est.knots_) > 0)
