"""Missing-physics diagnosis on synthetic recordings with a known hidden effect."""

from __future__ import annotations

import json

import numpy as np
import pytest

from core.base import Chain, Model
from core.diagnosis import as_records, diagnose, split_masks
from core.diagnosis.grid import baseline_thresholds
from core.diagnosis.stats import heldout_comparison, score_test
from core.diagnosis.structure import fit_structure
from core.exceptions import ParameterError
from core.pi import PIModel
from core.recordings import Recording
from core.stages import Asymmetry, InitialMemory, Lag

FS = 2000.0


def _inputs() -> list[tuple[str, np.ndarray, np.ndarray]]:
    t1 = np.arange(0, 3.0, 1 / FS)
    u1 = 60 * np.sin(2 * np.pi * 2 * t1) * np.exp(-t1 / 2)
    t2 = np.arange(0, 2.5, 1 / FS)
    u2 = np.where(t2 < 1.0, 60 * np.sin(2 * np.pi * 2 * t2),
                  np.where(t2 < 1.75, 60 * np.sin(2 * np.pi * 20 * t2),
                           60 * np.sin(2 * np.pi * 60 * t2)))
    return [("decay", t1, u1), ("multi", t2, u2)]


def _truth() -> PIModel:
    recs = [Recording(t, u, u, n) for n, t, u in _inputs()]
    tr, _, _ = split_masks(recs)
    r = baseline_thresholds(recs, tr, 10)
    return PIModel(0.4, r, 0.05 * np.exp(-r / 30.0))


def _records(extra: Model | None = None, first_only: Model | None = None,
             noise: float = 0.01, seed: int = 1) -> list[Recording]:
    rng = np.random.default_rng(seed)
    pi = _truth()
    out = []
    for k, (name, t, u) in enumerate(_inputs()):
        m: Model = first_only if (first_only is not None and k == 0) else pi
        if extra is not None:
            m = Chain.of(m, extra)
        y = m(u, dt=1 / FS) + noise * rng.standard_normal(u.size)
        out.append(Recording(t, u, y, name))
    return out


def test_null_recordings_claim_nothing() -> None:
    res = diagnose(_records(noise=0.02, seed=7), n_operators=10)
    assert res.effects == []
    assert res.heldout_rmse(res.final) == res.heldout_rmse(res.baseline)
    # the white-noise floor is estimated close to the true noise level
    assert res.noise_rms == pytest.approx(0.02, rel=0.3)
    names = {u.name for u in res.untestable}
    assert "creep" in names  # no step-and-hold in these recordings


def test_hidden_lag_is_named_fitted_and_improves_heldout() -> None:
    tau = 1e-3
    recs = _records(extra=Lag(tau))
    res = diagnose(recs, n_operators=10, effects=["delay", "lag", "resonance", "asymmetry"])
    assert [e.name for e in res.effects][:1] == ["lag"]
    e = res.effects[0]
    assert e.parameters["tau_s"] == pytest.approx(tau, rel=0.2)
    assert e.heldout_rmse_after < 0.5 * e.heldout_rmse_before
    # the lag acts on the reversible part as well (not rate-dependent hysteresis)
    assert e.discriminators["a_rev_s"] < 0
    # the saved model is the extended chain (refitted on every row) and reproduces its prediction
    assert any(s.type_name == "lag" for s in res.model.stages)
    y = res.model(recs[0].u, dt=recs[0].dt)
    np.testing.assert_allclose(y, res.saved_fit.pred[0], atol=1e-9)
    with pytest.raises(ParameterError, match="already"):
        res.with_effect("lag")  # one linear-dynamics stage only


def test_with_effect_refits_an_unclaimed_effect_on_null_data() -> None:
    res = diagnose(_records(noise=0.02, seed=11), n_operators=10, effects=["offset"])
    fit, params = res.with_effect("lag")
    assert params["tau_s"] > 0
    # on clean data the extra lag cannot help the held-out fit noticeably
    assert res.heldout_rmse(fit) > 0.97 * res.heldout_rmse(res.final)


