"""Several effects, weak effects and single-recording users (issue 8): the acceptance rules 4
(a further effect earns its place on cross-fitted blocks) and 5 (the reversible/hysteretic
split against a delay or lag named for rate-dependent hysteresis), each with a scenario that
fails without it, and the typed round rows."""

from __future__ import annotations

import json

import pytest

import core.diagnosis.judge as judge
from benchmarks.diagnosis.generator import make_periodic_set, make_single_staircase
from core.diagnosis import diagnose
from core.diagnosis.acceptance import RULE, earns_place, split_supports_transport
from core.diagnosis.results import RoundRow
from core.diagnosis.stats import HeldOut


def test_split_rule_values() -> None:
    """Reversible and hysteretic slope coefficients (s) measured on the benchmark: a 20 us
    delay gives -1.5e-5 / -3.3e-5 (ratio 0.46 after the refit), a weak lag 0.34, rate-
    dependent thresholds +6e-6 / -7e-5 (the reversible part does not lag)."""
    assert split_supports_transport(-1.49e-5, -3.26e-5)
    assert split_supports_transport(-6.2e-6, -1.8e-5)
    assert not split_supports_transport(6.5e-6, -7.4e-5)
    assert not split_supports_transport(-1e-7, -6.4e-4)  # ratio 0.0002 < 0.15
    assert split_supports_transport(0.0, 0.0)  # nothing to compare: no contradiction
    assert RULE.min_rev_share == 0.15


def test_earns_place_rejects_what_the_blocks_do_not_confirm() -> None:
    ok = earns_place(HeldOut(1.0, 0.5, 0.5, 6.0, 1e-9, 40), 4, {"tau_s": 0.1}, ("creep",))
    assert ok.passes
    bad = earns_place(HeldOut(1.0, 0.96, 0.04, 1.0, 0.2, 40), 4, None, ("creep",))
    assert not bad.passes and "further effect on top of creep" in bad.reasons[0]
    assert "< 5 %" in bad.reasons[0]


@pytest.fixture(scope="module")
def weak_rate():
    """Four short periodic recordings (0.5-4 Hz, 3 cycles of 40 samples), a rate-dependent
    plant whose loop area grows by only 3 % from the slowest to the fastest."""
    sc = make_periodic_set(0.0006, seed=201)
    assert sc.extras["loop_area"][-1] / sc.extras["loop_area"][0] - 1 < 0.05
    return sc.records


def test_weak_rate_is_not_named_a_delay_or_lag(weak_rate, weak_rate_set_diagnosis) -> None:
    res = weak_rate_set_diagnosis  # diagnose(weak_rate), shared with test_results_json.py
    assert [f.name for f in res.effects] == []
    rows = {r.effect: r for r in res.rounds if r.round == 1}
    assert rows["delay"].decision == "contradicted" and rows["lag"].decision == "contradicted"
    assert "reversible" in rows["delay"].reasons[0]
    # abstaining is right here; what improved the fit is said, not claimed
    assert {"delay", "lag", "rate"} <= {s["effect"] for s in res.suggestive}


def test_without_the_split_rule_the_weak_rate_is_misnamed(weak_rate, monkeypatch) -> None:
    monkeypatch.setattr(judge, "split_supports_transport", lambda a, b: True)
    res = diagnose(weak_rate)
    assert res.effects and res.effects[0].name in ("delay", "lag")


@pytest.fixture(scope="module")
def creep_staircase():
    """A single-recording user: one up-then-down staircase with 2 s holds, creep plant."""
    return make_single_staircase("creep", "white1", 0).records


@pytest.fixture()
def drift_testable(monkeypatch):
    """A single 22 s record cannot test a drift (issue 16, failure 4); rule 4 is tested on it
    with the older 20 s limit, so that drift is a candidate here."""
    from core.diagnosis.effects import drift

    monkeypatch.setattr(drift, "SINGLE_DRIFT_S", 20.0)


@pytest.fixture()
def creep_on_every_row(monkeypatch):
    """Creep judged on every test row, as it is where no hold or repeated cycle localises it
    and as it was before it was judged inside the holds
    (:func:`core.diagnosis.effects.creep.hold_signature`). Inside the holds the staircase's
    drift in round 2 is no longer significant and the weak drift is not taken for creep, so
    rules 4 and 7, which guard every row, are tested on every row."""
    from dataclasses import replace

    from core.diagnosis import registry
    from core.diagnosis.effects.creep import cycle_signature

    monkeypatch.setitem(registry.EFFECTS, "creep",
                        replace(registry.EFFECTS["creep"], signature=cycle_signature))


