"""Evidence between recordings (issue 8, slice 6): short periodic recordings at several
frequencies; rate-dependent effects judged by predicting each recording from the others."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.generator import loop_area, make_periodic_set, truth_pi
from core.diagnosis import diagnose
from core.diagnosis.between import between_recordings, left_out_residual
from core.diagnosis.context import FitContext
from core.diagnosis.data import split_masks
from core.diagnosis.grid import baseline_thresholds
from core.diagnosis.structure import Structure
from core.fitting.steadystate import steady_state_history
from core.recordings import Recording
from core.stages import InitialMemory

#: beta (s) of the rate-dependent plant: the loop area grows by about 2/3, 0.5 -> 4 Hz
BETA = 0.025


def test_loop_area_reference() -> None:
    """Shoelace area of an ideal square loop, and the scenario's area growth."""
    u = np.array([0.0, 1.0, 1.0, 0.0])
    y = np.array([0.0, 0.0, 2.0, 2.0])
    assert loop_area(u, y) == pytest.approx(2.0)
    a = make_periodic_set(BETA).extras["loop_area"]
    assert a[-1] / a[0] == pytest.approx(5 / 3, rel=0.03)
    a0 = make_periodic_set(None).extras["loop_area"]
    assert np.ptp(a0) == pytest.approx(0.0, abs=1e-9)


def _rate_row(res):
    return next(r for r in res.rounds if r["round"] == 1 and r["effect"] == "rate")


def test_rate_claimed_from_recordings_at_four_frequencies() -> None:
    res = diagnose(make_periodic_set(BETA).records)
    assert [f.name for f in res.effects] == ["rate"]
    row = _rate_row(res)
    assert "leave-one-recording-out" in row["evidence"]
    # every recording, predicted by a model whose beta was chosen without it, improves
    assert len(row["per_recording"]) == 4
    assert all(p["mse_reduction"] > 0.5 for p in row["per_recording"])
    beta = res.effects[0].parameters["beta_s"]
    assert beta == pytest.approx(BETA, rel=0.3)
    assert "rate" not in {u.name for u in res.untestable}


def test_rate_independent_plant_at_four_frequencies_claims_nothing() -> None:
    res = diagnose(make_periodic_set(None).records)
    assert res.effects == []
    row = _rate_row(res)
    # tested between recordings (not silently skipped), rejected there, and said so
    assert "leave-one-recording-out" in row["evidence"] and not row["passes"]
    assert "Tested between recordings, not claimed: rate" in res.summary()


def test_between_recordings_never_uses_the_left_out_recording() -> None:
    """Changing the output of recording j does not change the parameters chosen for j."""
    sc = make_periodic_set(BETA)
    recs = sc.records

    def chosen(rs):
        tr, te, _ = split_masks(rs, None, None)
        ctx = FitContext(rs, tr, te)
        s = Structure(tuple(baseline_thresholds(rs, tr, 12)), tuple(() for _ in rs))
        cur = ctx.fit(s)
        bt = between_recordings(ctx, "rate", cur)
        return bt, ctx, cur

    bt, ctx, cur = chosen(recs)
    wrecked = list(recs)
    r0 = recs[0]
    wrecked[0] = Recording(r0.t, r0.u, r0.y[::-1].copy(), name=r0.name)
    bt2, ctx2, _ = chosen(wrecked)
    assert bt2.per_recording[0]["parameters"] == bt.per_recording[0]["parameters"]
    # and the left-out residual is y_j minus a prediction that ignores y_j
    e = left_out_residual(ctx, cur.structure, 0)
    e2 = left_out_residual(ctx2, cur.structure, 0)
    np.testing.assert_allclose((r0.y - e), (wrecked[0].y - e2), rtol=1e-9, atol=1e-9)


def test_single_frequency_recordings_leave_rate_untestable() -> None:
    recs = make_periodic_set(BETA, freqs=(1.0, 1.0, 1.0), seed=1).records
    res = diagnose(recs)
    un = {u.name: u for u in res.untestable}
    assert "rate" in un and "single rate" in un["rate"].reason
    assert "rate" not in [f.name for f in res.effects]
    assert "Untestable: " in res.summary() and "rate" in res.summary()
    # what the one-rate loop widening was attributed to is reported ambiguous with rate
    for f in res.effects:
        if f.name in ("delay", "lag", "resonance"):
            assert any(a["effects"] == [f.name, "rate"] for a in res.ambiguous)
    assert any(f.name in ("delay", "lag", "resonance") for f in res.effects)