def test_asymmetry_is_found_and_reported_as_not_separable_from_sensor_map() -> None:
    recs = _records(extra=Asymmetry([0.25, 0.0], 0.0, 30.0))
    res = diagnose(recs, n_operators=10, effects=["lag", "asymmetry", "offset"])
    assert [e.name for e in res.effects][:1] == ["asymmetry"]
    assert res.effects[0].parameters["a2"] == pytest.approx(0.25, rel=0.3)
    assert any("sensor nonlinearity" in a["effects"] for a in res.ambiguous)


def test_initial_memory_is_found() -> None:
    pi = _truth()
    recs = _records(first_only=InitialMemory(pi, [-60.0, 25.0]))
    res = diagnose(recs, n_operators=10, effects=["initial-memory", "drift", "asymmetry"])
    assert [e.name for e in res.effects][:1] == ["initial-memory"]
    where = res.effects[0].where
    # the improvement lives early in the first recording (before the wipe-out time)
    assert where["time_windows"][0][0] == "decay"
    assert where["time_windows"][0][1] < 1.0
    # accepted in-sample; without an explicit test window the interleaved held-out blocks
    # also chose the other candidates, so the report must not call them "never used"
    text = res.summary()
    assert "never used for selection" not in text
    assert "held-out blocks (they also served the selection of other effects)" in text


def test_json_document_has_the_documented_blocks() -> None:
    res = diagnose(_records(extra=Lag(1e-3)), n_operators=10, effects=["lag", "delay"])
    d = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    assert d["format"] == "hysteresis-explorer/diagnosis"
    for key in ("effects", "untestable", "ambiguous", "baseline", "final", "tested"):
        assert key in d
    for e in d["effects"]:
        for key in ("name", "parameters", "where", "explanation", "heldout_rmse_before",
                    "heldout_rmse_after"):
            assert key in e
    assert d["final"]["heldout_rmse"] < d["baseline"]["heldout_rmse"]
    assert d["final"]["model"]["type"] == "chain"
    assert "lag" in res.summary()
    for block in ("baseline", "final"):
        lo = d[block]["leave_one_recording_out"]
        assert [p["recording"] for p in lo["per_recording"]] == ["decay", "multi"]
        assert lo["rmse"] > 0 and "rule" in lo
    assert "mse_reduction" in d["final"]["leave_one_recording_out"]


def test_explicit_time_split_and_tuple_input() -> None:
    r = _records()[1]
    res = diagnose((r.t, r.u, r.y), train=(0.0, 1.5), test=(1.5, 2.5), n_operators=10,
                   effects=["offset"])
    assert res.split.startswith("train t in [0, 1.5)")
    assert res.test[0][r.t >= 1.6].all() and not res.train[0][r.t >= 1.6].any()
    untestable = {u.name for u in res.untestable}
    assert "offset" in untestable
    # its 15 cycles at 20 Hz (and 45 at 60 Hz) at one amplitude revisit their input history
    # at one rate: a drift is testable between them in this one short record
    assert "drift" not in untestable
    # leave-one-recording-out needs several recordings and the default split
    assert res.loro_baseline is None and res.loro_final is None
    assert res.to_dict()["final"]["leave_one_recording_out"] is None


def test_a_single_short_record_that_never_revisits_its_input_cannot_test_a_drift() -> None:
    """The decaying sine never returns to an input value with the same direction and
    extrema: nothing in one 3 s record tells a drift from the base's bias."""
    r = _records()[0]
    res = diagnose(r, train=(0.0, 1.5), test=(1.5, 3.0), n_operators=10, effects=["offset"])
    assert {u.name for u in res.untestable} >= {"offset", "drift"}


