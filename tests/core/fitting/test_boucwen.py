"""BoucWenRegressor against the benchmark's separately written Bouc-Wen plants
(benchmarks/diagnosis/families.py, n = 1, 2, 1.5), and against the PI fit of the same data."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.families import make_base
from core.exceptions import NotFittedError, ParameterError, UnsupportedOptionError
from core.fitting import BoucWenRegressor, PIRegressor, fit_recordings
from core.models import estimator_class, fit_kinds
from core.recordings import Recording

#: Measurement noise of the synthetic recordings (um, on a 100 um stroke).
SIGMA = 0.01


def _record(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A decaying sine, a staircase, then a held-out sine about another bias (V, um)."""
    t = np.linspace(0.0, 2.0, 1200)
    sine = 75 - 75 * np.exp(-t / 1.5) * np.cos(2 * np.pi * t)
    levels = [0.0, 40.0, 80.0, 120.0, 150.0, 100.0, 50.0, 0.0]
    stairs = np.concatenate(
        [
            np.r_[np.linspace(a, b, 6)[1:], np.full(30, b)]
            for a, b in zip(levels[:-1], levels[1:], strict=True)
        ]
    )
    held = 90 - 50 * np.cos(2 * np.pi * np.linspace(0.0, 2.0, 500))
    u = np.concatenate((sine, stairs, held))
    test = np.zeros(u.size, dtype=bool)
    test[-held.size :] = True
    rng = np.random.default_rng(7)
    y = make_base(name)(u) + SIGMA * rng.normal(size=u.size)
    return u, y, test


@pytest.mark.parametrize("name", ["bouc-wen-1", "bouc-wen-2", "bouc-wen-3"])
def test_grid_fit_beats_the_pi_on_held_out_rows(name: str) -> None:
    u, y, test = _record(name)
    bw = BoucWenRegressor(polish=False).fit(u, y, test=test)
    pi = PIRegressor().fit(u, y, test=test)
    e_bw, e_pi = bw.report_.test.rmse_pct, pi.report_.test.rmse_pct
    assert e_bw < 0.5, (name, e_bw)  # % of the held-out output range
    assert e_bw < e_pi / 3, (name, e_bw, e_pi)
    assert bw.report_.invertible and bw.model_.slope_bounds()[0] > 0
    assert bw.report_.compensation_max_abs < 1e-6 * np.ptp(y)
    np.testing.assert_allclose(bw.predict(u), bw.full_model_(u), rtol=0, atol=1e-9)


def test_polish_recovers_the_n2_plant_shape() -> None:
    u, y, test = _record("bouc-wen-2")
    plant = make_base("bouc-wen-2")
    bw = BoucWenRegressor(n_operators=1).fit(u, y, test=test)
    m = bw.model_
    b, g = plant.beta, plant.gamma
    np.testing.assert_allclose(m.saturation, [(b + g) ** -0.5], rtol=2e-2)
    np.testing.assert_allclose(m.reversal_slope, [2 * b / (b + g)], rtol=2e-2)
    np.testing.assert_allclose(m.exponent, [2.0], rtol=2e-2)
    np.testing.assert_allclose(-m.weights, [plant.gain * plant.c], rtol=2e-2)
    assert bw.report_.test.rmse < 3 * SIGMA
    assert bw.report_.test.rmse < bw.grid_error_


def test_fit_kind_entry_and_refusals() -> None:
    assert "bouc-wen" in fit_kinds() and estimator_class("bouc-wen") is BoucWenRegressor
    u, y, _ = _record("bouc-wen-1")
    rec = Recording(t=np.arange(u.size) * 1e-3, u=u, y=y, name="bw.csv")
    out = fit_recordings(rec, "bouc-wen", n_operators=2)
    assert out.model.to_dict()["stages"][0]["type"] == "bouc-wen"
    assert out.report.test is not None and out.report.test.rmse_pct < 0.5
    with pytest.raises(UnsupportedOptionError, match="constraint='slopes'"):
        BoucWenRegressor(constraint="slopes").fit(u, y)
    with pytest.raises(UnsupportedOptionError, match="initial_memory='exclude'"):
        BoucWenRegressor(initial_memory="exclude").fit(u, y)
    with pytest.raises(ParameterError, match="whole number from 1 to 50"):
        BoucWenRegressor(n_operators=0).fit(u, y)
    with pytest.raises(NotFittedError):
        BoucWenRegressor().predict(u)


def test_polish_residual_checks_nnls_optimality(monkeypatch):
    """The polish's weight solve keeps the minimum when scipy's ``nnls`` stops short of it
    (scipy >= 1.16 can: :func:`core.fitting.gram.nnls_checked`)."""
    import scipy.optimize

    from core.fitting import boucwen

    rng = np.random.default_rng(3)
    A = np.abs(rng.standard_normal((200, 6)))
    y = A @ np.array([1.0, 0.0, 2.0, 0.5, 0.0, 3.0]) + 0.01 * rng.standard_normal(200)
    best = np.linalg.norm(boucwen._nnls_residual(A, y, offset=False))
    monkeypatch.setattr(scipy.optimize, "nnls",
                        lambda M, b, **kw: (np.zeros(M.shape[1]), float(np.linalg.norm(b))))
    got = np.linalg.norm(boucwen._nnls_residual(A, y, offset=False))
    assert got == pytest.approx(best, rel=1e-8)
    assert best < 0.05 * np.linalg.norm(y)