def test_periodic_steady_state_yields_no_initial_memory() -> None:
    """One cycle repeated after the plant reached its periodic steady state."""
    fs, f = 200.0, 1.0
    t = np.arange(int(6 * fs / f)) / fs
    u = 75.0 - 75.0 * np.cos(2 * np.pi * f * t + 1.0)  # starts mid-branch, not at an extreme
    y = truth_pi()(u)
    keep = slice(int(3 * fs / f), None)  # three warm-up cycles dropped
    rng = np.random.default_rng(3)
    rec = Recording(t[keep] - t[keep][0], u[keep], y[keep] + 0.02 * rng.standard_normal(
        t[keep].size), name="steady")
    res = diagnose(rec, effects=["initial-memory", "offset", "asymmetry"])
    assert res.effects == []
    un = {u.name: u.reason for u in res.untestable}
    assert "periodic steady state" in un["initial-memory"]
    # the baseline starts from the cycle's own memory: its residual is at the noise floor
    assert res.heldout_rmse(res.baseline) < 1.5 * 0.02


def test_virgin_start_of_a_periodic_input_is_not_steady_state() -> None:
    """The same input from the virgin state: the first period differs, no virtual history."""
    sc = make_periodic_set(None, freqs=(1.0,), cycles=3)
    assert steady_state_history(sc.records[0]) == ()
    fs = 40.0
    t = np.arange(240) / fs
    rng = np.random.default_rng(5)
    for phase in (0.0, 1.0, 2.5, 4.0):  # starting on either branch, near an extreme or not
        u = 75.0 - 75.0 * np.cos(2 * np.pi * t + phase)
        y = truth_pi()(u) + 0.02 * rng.standard_normal(u.size)
        assert steady_state_history(Recording(t, u, y)) == ()  # virgin start
        h = steady_state_history(Recording(t[80:] - t[80], u[80:], y[80:]))
        # the cycle's extremes; started from them the truth reproduces the steady record
        assert sorted(h) == pytest.approx([0.0, 150.0], abs=2.0)
        np.testing.assert_allclose(InitialMemory(truth_pi(), list(h))(u[80:]), y[80:],
                                   atol=0.3)


def test_friction_damper_at_two_rates_rate_tested_between_recordings_not_claimed() -> None:
    """Real recordings (a friction damper, rate-independent Coulomb-like sliding) at 0.25 and
    2 Hz: rate is tested by predicting each from the other, and not claimed."""
    from core.diagnosis.data import as_records

    d = "examples/data/friction_damper/"
    cols = {"time": "t_s", "input": "u_disp_in", "output": "y_force_kip"}
    slow = as_records(d + "0.25Hz30lbtension0.5amplitude.csv", **cols)[0].window(0, 8.5)
    fast = as_records(d + "2Hz30lbtension0.5amplitude.csv", **cols)[0]
    # (on the stop-operator base of clockwise loops rate is not modelled: the PI base)
    res = diagnose([slow, fast], n_operators=15, effects=["rate", "delay", "lag"], base="pi")
    assert "rate" not in [f.name for f in res.effects]
    assert "rate" not in {u.name for u in res.untestable}
    row = _rate_row(res)
    assert "leave-one-recording-out" in row["evidence"] and not row["passes"]
    assert [p["recording"] for p in row["per_recording"]] == [slow.name, fast.name]
    stop = diagnose([slow, fast], n_operators=15, effects=["rate"], max_effects=0)
    assert stop.base_choice is not None and stop.base_choice.kind == "stop-pi"
    (why,) = [u for u in stop.untestable if u.name == "rate"]
    assert "stop operators" in why.reason and "--base pi" in why.experiment


def test_the_untestable_rate_says_recording_or_recordings() -> None:
    """One recording at one rate: "the recording excites a single rate" (issue 33: the
    findings said "the recordings" of a single upload); two at one rate: "recordings"."""
    from core.diagnosis.effects.rate import _untestable

    rs = make_periodic_set(BETA).records[:1]

    def reason(recs: list[Recording]) -> str | None:
        tr, te, _ = split_masks(recs, None, None)
        return _untestable(FitContext(recs, tr, te))

    one = reason(rs)
    assert one is not None and one.startswith("the recording excites a single rate"), one
    two = reason([rs[0], rs[0]])
    assert two is not None and two.startswith("the recordings excite a single rate"), two