def test_leave_one_recording_out_matches_a_refit_on_the_other_recording() -> None:
    """Each recording predicted by the final structure refitted on the other one alone."""
    recs = _records(extra=Lag(1e-3))
    res = diagnose(recs, n_operators=10, effects=["lag", "delay"])
    assert [e.name for e in res.effects] == ["lag"]
    lb, lf = res.loro_baseline, res.loro_final
    assert lb is not None and lf is not None
    # the lag transfers to the unseen recording: better on each held-out recording
    for a, b in zip(lb["per_recording"], lf["per_recording"], strict=True):
        assert b["rmse"] < a["rmse"]
    assert lf["mse_reduction"] == pytest.approx(1 - lf["rmse"] ** 2 / lb["rmse"] ** 2)
    # independent route: fit on a one-recording list, simulate the fitted chain on the other
    s = res.final.structure
    for j in (0, 1):
        k = 1 - j
        f = fit_structure(s.with_(history=((),)), [recs[k]], [res.train[k] | res.test[k]])
        e = recs[j].y - f.models[0](recs[j].u, dt=recs[j].dt)
        assert lf["per_recording"][j]["rmse"] == pytest.approx(np.sqrt(np.mean(e * e)),
                                                               rel=1e-6)
    assert "Leave-one-recording-out" in res.summary()


@pytest.mark.parametrize(
    "kwargs, msg",
    [
        ({"model": "preisach"}, "not supported"),
        ({"effects": ["magic"]}, "unknown effect"),
        ({"test": (0.0, 1.0)}, "needs --train"),
        ({"train": (50.0, 60.0), "test": (60.0, 70.0)}, "too few"),
    ],
)
def test_bad_arguments_are_explained(kwargs, msg) -> None:
    with pytest.raises(ParameterError, match=msg):
        diagnose(_records()[:1], **kwargs)


def test_recordings_jitter_is_resampled_and_a_gap_is_located() -> None:
    with pytest.raises(ParameterError, match="same length"):
        as_records((np.arange(30.0), np.zeros(30), np.zeros(29)))
    u = np.sin(np.arange(41.0))
    with pytest.raises(ParameterError, match=r"jump by 11 s from t = 29 s to t = 40 s"):
        as_records((np.r_[np.arange(30.0), 40 + np.arange(11.0)], u, u))
    rng = np.random.default_rng(0)
    t = 0.01 * np.arange(200) + rng.uniform(-2e-4, 2e-4, 200)
    (r,) = as_records((t, np.sin(t * 20), np.cos(t * 20)))
    assert r.is_uniform and "jitter" in r.cleaning[-1]
    assert np.isclose(r.dt, np.median(np.diff(t)))
    (g,) = as_records((np.r_[np.arange(30.0), 40 + np.arange(11.0)], u, u), resample=True)
    assert g.is_uniform and g.n_samples == 51


def test_heldout_comparison_and_score_test() -> None:
    rng = np.random.default_rng(3)
    e0 = [rng.standard_normal(4000)]
    same = heldout_comparison(e0, e0)
    assert same.gain == 0.0 and same.z == 0.0
    better = heldout_comparison(e0, [0.5 * e0[0]])
    assert better.gain == pytest.approx(0.75) and better.z > 5 and better.sign_p < 1e-4
    n = 3000
    J0 = np.column_stack((np.ones(n), rng.standard_normal(n)))
    psi = rng.standard_normal(n)
    e_null = rng.standard_normal(n)
    e_eff = e_null + 0.3 * psi
    s_null, q = score_test(e_null, J0, psi, lags=5)
    s_eff, _ = score_test(e_eff, J0, psi, lags=5)
    assert q == 1
    assert s_null < 10.8  # chi2_1 at 0.1 %
    assert s_eff > 50


def test_benchmark_subset_creep_is_not_mistaken_for_drift() -> None:
    """One cell of benchmarks/diagnosis: hidden creep with an up-then-down staircase."""
    from benchmarks.diagnosis.generator import make_scenario

    sc = make_scenario("creep", "white1", seed=3)
    res = diagnose(sc.records, effects=["creep", "drift"], auto_resolution=False)
    assert [e.name for e in res.effects][:1] == ["creep"]
    assert res.effects[0].parameters["gamma_per_decade"] == pytest.approx(0.0015, rel=0.5)
    # sign locking: the residual trend after each hold follows the sign of the step
    assert res.effects[0].discriminators["trend_follows_step_sign"] >= 0.8