@pytest.mark.slow
def test_a_further_effect_must_earn_its_place(creep_staircase, drift_testable,
                                              creep_on_every_row) -> None:
    res = diagnose(creep_staircase)
    assert [f.name for f in res.effects] == ["creep"]
    drift = next(r for r in res.rounds if r.round == 2 and r.effect == "drift")
    assert drift.decision == "not earned" and not drift.passes
    assert "on top of creep" in drift.reasons[0]


@pytest.mark.slow
def test_without_rule_4_the_staircase_claims_drift_too(creep_staircase, monkeypatch,
                                                      drift_testable, creep_on_every_row
                                                      ) -> None:
    monkeypatch.setattr(judge, "needs_earning", lambda ctx, c: False)
    res = diagnose(creep_staircase)
    assert [f.name for f in res.effects] == ["creep", "drift"]


def test_staircase_without_hidden_effect_claims_nothing() -> None:
    """Issue 8, failure 4: the null plant's staircase once had resonance claimed."""
    res = diagnose(make_single_staircase(None, "white1", 0).records)
    assert res.effects == []


def test_round_rows_are_typed_and_round_trip() -> None:
    row = RoundRow(2, "lag", 0.4, 3.1, 1e-4, True, "accepted", {"tau_s": 1e-4}, "test rows",
                   (), (("parameter_cv", {"tau_s": 0.1}),))
    d = row.to_dict()
    assert RoundRow.from_dict(json.loads(json.dumps(d))) == row
    assert d["parameter_cv"] == {"tau_s": 0.1} and row.detail("parameter_cv") == {"tau_s": 0.1}
    assert row["decision"] == "accepted" and "reasons" in row and "dm_z_pooled" not in row
    with pytest.raises(AttributeError):
        row.passes = False  # type: ignore[misc]


# ----------------------------------------------------------------------------- amplitudes
def test_amplitude_dependence_judged_between_recordings() -> None:
    """Four short periodic recordings at 25-100 % of the input range, the truth's quadratic
    output map: each recording predicted from the others (never from its own rows)."""
    from benchmarks.diagnosis.generator import make_amplitude_set

    res = diagnose(make_amplitude_set(0.9, seed=300).records)
    assert res.between is not None and res.between.amplitude
    assert [f.name for f in res.effects] == ["asymmetry"]
    row = next(r for r in res.rounds if r.round == 1 and r.effect == "asymmetry")
    assert "leave-one-recording-out" in row.evidence and len(row.detail("per_recording")) == 4
    null = diagnose(make_amplitude_set(None, seed=300).records)
    assert null.effects == []
    doc = null.to_dict()["between_recordings"]
    assert doc["amplitude"] == {"tested": True, "reason": ""}


def test_amplitude_test_untestable_with_reason() -> None:
    from core.diagnosis.between import amplitudes_differ
    from core.diagnosis.context import FitContext
    from core.diagnosis.data import split_masks

    def ctx(recs):
        tr, te, _ = split_masks(recs)
        return FitContext(recs, tr, te)

    from benchmarks.diagnosis.generator import make_amplitude_set

    same = make_amplitude_set(None, amps=(1.0, 1.0)).records
    ok, why = amplitudes_differ(ctx(same))
    assert not ok and "one input amplitude" in why
    ok, why = amplitudes_differ(ctx(same[:1]))
    assert not ok and why == "a single recording"
    from benchmarks.diagnosis.generator import make_scenario

    decaying = make_scenario(None).records[:1] + same[:1]
    ok, why = amplitudes_differ(ctx(decaying))
    assert not ok and "decaying sweeps several amplitudes" in why


def test_single_closed_loop_is_steady_state_not_initial_memory() -> None:
    """One closed loop cut from a periodic steady state (from the bottom of the cycle, where
    the virgin state differs from the cycle's own): recognised as steady state, so the
    memory at its first sample is the cycle's and initial-memory is untestable, not an
    artefact to claim."""
    import numpy as np

    from benchmarks.diagnosis.generator import truth_pi
    from core.fitting.steadystate import closed_loop_history, steady_state_history
    from core.recordings import Recording

    n = 200
    t = np.arange(3 * n + 1) / n
    u = 75 - 75 * np.cos(2 * np.pi * t)
    y = truth_pi()(u) + 0.02 * np.random.default_rng(0).standard_normal(u.size)
    rec = Recording(t[: n + 1], u[2 * n :], y[2 * n :], "loop")
    assert steady_state_history(rec) == closed_loop_history(rec) == (150.0, 0.0)
    # the cycle's memory reproduces the truth's steady state from the first sample on
    pred = truth_pi()(np.concatenate(([0.0, 150.0], rec.u)))[2:]
    assert np.max(np.abs(pred - truth_pi()(u)[2 * n :])) < 1e-9
    res = diagnose([rec])
    assert res.effects == []
    why = {x.name: x.reason for x in res.untestable}
    assert "single closed loop" in why["initial-memory"]
    # an open cycle (the output does not return) is not a closed loop
    assert closed_loop_history(Recording(rec.t, rec.u, rec.y + np.linspace(0, 5, rec.n_samples),
                                         "open")) == ()


