"""Clockwise (friction-like) loops: orientation, the stop-operator fit, the Bouc-Wen fit in
both directions, the base choice of ``--model auto`` and the misfit warning.

The clockwise plants are independent formulas written here (an elastic-plastic return
mapping with kinematic hardening, a Bouc-Wen ODE), not the project's operators.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from core.csvio import read_csv
from core.diagnosis import basechoice
from core.fitting import StopPIRegressor, choice, fit_recordings, loop_orientation
from core.fitting.adequacy import MISFIT_RATIO
from core.fitting.stop import GAP_MIN_GAIN, SIGNED_MIN_GAIN
from core.pi import PIModel
from core.recordings import Recording
from core.stages import SignedGain
from core.stop import StopPIModel

DAMPER = Path(__file__).resolve().parents[3] / "examples" / "data" / "friction_damper"


def _strain(n: int = 6000) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(n) * 1e-3
    u = 0.01 * np.sin(2 * np.pi * t) * (0.4 + 0.6 * np.minimum(1, t / 2)) * (1 - 0.3 * (t > 4))
    return t, u


def _elastic_plastic(u: np.ndarray, E: float = 200.0, fy: float = 1.0,
                     H: float = 0.02) -> np.ndarray:
    """Stress of an elastic-plastic bar with linear kinematic hardening (return mapping)."""
    ep = alpha = 0.0
    out = np.empty(u.size)
    for k, e in enumerate(u):
        xi = E * (e - ep) - alpha
        f = abs(xi) - fy
        if f > 0:
            dg = f / (E + H * E)
            ep += dg * np.sign(xi)
            alpha += H * E * dg * np.sign(xi)
        out[k] = E * (e - ep)
    return out


def _bouc_wen(u: np.ndarray, k: float = 200.0, a: float = 0.05, beta: float = 150.0,
              gamma: float = 50.0, sub: int = 20) -> np.ndarray:
    """Classical Bouc-Wen ``y = a k u + (1 - a) k z``, ``dz = (1 - (beta sgn(du z) + gamma)
    |z|) du`` (n = 1), explicit Euler with ``sub`` sub-steps per sample."""
    z, prev = 0.0, u[0]
    out = np.empty(u.size)
    for i, x in enumerate(u):
        du = (x - prev) / sub
        for _ in range(sub):
            z += (1.0 - (beta * np.sign(du * z) + gamma) * abs(z)) * du
        prev = x
        out[i] = a * k * x + (1 - a) * k * z
    return out


def _noisy(name: str, y: np.ndarray, t: np.ndarray, u: np.ndarray, seed: int,
           rel: float = 0.002) -> tuple[Recording, float]:
    sigma = rel * float(np.ptp(y))
    y = y + sigma * np.random.default_rng(seed).standard_normal(y.size)
    return Recording(t, u, y, name=name), sigma


def test_orientation_of_a_piezo_like_and_a_friction_like_loop() -> None:
    t, u = _strain()
    ccw = loop_orientation([u], [PIModel(0.5, [0.002, 0.004], [30.0, 20.0])(u)])
    cw = loop_orientation([u], [_elastic_plastic(u)])
    assert not ccw.clockwise and ccw.area < 0
    assert cw.clockwise and cw.area > 0 and "clockwise" in cw.text


def test_auto_fits_an_elastic_plastic_loop_to_its_noise_and_says_clockwise() -> None:
    t, u = _strain()
    rec, sigma = _noisy("epp", _elastic_plastic(u), t, u, 1)
    out = fit_recordings([rec], "auto")
    assert out.kind == "stop-pi"
    assert out.report.test.rmse < 1.3 * sigma  # at the noise (before: 15.7 % of range)
    assert "clockwise" in out.report.extra["orientation"]
    assert "base chosen as hyst diagnose chooses it" in out.report.extra["base_choice"]
    assert out.report.extra["friction_plateau"] == pytest.approx(1.0, rel=0.05)  # fy
    # the one warning: on the plastic plateau the stress does not tell the strain, so the
    # (invertible) model's inverse cannot recover the input from the measured output
    assert len(out.report.warnings) == 1
    assert out.report.warnings[0].startswith("the inverse of this model does not recover")
    # the kind "pi" fits the same loop with stop operators (negative play weights)
    pi = fit_recordings([rec], "pi")
    assert pi.report.test.rmse < 1.3 * sigma and (pi.model.stages[0].weights <= 0).all()


def test_bouc_wen_fits_a_clockwise_bouc_wen_loop() -> None:
    t, u = _strain()
    rec, sigma = _noisy("bw", _bouc_wen(u), t, u, 2)
    out = fit_recordings([rec], "bouc-wen")
    bw = out.model.stages[0]
    assert (bw.weights > 0).any()  # before: one weight of exactly -0.0, a straight line
    assert out.report.test.rmse < 1.5 * sigma
    assert "clockwise" in out.report.extra["orientation"]
    assert out.report.invertible


def test_a_misfit_kind_warns_where_and_a_good_fit_does_not() -> None:
    t, u = _strain()
    rec, sigma = _noisy("epp", _elastic_plastic(u), t, u, 3)
    bad = fit_recordings([rec], "preisach")  # counter-clockwise kind on a clockwise loop
    assert bad.report.extra["rmse_over_noise_floor"] > MISFIT_RATIO
    # every kind whose loops run counter-clockwise only says so in words and names the
    # kinds that can follow the loop
    assert any("counter-clockwise loops only" in w and "stop-pi" in w for w in bad.warnings)
    (cw,) = [w for w in fit_recordings([rec], "mpi").warnings
             if "cannot follow these clockwise loops" in w]
    assert "the mpi kind's loops run counter-clockwise only" in cw
    assert "--model stop-pi" in cw and "--model bouc-wen" in cw
    assert not any("cannot follow" in w for w in fit_recordings([rec], "bouc-wen").warnings)
    (msg,) = [w for w in bad.report.warnings if "white-noise floor" in w]
    assert "Largest residuals: at inputs" in msg and "branch" in msg and "t = " in msg
    assert msg in bad.warnings and msg in bad.parameter_set.provenance.fit["warnings"]
    assert "warning: the held-out RMSE" in bad.summary()
    good = fit_recordings([rec], "stop-pi")
    assert good.report.extra["rmse_over_noise_floor"] < 2.0
    assert not any("white-noise floor" in w for w in good.report.warnings)


def test_auto_on_one_recording_keeps_the_pi_family_and_says_what_to_try() -> None:
    """A classical Bouc-Wen loop is not a Masing (stop-operator) loop: with one recording the
    choice keeps the PI family, as the diagnosis does, and its misfit warning names the
    Bouc-Wen kind, which fits it to the noise."""
    t, u = _strain()
    rec, sigma = _noisy("bw", _bouc_wen(u), t, u, 5)
    out = fit_recordings([rec], "auto")
    assert out.kind == "stop-pi" and out.report.test.rmse > 3 * sigma
    (msg,) = [w for w in out.warnings if "white-noise floor" in w]
    assert "fit --model bouc-wen" in msg and "preisach" not in msg


def test_auto_with_several_recordings_chooses_bouc_wen_for_a_bouc_wen_plant() -> None:
    """Each recording predicted from the others: a classical Bouc-Wen plant, which stop
    operators miss (Masing's rule), gets the Bouc-Wen base, to its noise."""
    rng = np.random.default_rng(1)
    recs, sig = [], []
    for k, (amp, fr) in enumerate(((0.01, 1.0), (0.007, 2.0), (0.012, 1.5))):
        t = np.arange(1500) * 1e-3
        u = amp * np.sin(2 * np.pi * fr * t) * np.minimum(1, t / 0.6)
        y = _bouc_wen(u, sub=10)
        sig.append(0.002 * float(np.ptp(y)))
        recs.append(Recording(t, u, y + sig[-1] * rng.standard_normal(y.size), name=f"r{k}"))
    out = fit_recordings(recs, "auto")
    assert out.kind == "bouc-wen"
    assert "each of 3 recordings predicted from the others" in out.report.extra["base_choice"]
    assert out.report.test.rmse < 1.5 * max(sig)


def test_choice_margins_are_the_diagnosis_margins() -> None:
    from core.diagnosis import bases

    assert choice.PREISACH_MIN_GAIN == basechoice.PREISACH_MIN_GAIN
    assert choice.PREISACH_OVER_MAP == basechoice.PREISACH_OVER_MAP
    assert bases.BW_MIN_GAIN is choice.BW_MIN_GAIN


def _shelf_travel(u: np.ndarray, y: np.ndarray, band: float) -> float:
    """Median input travel per full transition while ``|y| < band``, read off a recording."""
    du = np.diff(u)
    rev = np.flatnonzero(np.diff(np.sign(du)) != 0) + 1
    out = [float(np.sum(np.abs(du[a:b])[np.abs(y[a:b]) < band]))
           for a, b in zip(rev[:-1], rev[1:], strict=True) if np.ptp(y[a:b + 1]) > 0.5 * np.ptp(y)]
    return float(np.median(out))


def test_friction_damper_names_its_plateau_and_backlash_gap() -> None:
    (rec,) = read_csv(DAMPER / "1Hz30lbtension0.5amplitude.csv")
    out = fit_recordings([rec], "auto")
    ex = out.report.extra
    assert out.kind == "stop-pi"
    # the force sits near zero for 0.10-0.15 in half-way through every transition (read off
    # the recording: |y| < 0.15 kip): the fitted gap is that shelf
    shelf = _shelf_travel(rec.u, rec.y, 0.15)
    assert 0.8 * shelf < ex["gap"] < 1.2 * shelf
    assert 1.5 < ex["friction_plateau"] < 2.7  # half the jump between the branches, kip
    assert "backlash dead band" in out.summary() and "friction plateau" in out.summary()
    assert " kip " in ex["branch"] and " in wide" in ex["branch"]  # the recording's units
    # the gap follows the shelf wherever the reversal was: the held-out error falls by a
    # third against the same fit without it (5.9 % -> 4.0 % of range)
    nogap = StopPIRegressor(gap=0.0, initial_memory="exclude").fit(rec.u, rec.y)
    assert nogap.model_.gap == 0.0
    assert out.report.test.rmse < 0.75 * nogap.report_.test.rmse
    # the residual left (stiction overshoot and chatter on the plateaus) is still reported
    assert any("white-noise floor" in w for w in out.report.warnings)


def _gap_plant(seed: int, gap: float,
               noise: float = 0.002) -> tuple[np.ndarray, np.ndarray, float]:
    """A stop bank behind a gap driven by a sine whose amplitude wanders (reversals at many
    levels), white noise of ``noise`` x the output's range."""
    rng = np.random.default_rng(seed)
    t = np.arange(6000) * 1e-3
    amp = 0.5 * (0.5 + 0.5 * np.abs(np.sin(2 * np.pi * 0.13 * t + rng.uniform(0, 6))))
    u = amp * np.sin(2 * np.pi * t)
    y = StopPIModel(0.2, [0.02, 0.05, 0.1, 0.2], [20.0, 10.0, 5.0, 2.0], gap=gap)(u)
    sigma = noise * float(np.ptp(y))
    return u, y + sigma * rng.standard_normal(y.size), sigma


@pytest.fixture(scope="module")
def gap_plant_fit() -> tuple[np.ndarray, np.ndarray, float, StopPIRegressor]:
    """``_gap_plant(3, 0.12)`` and its default fit (gap and gains searched); the tests only
    read it."""
    u, y, sigma = _gap_plant(3, 0.12)
    return u, y, sigma, StopPIRegressor().fit(u, y)


def test_the_gap_of_a_stop_plant_is_recovered_from_its_training_rows(gap_plant_fit) -> None:
    u, y, sigma, est = gap_plant_fit
    assert est.model_.gap == pytest.approx(0.12, rel=0.05)
    assert est.report_.test.rmse < 2.0 * sigma
    assert StopPIRegressor(gap=0.0).fit(u, y).report_.test.rmse > 8 * sigma
    assert "backlash dead band 0.12" in est.features_.text()


def test_the_gap_search_finds_the_same_without_scoring_its_steps(gap_plant_fit,
                                                                  monkeypatch) -> None:
    """The weight fits inside the gap search are not scored (only their model and offset are
    read, core.fitting.stop._GapStep): scored, the search gives the same model, widths'
    training MSEs and report."""
    import json

    from core.fitting import stop

    u, y, _, est = gap_plant_fit
    monkeypatch.setattr(stop._GapStep, "scores_fit", True)
    scored = StopPIRegressor().fit(u, y)
    assert json.dumps(scored.full_model_.to_dict()) == json.dumps(est.full_model_.to_dict())
    assert scored.gap_scores_ == est.gap_scores_
    assert json.dumps(scored.report_.to_dict(), sort_keys=True) == json.dumps(
        est.report_.to_dict(), sort_keys=True)


def test_the_gap_search_finds_the_same_without_its_unread_parts(gap_plant_fit,
                                                                 monkeypatch) -> None:
    """The weight fits of the gap search stream the training rows' Gram matrix alone (the
    held-out rows are never solved on) and take the orientation of the fit they serve
    (``_GapStep._orientation``: the stop constraint does not read it): against the search
    streaming the held-out Gram too (every ``stream_gram`` call of the PI fit given one
    label more) and computing each step's orientation on the elements' input, as before,
    the same chosen width, model, widths' training MSEs and report, bit for bit."""
    import json

    from core.fitting import pi, stop

    u, y, _, est = gap_plant_fit
    original = pi.stream_gram
    oriented: list[bool] = []

    def with_held_out(*args, n_labels, **kwargs):
        return original(*args, n_labels=n_labels + 1, **kwargs)

    def own_orientation(step, prep):
        oriented.append(step.served_orientation_.clockwise)
        return pi.PIRegressor._orientation(step, prep)

    monkeypatch.setattr(pi, "stream_gram", with_held_out)
    monkeypatch.setattr(stop._GapStep, "_orientation", own_orientation)
    before = StopPIRegressor().fit(u, y)
    assert len(oriented) > len(stop.GAP_GRID) and all(oriented)  # every step, served clockwise
    assert before.model_.gap == est.model_.gap
    assert json.dumps(before.full_model_.to_dict()) == json.dumps(est.full_model_.to_dict())
    assert before.gap_scores_ == est.gap_scores_
    assert json.dumps(before.report_.to_dict(), sort_keys=True) == json.dumps(
        est.report_.to_dict(), sort_keys=True)


def test_a_gap_too_small_to_matter_is_not_named() -> None:
    # a 0.006 wide gap (0.6 % of the travel) under 1 % noise: the best width lowers the
    # training MSE by about 3 %, less than GAP_MIN_GAIN
    u, y, _ = _gap_plant(4, 0.006, noise=0.01)
    est = StopPIRegressor().fit(u, y)
    assert est.model_.gap == 0.0 and "backlash" not in est.features_.text()
    best = min(v for k, v in est.gap_scores_.items() if k > 0)
    assert est.gap_scores_[0.0] > best > (1 - GAP_MIN_GAIN) * est.gap_scores_[0.0]


def test_a_slip_force_by_direction_is_recovered_and_named() -> None:
    # the plant's force where it is negative is 1.6 times what the symmetric bank gives
    u, y0, sigma = _gap_plant(5, 0.1)
    y = SignedGain(1.0, 1.6)(y0)
    est = StopPIRegressor().fit(u, y)
    assert est.signed_gain_ is not None
    assert est.signed_gain_.ratio == pytest.approx(1.6, rel=0.03)
    # the gap is searched before the gains, on the asymmetric loop: 0.091 here, which
    # leaves the held-out error at 2.7 noise sigmas (of y0's noise, 1.6 x on the negative side)
    assert est.model_.gap == pytest.approx(0.1, rel=0.15)
    assert est.report_.test.rmse < 4.0 * sigma
    assert "depends on the sliding direction" in est.features_.text()
    assert est.report_.extra["slip_force_ratio"] == pytest.approx(1.6, rel=0.03)
    # the saved model is the chain bank >> gain >> offset, and it inverts exactly
    assert isinstance(est.full_model_.stages[1], SignedGain)
    yd = est.predict(u)
    assert np.max(np.abs(est.predict(est.compensate(yd)) - yd)) < 1e-9 * np.ptp(yd)
    # without it the held-out error is several times larger
    sym = StopPIRegressor(signed=False).fit(u, y)
    assert sym.report_.test.rmse > 3.0 * est.report_.test.rmse


def test_a_symmetric_plant_gets_no_gain_by_direction(gap_plant_fit) -> None:
    est = gap_plant_fit[3]
    assert est.signed_gain_ is None and "sliding direction" not in est.features_.text()
    # screened out: two gains on the fitted bank lower the training MSE of one by < 10 %
    s = est.report_.extra["signed_training_mse"]
    assert "by direction" not in s
    one, two = s["one gain on the first bank"], s["two gains on the first bank"]
    assert one >= two > (1 - SIGNED_MIN_GAIN) * one


def test_friction_damper_at_36_lb_names_its_slip_force_by_direction() -> None:
    (rec,) = read_csv(DAMPER / "1Hz36lbtension0.5amplitude.csv")
    out = fit_recordings([rec], "auto")
    ex = out.report.extra
    assert out.kind == "stop-pi"
    # the plateau while the force is negative is ~1.6 x the positive one (read off the
    # recording: -4.7 kip against +2.6 kip on the sliding strokes)
    assert 1.4 < ex["slip_force_ratio"] < 1.9
    assert "depends on the sliding direction" in ex["branch"] and " kip " in ex["branch"]
    # held-out error 6.8 % -> 3.1 % of range against the symmetric fit
    sym = StopPIRegressor(signed=False, initial_memory="exclude").fit(rec.u, rec.y)
    assert out.report.test.rmse < 0.6 * sym.report_.test.rmse