def test_ranking_solve_of_a_new_history_or_rate_covers_every_training_row() -> None:
    """The ranking solves of a history or rate not in the play-bank cache build the bank only
    up to the last training row. With 16 000 training rows or more the solved rows are
    subsampled and the reduced basis is taken on a coarser subsample of the training rows,
    which can reach past the last solved row: the bank must cover it, and the RSS equal the one
    computed from the full bank that a structure fit leaves in the cache."""
    from core.diagnosis.bankcache import BankCache
    from core.diagnosis.structure import Structure

    t = np.arange(36001) * 1e-3
    u = 40.0 * np.sin(2 * np.pi * 0.5 * t) * (1 - np.exp(-t))
    rec = Recording(t, u, PIModel(0.5, [4.0, 12.0], [0.4, 0.2])(u), "sine")
    # 26 001 rows: every 3rd is solved on (the last, 26 000, is not), every 13th spans the basis
    train = [t <= 26.0005]
    r = tuple(float(v) for v in baseline_thresholds([rec], train, 8))
    x_init = [0.8 * u]
    for s in (Structure(r, ((30.0, -10.0),)), Structure(r, ((),), beta_s=1e-3)):
        fresh = fit_structure(s, [rec], train, BankCache(), x_init, iterations=1, rss_only=True)
        cache = BankCache()
        fit_structure(s, [rec], train, cache)  # leaves the full bank in the cache
        cached = fit_structure(s, [rec], train, cache, x_init, iterations=1, rss_only=True)
        assert fresh == pytest.approx(cached, rel=1e-12)


def test_full_fits_from_the_memoised_gram_block_and_lazy_pi_stage_outputs(monkeypatch) -> None:
    """Full fits form X'X from a memoised block of the PI-stage columns: a structure adding
    bilinear columns (asymmetry, three refreshes) to a bank fitted before gives the fit of the
    plain product; the PI-stage outputs, formed when first read, equal the PI model with the
    fitted weights and pickle as plain arrays (a worker process sends results back)."""
    import pickle

    from core.diagnosis import structure as st
    from core.diagnosis.bankcache import BankCache

    t = np.arange(6001) * 1e-3
    u = 40.0 * np.sin(2 * np.pi * 0.7 * t) * (1 - np.exp(-t))
    y = PIModel(0.5, [4.0, 12.0], [0.4, 0.2])(u)
    rec = Recording(t, u, y + 0.002 * y**2, "sine")
    train = [t <= 4.5]
    r = tuple(float(v) for v in baseline_thresholds([rec], train, 8))
    base = st.Structure(r, ((),), dynamics=("lag", 0.004))
    cache = BankCache()
    st.fit_structure(base.with_(dynamics=("lag", 0.02)), [rec], train, cache)  # another block
    f0 = st.fit_structure(base, [rec], train, cache)
    assert len(cache.g) == 2  # the blocks of the bank through each lag are memoised
    s = base.with_term("asymmetry", True)
    got = st.fit_structure(s, [rec], train, cache, f0.x_pi)
    monkeypatch.setattr(st, "gram", lambda X, nq, cache, key, owner: X.T @ X)
    want = st.fit_structure(s, [rec], train, BankCache(), f0.x_pi)
    scale = float(np.ptp(y))
    np.testing.assert_allclose(got.pred[0], want.pred[0], rtol=0, atol=1e-9 * scale)
    assert got.train_rss == pytest.approx(want.train_rss, rel=1e-9)
    x = got.x_pi
    assert isinstance(x, st.PIStageOutputs) and x._x is None  # not formed until read
    pi = PIModel(max(got.p0, 0.0), np.asarray(r), np.maximum(got.weights, 0.0))(u)
    np.testing.assert_allclose(x[0], pi, rtol=0, atol=1e-12 * scale)
    back = pickle.loads(pickle.dumps(got.x_pi))
    assert type(back) is list and np.array_equal(back[0], x[0])


