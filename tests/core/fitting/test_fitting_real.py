"""Fits on real measured recordings (the shipped copies in examples/data): piezo, friction
damper, B-H loops."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from core.datasets import DATA_DIR as DATA
from core.exceptions import FitWarning
from core.fitting.pi import PIRegressor


def _load(rel: str) -> np.ndarray:
    return np.loadtxt(DATA / rel, delimiter=",", skiprows=1)


def _piezo():
    d = _load("piezo/piezo_150V_1Hz.csv")
    t, u, y = d[:, 0], d[:, 1], d[:, 2]
    keep = t <= 9.0 + 1e-9
    return t[keep], u[keep], y[keep]


def test_piezo_classical_pi_n25_heldout_rmse_below_035_percent():
    """Train on t in [3.3, 7) s, score on [7, 9] s; simulate from t = 0 (0 V rest, so the
    play states start relaxed at 0 V), the jump to -87 V and the first sine half-period
    only drive the memory. Output range = max - min of the measured y on [7, 9] s
    (39.31 um). Measured: held-out RMSE 0.119 um = 0.303 % (train 0.212 um)."""
    t, u, y = _piezo()
    train = (t >= 3.3) & (t < 7.0)
    test = (t >= 7.0) & (t <= 9.0)
    est = PIRegressor(n_operators=25).fit(u, y, train=train, test=test)
    rep = est.report_
    assert rep.test is not None
    assert rep.test.output_range == pytest.approx(np.ptp(y[test]))
    assert 39.0 < rep.test.output_range < 39.6
    assert rep.test.rmse_pct <= 0.35, rep.summary()
    assert rep.test.rmse <= 0.138
    # invertible, and the model through its own inverse reproduces the measured output
    assert est.model_.is_invertible and est.p0_ > 0
    assert rep.compensation_max_abs < 1e-10 * rep.test.output_range
    # the inverse maps the measured displacement back to the applied voltage within ~0.5 %
    assert rep.test.inverse_input_rmse_pct < 1.0
    # the free offset matters: without it the same model is clearly worse
    no_off = PIRegressor(n_operators=25, include_offset=False).fit(u, y, train=train, test=test)
    assert no_off.report_.test.rmse > 1.2 * rep.test.rmse


def test_piezo_recording_starting_mid_history_leaves_pre_wipeout_rows_out():
    """A file holding only t in [3.3, 7) s starts in the middle of the actuator's history.
    The rows before the input first reaches both ends of its range (t_w = 4.06 s) depend on
    the unknown memory; leaving them out of the weight fit (the default) predicts the unseen
    [7, 9] s within 0.32 % of its output range (``hyst fit``'s default). Fitting them from
    the relaxed state misses by 0.37-0.40 %. Measured: 0.217 % vs 0.374 %."""
    t, u, y = _piezo()
    s = t >= 3.3
    ts, us, ys = t[s], u[s], y[s]
    file = ts < 7.0
    test = ts >= 7.0
    yr = float(np.ptp(ys[test]))
    scores = {}
    for rule in ("exclude", "keep"):
        est = PIRegressor(n_operators=25, initial_memory=rule).fit(us[file], ys[file])
        e = (ys - est.predict(us))[test]
        scores[rule] = 100 * float(np.sqrt(np.mean(e * e))) / yr
        mem = est.report_.extra["initial_memory"]
        assert (mem["excluded_train_rows"] > 0) == (rule == "exclude")
    assert scores["exclude"] <= 0.32, scores
    assert scores["keep"] > 0.35, scores
    rep = PIRegressor(n_operators=25, initial_memory="exclude").fit(us[file], ys[file]).report_
    assert "left out of the weight fit" in rep.summary()


def test_piezo_operator_count_chosen_on_held_out_blocks():
    t, u, y = _piezo()
    train = (t >= 3.3) & (t < 7.0)
    test = (t >= 7.0) & (t <= 9.0)
    est = PIRegressor().fit(u, y, train=train, test=test)
    assert est.n_operators_ in (10, 15, 20, 25, 30)
    assert est.report_.test.rmse_pct <= 0.35


@pytest.mark.parametrize(
    "name", ["1Hz30lbtension0.5amplitude.csv", "2Hz30lbtension0.5amplitude.csv"]
)
def test_friction_damper_displacement_to_force(name):
    """Friction force saturates with displacement (concave loading curve, clockwise loops):
    the slope constraint (negative weights allowed) or the non-negative rule applied to stop
    operators (which it becomes on clockwise data) fit it. Measured held-out RMSE (last
    20 %): 5.9 % (1 Hz) and 7.5 % (2 Hz) of the force range with slopes, 6.0 % and 7.6 %
    with stop operators, against 18 % with play operators and p_i >= 0."""
    d = _load(f"friction_damper/{name}")
    u, y = d[:, 1], d[:, 2]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)  # saturated branches: slope at its bound
        est = PIRegressor(constraint="slopes").fit(u, y)
        hard = PIRegressor(constraint="nonnegative").fit(u, y)
    assert est.model_.is_invertible
    assert est.report_.test.rmse_pct < 9.0, est.report_.summary()
    assert hard.constraint_ == "stop" and (hard.weights_ <= 0).all()
    assert hard.report_.test.rmse_pct < 9.0, hard.report_.summary()


def _bh_runs(name: str):
    """One run per loop, each loop repeated twice: the first pass only sets the memory
    (a measured steady-state loop has no virgin start), the second is scored."""
    d = _load(f"bh_loops/{name}")
    loop = d[:, 0].astype(int)
    us, ys, tr = [], [], []
    for k in np.unique(loop):
        u, y = d[loop == k, 3], d[loop == k, 4]
        us.append(np.tile(u, 2))
        ys.append(np.tile(y, 2))
        tr.append(np.r_[np.zeros(u.size, bool), np.ones(u.size, bool)])
    return us, ys, tr


@pytest.mark.parametrize(
    ("name", "limit"),
    [
        ("amorphous_alloy.csv", 0.5),  # one loop: measured 0.04 %
        ("MnZn_ferrite.csv", 12.0),  # four amplitudes: measured 10.4 %
        ("M130-27s_GO_steel.csv", 11.0),  # three amplitudes: measured 8.8 %
    ],
)
def test_bh_loops_fit_as_separate_runs(name, limit):
    us, ys, tr = _bh_runs(name)
    te = [np.zeros(m.size, bool) for m in tr]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        est = PIRegressor(constraint="slopes").fit(us, ys, train=tr, test=te)
    rep = est.report_
    assert est.model_.is_invertible
    assert rep.train.rmse_pct < limit, rep.summary()
    assert np.isfinite(rep.compensation_max_abs)


def test_piezo_generalized_and_digitized_models():
    """Same windows as the classical test. Measured held-out RMSE: classical 0.119 um,
    Kuhnen MPI 0.094 um (0.24 %), dead-zone GPI 0.094 um; digitized (26 digits) equals the
    classical on the held-out part with a 0.016 um discretisation RMSE over the scored
    samples."""
    from core.fitting.digitized import DigitizedPIRegressor
    from core.fitting.gpi import ModifiedPIRegressor

    t, u, y = _piezo()
    train = (t >= 3.3) & (t < 7.0)
    test = (t >= 7.0) & (t <= 9.0)
    classical = PIRegressor(n_operators=25).fit(u, y, train=train, test=test)
    mpi = ModifiedPIRegressor(n_operators=25).fit(u, y, train=train, test=test)
    assert mpi.report_.test.rmse <= 0.9 * classical.report_.test.rmse
    assert mpi.report_.compensation_max_abs < 1e-10 * np.ptp(y)
    dig = DigitizedPIRegressor(n_operators=25).fit(u, y, train=train, test=test)
    assert dig.report_.extra["discretisation_rmse"] < 0.05
    assert dig.report_.test.rmse == pytest.approx(classical.report_.test.rmse, rel=0.05)


def test_bh_loops_need_a_generalized_model():
    """Loops of several amplitudes break the classical PI's Masing rules; an output
    dead-zone map (Kuhnen MPI) fixes most of it. Measured (MnZn ferrite, 4 loops): classical
    10.4 % of the B range, MPI 4.3 %."""
    from core.fitting.gpi import ModifiedPIRegressor

    us, ys, tr = _bh_runs("MnZn_ferrite.csv")
    te = [np.zeros(m.size, bool) for m in tr]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        pi = PIRegressor(constraint="slopes").fit(us, ys, train=tr, test=te)
        mpi = ModifiedPIRegressor().fit(us, ys, train=tr, test=te)
    assert mpi.report_.train.rmse_pct < 6.0
    assert mpi.report_.train.rmse < 0.6 * pi.report_.train.rmse
    assert mpi.deadzone_.is_invertible and mpi.model_.pi.is_invertible


def test_piezo_cv_at_the_largest_candidate_says_more_operators_may_fit_better():
    """On the whole piezo file (``hyst fit``'s defaults: the last 20 % held out) the
    cross-validated RMSE still falls at 40 operators, the largest candidate, and the report
    says so; the advice holds on the held-out rows, which the choice never saw (measured
    0.2075 % at 40 -> 0.198 % at 60). A choice inside the grid gets no such advice."""
    from core.fitting.pi import cv_choice_note

    d = _load("piezo/piezo_150V_1Hz.csv")
    u, y = d[:, 1], d[:, 2]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        est = PIRegressor(initial_memory="exclude").fit(u, y)
        more = PIRegressor(initial_memory="exclude", n_operators=60).fit(u, y)
    assert est.n_operators_ == 40
    note = est.report_.extra["cv_choice"]
    assert "still falling" in note and "(60 or more)" in note and note in est.report_.summary()
    assert more.report_.test.rmse < 0.97 * est.report_.test.rmse
    # inside the grid, or at its edge with a flat error: only the choice is stated
    inside = cv_choice_note({10: 0.2, 20: 0.1, 40: 0.099}, 20, 0.02)
    assert inside == "n = 20 operators chosen by cross-validation among 10, 20, 40"
    assert "still falling" not in cv_choice_note({20: 0.1, 40: 0.099}, 40, 0.02)
    assert "still falling" in cv_choice_note({20: 0.1, 40: 0.09, 80: None}, 40, 0.02)
    assert "too few" in cv_choice_note({20: None, 40: None}, 20, 0.02)
