"""What every estimator shares (core.fitting.estimator): fits made inside
``without_compensation_scores`` are the same fits, their reports without the compensation
errors (the inverse is formed, not run)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from core.exceptions import NotInvertibleError
from core.fitting import PIRegressor
from core.fitting.estimator import without_compensation_scores
from core.fitting.gram import Segment
from core.fitting.metrics import evaluate_fit
from core.pi import PIModel


def _record() -> tuple[np.ndarray, np.ndarray]:
    """A classical PI plant driven by a growing sine, 4,000 samples."""
    t = np.arange(4000) / 1000.0
    u = 5.0 * np.sin(2 * np.pi * t) * (1.0 + t / 4.0)
    y = PIModel(0.5, [1.0, 2.0, 3.0], [0.2, 0.1, 0.05])(u)
    return u, y


def test_a_fit_without_compensation_scores_is_the_same_fit() -> None:
    u, y = _record()
    scored = PIRegressor(n_operators=6).fit(u, y)
    with without_compensation_scores():
        plain = PIRegressor(n_operators=6).fit(u, y)
    assert plain.full_model_.to_dict() == scored.full_model_.to_dict()
    np.testing.assert_array_equal(plain.predict(u), scored.predict(u))
    assert plain.report_.train.rmse == scored.report_.train.rmse
    assert np.isfinite(scored.report_.compensation_rmse)
    assert np.isnan(plain.report_.compensation_rmse)
    assert np.isnan(plain.report_.compensation_max_abs)
    # after the block, fits score their inverse again
    assert np.isfinite(PIRegressor(n_operators=6).fit(u, y).report_.compensation_rmse)


class _PassThrough:
    """A pass-through model that counts its runs; ``invertible``: whether it has an inverse
    (another pass-through, kept in ``inv``)."""

    def __init__(self, invertible: bool = True) -> None:
        self.runs = 0
        self.invertible = invertible
        self.inv: _PassThrough | None = None

    def simulate(self, u: np.ndarray, state: object = None) -> SimpleNamespace:
        self.runs += 1
        return SimpleNamespace(y=np.asarray(u, dtype=float).copy(), state=None)

    def inverse(self) -> _PassThrough:
        if not self.invertible:
            raise NotInvertibleError("no inverse here")
        self.inv = _PassThrough()
        return self.inv


def test_unscored_compensation_forms_the_inverse_and_does_not_run_it() -> None:
    """A model without an inverse fails the report as before (a caller that skips such a
    class still skips it); one with an inverse runs only forward, and the training errors
    are those of the scored report."""
    u = np.linspace(0.0, 1.0, 50)
    seg = [Segment(u, u + 0.1)]
    with pytest.raises(NotInvertibleError):
        evaluate_fit(lambda _: _PassThrough(False), 0.0, seg, train_labels=(0,),
                     compensation=False)
    m = _PassThrough()
    train, _, cmax, crmse = evaluate_fit(lambda _: m, 0.0, seg, train_labels=(0,),
                                         compensation=False)
    assert m.inv is not None and m.inv.runs == 0 and m.runs == 1
    assert np.isnan(cmax) and np.isnan(crmse)
    full = _PassThrough()
    train_full, _, cmax_full, _ = evaluate_fit(lambda _: full, 0.0, seg, train_labels=(0,))
    assert full.inv is not None and full.inv.runs == 1
    # (an exact inverse: the forward model of the inverted output is the output)
    assert cmax_full == 0.0
    assert train.rmse == train_full.rmse == pytest.approx(0.1)