def test_a_mode_too_damped_to_ring_is_no_resonance() -> None:
    """A second-order stage rings only below damping 1/2 (notes §4.1: g2 < 0); above it, it
    acts as a delay or a lag (g2 / g1^2 = 1 - 1 / (4 zeta^2) between 0 and 1)."""
    from core.diagnosis.effects.resonance import RINGING_MAX_DAMPING, _lacks_ringing

    for zeta in (0.01, 0.05, 0.3, 0.49):
        assert _lacks_ringing((200.0, zeta)) is None
        assert 1 - 1 / (4 * zeta**2) < 0  # the low-frequency signature of a mode
    for zeta in (0.5, 0.74, 2.0):
        assert "too high for it to ring" in _lacks_ringing((200.0, zeta))
        assert 0 <= 1 - 1 / (4 * zeta**2) < 1  # between a delay's 1/2 ... and a lag's 1
    assert RINGING_MAX_DAMPING == 0.5


@pytest.mark.slow
def test_a_small_delay_is_not_named_as_an_overdamped_resonance(monkeypatch) -> None:
    """Issue 16 (Bouc-Wen actuator, hidden 0.33 ms delay): the best output stage was a
    "resonance" at 671 Hz with damping 0.74, a mode that does not ring, while the delay
    predicted the held-out rows no significantly worse (DM z < 3). Now the delay is named
    (within 10 % of the truth), ambiguous with the resonance, and the note says why. With
    the mode's search grid of round 5 the two predict equally well; from round 4's 7-point
    grid (``monkeypatch``) the resonance wins and rule 9 (it does not ring) decides."""
    from benchmarks.diagnosis.families import make_family
    from core.diagnosis.effects import resonance

    sc = make_family("bouc-wen-1", "delay", "small", seed=500)
    for grid in ("now", "round 4"):
        if grid == "round 4":
            monkeypatch.setattr(resonance, "grid_frequencies",
                                lambda fmin, fmax: np.geomspace(fmin, fmax, 7))
        res = diagnose(sc.records, effects=["delay", "lag", "resonance"], base="pi")
        assert [e.name for e in res.effects] == ["delay"], grid
        assert res.effects[0].parameters["delay_s"] == pytest.approx(1e-3 / 3, rel=0.1)
        assert "resonance" in res.effects[0].ambiguous_with
        note = next(a for a in res.ambiguous if set(a["effects"]) == {"delay", "resonance"})
        if grid == "round 4":
            assert (("resonance is not named" in note["reason"] and "ring" in note["reason"])
            or "delay predicts the held-out rows better than resonance" in note["reason"])


@pytest.mark.slow
def test_an_eighth_size_delay_is_not_named_as_an_overdamped_resonance() -> None:
    """Issue 16 item 5 (Maxwell-slip actuator, hidden 0.125 ms delay, 0.3 um noise): the best
    output stage was a "resonance" at 1.76 kHz with damping 0.69 that left 0.5 % less
    held-out MSE than the delay, significant by the signed-rank test (p 0.003), so the delay
    was not a look-alike and the resonance was named alone. Rule 9: a stage that lacks its
    signature yields to a look-alike within 10 % of its held-out MSE; the delay is named
    (within 25 % of the truth), ambiguous with the resonance, and the note says why: the
    resonance does not ring, or (since the mode's search starts from a simplex spanning its
    grid cell) the delay already predicts the held-out rows better."""
    from benchmarks.diagnosis.families import make_family

    sc = make_family("maxwell-slip", "delay", "eighth", noise=0.003, seed=500)
    res = diagnose(sc.records, effects=["delay", "lag", "resonance"], base="pi")
    assert [e.name for e in res.effects] == ["delay"]
    assert res.effects[0].parameters["delay_s"] == pytest.approx(1e-3 / 8, rel=0.25)
    assert "resonance" in res.effects[0].ambiguous_with
    note = next(a for a in res.ambiguous if set(a["effects"]) == {"delay", "resonance"})
    assert (("resonance is not named" in note["reason"] and "ring" in note["reason"])
            or "delay predicts the held-out rows better than resonance" in note["reason"])
