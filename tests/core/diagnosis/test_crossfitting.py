"""Cross-fitted significance evidence and block-jackknife uncertainties of the diagnosis."""

from __future__ import annotations

import numpy as np
import pytest

from core.diagnosis import diagnose
from core.diagnosis.crossfitting import block_jackknife
from core.diagnosis.data import crossfit_folds, wipeout_index
from core.recordings import Recording
from core.stages import Lag
from tests.core.diagnosis.test_diagnosis import _records


def test_folds_are_disjoint_blocks_of_the_training_rows_after_the_wipeout_time() -> None:
    recs = _records()
    train = [(r.t >= 0.0) & (r.t < 2.0) for r in recs]
    folds = crossfit_folds(recs, train)
    assert 2 <= len(folds) <= 8
    covered = [np.zeros(r.n_samples, dtype=bool) for r in recs]
    for tr_f, blk in folds:
        for k, r in enumerate(recs):
            assert not (covered[k] & blk[k]).any()  # disjoint
            covered[k] |= blk[k]
            assert np.array_equal(tr_f[k], train[k] & ~blk[k])
            assert not blk[k][: wipeout_index(r.u)].any()  # never before the wipe-out time
        # a block is contiguous and at least 0.5 s long
        k = next(i for i, b in enumerate(blk) if b.any())
        idx = np.flatnonzero(blk[k])
        assert np.all(np.diff(idx) == 1) and idx.size * recs[k].dt >= 0.5 - 1e-9
    for k, r in enumerate(recs):
        after = train[k].copy()
        after[: wipeout_index(r.u)] = False
        assert np.array_equal(covered[k], after)  # every training row after t_w is held out once


def test_too_short_a_training_window_gives_no_folds() -> None:
    recs = _records()[:1]
    train = [(recs[0].t >= 0.0) & (recs[0].t < 0.6)]
    assert crossfit_folds(recs, train) == []


def test_jackknife_of_a_mean_is_the_standard_error() -> None:
    # delete-one estimates of a mean: the jackknife sd is exactly std(x, ddof=1) / sqrt(K)
    x = np.array([1.0, 4.0, 2.5, 3.0, -1.0, 0.5])
    loo = [{"m": float(np.delete(x, k).mean()), "v": [float(np.delete(x, k).mean()), 2.0],
            "fixed": 7.0} for k in range(x.size)]
    jk = block_jackknife(loo)
    se = float(np.std(x, ddof=1) / np.sqrt(x.size))
    assert jk["m"] == pytest.approx(se, rel=1e-12)
    assert jk["v"] == pytest.approx([se, 0.0], abs=1e-12)
    assert "fixed" not in jk  # fixed by design: no uncertainty claimed


def test_lag_with_explicit_windows_is_confirmed_on_cross_fitted_blocks() -> None:
    tau = 0.004
    recs = _records(extra=Lag(tau), noise=0.01, seed=3)
    res = diagnose(recs, train=(0.0, 2.0), test=(2.0, 2.5), n_operators=10,
                   auto_resolution=False, effects=["delay", "lag", "drift", "asymmetry"])
    assert "selection by cross-fitting" in res.split
    names = [e.name for e in res.effects]
    assert names and names[0] in ("lag", "delay")
    e = res.effects[0]
    cf = e.crossfit
    assert cf is not None and cf["folds"] >= 2
    assert len(cf["fold_mse_reductions"]) == cf["folds"]
    assert min(cf["fold_mse_reductions"]) > 0  # every held-out block improves
    key = "tau_s" if e.name == "lag" else "delay_s"
    vals = [p[key] for p in cf["fold_parameters"]]
    assert max(vals) / min(vals) < 1.5  # the nonlinear parameter agrees across folds
    assert e.uncertainty_method.startswith("block jackknife")
    assert 0 < e.uncertainty[key] < 0.5 * e.parameters[key]
    d = e.to_dict(res.y_range)
    assert d["crossfit"]["dm_z_pooled"] >= 3.0 or d["crossfit"]["signed_rank_p_pooled"] < 0.01
    # strict hold-out: the acceptance statistics are those of the cross-fitted blocks alone
    row = next(r for r in res.rounds if r["effect"] == e.name and r.get("decision") == "accepted")
    assert row["evidence"] == f"{cf['folds']} cross-fitted training blocks"
    assert row["dm_z"] == pytest.approx(cf["dm_z_pooled"])
    assert e.heldout_rmse_after < 0.5 * e.heldout_rmse_before  # the test window, scored once


def test_strict_holdout_selection_never_reads_the_test_window() -> None:
    """Replacing the measured output inside the test window by garbage changes no decision
    and no parameter (only the scored held-out numbers): selection rests on the training
    rows alone."""
    recs = _records(extra=Lag(0.004), noise=0.01, seed=3)
    kw = dict(train=(0.0, 2.0), test=(2.0, 2.5), n_operators=10, auto_resolution=False,
              effects=["delay", "lag", "asymmetry"])
    res = diagnose(recs, **kw)
    rng = np.random.default_rng(0)
    bad = [Recording(r.t, r.u, np.where(r.t >= 2.0, rng.normal(0, 50, r.t.size), r.y), r.name)
           for r in recs]
    res2 = diagnose(bad, **kw)
    assert [e.name for e in res2.effects] == [e.name for e in res.effects] != []
    for a, b in zip(res.effects, res2.effects, strict=True):
        assert a.parameters == pytest.approx(b.parameters)
    assert [(r["effect"], r["passes"], r.get("decision")) for r in res2.rounds] == [
        (r["effect"], r["passes"], r.get("decision")) for r in res.rounds]
    assert res2.heldout_rmse(res2.final) > 10 * res.heldout_rmse(res.final)


def test_null_with_explicit_windows_claims_nothing_and_crossfit_can_be_switched_off() -> None:
    recs = _records(noise=0.02, seed=11)
    res = diagnose(recs, train=(0.0, 2.0), test=(2.0, 2.5), n_operators=10,
                   auto_resolution=False, effects=["delay", "lag", "drift", "asymmetry"])
    assert res.effects == []
    off = diagnose([Recording(r.t, r.u, r.y, r.name) for r in recs], train=(0.0, 2.0),
                   test=(2.0, 2.5), n_operators=10, auto_resolution=False,
                   effects=["lag"], crossfit=False)
    assert "cross-fitting" not in off.split
    assert all("dm_z_pooled" not in r for r in off.rounds)


def test_each_accepted_effect_is_scored_leave_one_recording_out() -> None:
    res = diagnose(_records(extra=Lag(0.004), noise=0.01, seed=3), n_operators=10,
                   auto_resolution=False, effects=["delay", "lag", "drift"])
    assert res.effects and res.loro_baseline is not None and res.loro_final is not None
    first, last = res.effects[0], res.effects[-1]
    assert first.loro is not None and last.loro is not None
    assert first.loro["rmse_before"] == pytest.approx(res.loro_baseline["rmse"])
    assert last.loro["rmse_after"] == pytest.approx(res.loro_final["rmse"])
    assert first.loro["rmse_after"] < first.loro["rmse_before"]  # the lag helps unseen records
    assert len(first.loro["per_recording"]) == 2
    assert first.to_dict(res.y_range)["leave_one_recording_out"]["mse_reduction"] > 0.05
    assert "leave-one-recording-out RMSE" in res.summary()