@pytest.mark.slow
def test_two_effects_that_hide_each_other_are_both_found(
        resonance_and_drift_diagnosis) -> None:
    """Issue 8, failure 4 (resonance + drift, L2): the resonance explains 92 % of the
    held-out MSE but fails significance while the drift is unmodelled, and the drift alone
    makes the test rows worse; nothing passes on the baseline, so without rule 6 nothing is
    claimed. The drift passes on top of the resonance, the resonance on top of the drift."""
    res = resonance_and_drift_diagnosis  # shared with test_results_json.py (conftest.py)
    assert [f.name for f in res.effects] == ["resonance", "drift"]
    assert "judged on top of drift" in res.effects[0].evidence
    r1 = [r for r in res.rounds if r.round == 1 and ":" not in r.effect]
    assert [r.effect for r in r1 if r.passes] == ["resonance"]
    assert res.effects[0].parameters["freq_hz"] == pytest.approx(400.0, rel=0.03)


def test_sign_locking_rule_values() -> None:
    """Shares measured on the benchmark (10 holds): hidden creep 0.9-1.0, hidden drift
    0.5-0.7; fewer than 4 holds decide nothing."""
    from core.diagnosis.acceptance import trend_follows_steps

    assert trend_follows_steps(1.0, 10) and trend_follows_steps(0.9, 10)
    assert not trend_follows_steps(0.7, 10) and not trend_follows_steps(0.5, 10)
    assert trend_follows_steps(0.0, 3) and trend_follows_steps(None, 0)


@pytest.fixture(scope="module")
def weak_drift():
    """A weak additive drift (0.045 um scale) in the three benchmark recordings."""
    from benchmarks.diagnosis.generator import make_weak

    return make_weak("drift", "white1", 100).records


@pytest.mark.slow
def test_weak_drift_is_not_taken_for_creep_inside_the_holds(weak_drift) -> None:
    """Inside the staircase's holds a drift does not follow the sign of each step: the
    creep fitted on the changes there removes too little of them (rule 7 is not needed)."""
    res = diagnose(weak_drift)
    assert "creep" not in [f.name for f in res.effects]
    creep = next(r for r in res.rounds if r.round == 1 and r.effect == "creep")
    assert creep.decision == "rejected" and "inside the 10 holds" in creep.evidence


@pytest.mark.slow
def test_weak_drift_is_not_named_creep(weak_drift, creep_on_every_row) -> None:
    res = diagnose(weak_drift)
    assert "creep" not in [f.name for f in res.effects]
    creep = next(r for r in res.rounds if r.round == 1 and r.effect == "creep")
    assert creep.decision == "contradicted" and "sign of the step" in creep.reasons[0]
    # no wrong name: what is claimed is the drift or is reported ambiguous with it (an
    # offset per recording explains as much of a slow drift as the drift itself here)
    for f in res.effects:
        assert f.name == "drift" or "drift" in f.ambiguous_with, (f.name, f.ambiguous_with)
    assert all(a["experiment"].startswith("a zero-input hold") for a in res.ambiguous
               if set(a["effects"]) == {"offset", "drift"})


@pytest.mark.slow
def test_without_the_offset_drift_lookalike_the_weak_drift_is_named_offset(
        weak_drift, monkeypatch) -> None:
    from dataclasses import replace

    from core.diagnosis import registry

    monkeypatch.setitem(registry.EFFECTS, "offset",
                        replace(registry.EFFECTS["offset"], lookalikes=()))
    res = diagnose(weak_drift)
    assert [(f.name, f.ambiguous_with) for f in res.effects] == [("offset", [])]


@pytest.mark.slow
def test_without_rule_7_the_weak_drift_is_named_creep(weak_drift, monkeypatch,
                                                     creep_on_every_row) -> None:
    monkeypatch.setattr(judge, "trend_follows_steps", lambda share, holds: True)
    res = diagnose(weak_drift)
    assert [f.name for f in res.effects][:1] == ["creep"]
