"""Holds after an input change (a step or a ramp) make creep testable (issue 16, failure 2):
the ramp-and-hold relaxation test is the standard creep experiment."""

from __future__ import annotations

import numpy as np
import pytest

from core.base import Chain
from core.diagnosis import diagnose
from core.diagnosis.locate import Coordinates
from core.pi import PIModel
from core.recordings import Recording
from core.stages import Creep


def _rec(t: np.ndarray, u: np.ndarray) -> Recording:
    return Recording(t, u, u, "r")


def test_holds_follow_steps_and_ramps_not_sines() -> None:
    fs = 100.0
    t = np.arange(0, 30, 1 / fs)
    # ramp up over 4 s, hold 6 s, ramp down over 10 s (slow), hold to the end
    u = np.interp(t, [0, 4, 10, 20, 30], [0, 2, 2, 0.5, 0.5])
    holds = Coordinates(_rec(t, u)).holds
    assert [(round(h0 / fs, 1), s) for h0, _, s in holds] == [(4.0, 1.0), (20.0, -1.0)]
    assert holds[0][1] / fs >= 5.9
    sine = Coordinates(_rec(t, np.sin(2 * np.pi * t))).holds
    assert sine == []
    # a step sampled fast
    fs = 1000.0
    t = np.arange(0, 3, 1 / fs)
    u = np.where(t < 1, 0.0, np.where(t < 2, 1.0, 0.3))
    assert [(round(h0 / fs, 2), s) for h0, _, s in Coordinates(_rec(t, u)).holds] == [
        (1.0, 1.0), (2.0, -1.0)]


def _relaxation_records(plant, seed: int = 0) -> list[Recording]:
    """A ramp to a level in 4 s then a 10 min hold, plus load-unload ramps at three rates."""
    rng = np.random.default_rng(seed)
    recs = []
    fs = 10.0
    t = np.arange(0, 604, 1 / fs)
    u = np.minimum(t / 4, 1.0) * 2.0
    recs.append(Recording(t, u, plant(u, dt=1 / fs) + 0.003 * rng.standard_normal(t.size),
                          "relax"))
    for period in (2.0, 10.0, 50.0):
        fs = 200 / period
        t = np.arange(0, 3 * period, 1 / fs)
        u = 2.0 * (1 - np.abs(((t / period) % 1) * 2 - 1))
        recs.append(Recording(t, u, plant(u, dt=1 / fs) + 0.003 * rng.standard_normal(t.size),
                              f"ramps {period:g} s"))
    return recs


def _pi() -> PIModel:
    r = np.linspace(0.1, 1.8, 8)
    return PIModel(0.3, r, 0.08 * np.exp(-r))


def test_ramp_and_hold_relaxation_is_a_creep_test() -> None:
    """Before: creep 'untestable: no step followed by a hold', offset and drift claimed."""
    plant = Chain.of(_pi(), Creep([1.0, 10.0, 100.0], [0.05, 0.05, 0.05]))
    res = diagnose(_relaxation_records(plant))
    assert "creep" not in {u.name for u in res.untestable}
    assert [e.name for e in res.effects][:1] == ["creep"]
    assert "drift" not in [e.name for e in res.effects]


def test_ramp_and_hold_without_creep_claims_nothing() -> None:
    res = diagnose(_relaxation_records(_pi(), seed=3))
    assert res.effects == []


def test_an_effect_that_does_not_generalise_is_recording_specific() -> None:
    """Issue 16, failure 3 (acceptance rule 8): a Preisach actuator (not a PI) with creep,
    creep not among the effects tested, the base held to a PI. One offset per recording
    passes on the recordings it
    was fitted on (it absorbs part of the PI's misfit of each), but each recording predicted
    from the others, with its own level, is worse with it (shared leave-one-recording-out
    MSE -6 %). Before: offset claimed as physics. Now: recording-specific, with the numbers,
    and not in the final model."""
    from benchmarks.diagnosis.families import make_family

    sc = make_family("preisach", "creep", "large", seed=500)
    res = diagnose(sc.records, effects=["drift", "offset", "lag", "delay"], base="pi")
    assert "offset" not in [e.name for e in res.effects]
    spec = {r.name: r for r in res.recording_specific}
    assert "offset" in spec and spec["offset"].loro_mse_reduction < -0.05
    assert "times worse" in spec["offset"].text
    assert "one per recording" in spec["offset"].text
    assert not res.final.structure.term("offset")
    doc = res.to_dict()
    assert doc["recording_specific"][0]["name"] == "offset"
    assert "Recording-specific, not claimed: offset" in res.summary()


def test_generalisation_rule_threshold() -> None:
    from core.diagnosis.acceptance import RULE, generalises

    assert generalises(None) and generalises(0.3) and generalises(-RULE.max_loro_loss)
    assert not generalises(-RULE.max_loro_loss - 0.01) and not generalises(-2.86)


@pytest.mark.slow
def test_creep_is_not_judged_on_the_recording_that_holds_every_hold() -> None:
    """Acceptance rule 8 scores a left-out recording only when the other recordings can test
    the effect. A Preisach actuator with a small creep (2 % of a step), four recordings, the
    staircase the only one with holds: creep fitted on the other three (no hold: creep is
    untestable there) mispredicts the staircase, which made creep "recording-specific"
    (leave-one-recording-out MSE +19 %) although the three recordings predicted from the
    others all improve. Now the staircase is not scored (said so, with its numbers) and
    creep is named."""
    from benchmarks.diagnosis.families import make_family
    from core.diagnosis.acceptance import RULE

    sc = make_family("preisach", "creep", "small", seed=500)
    res = diagnose(sc.records, effects=["creep"])
    assert [e.name for e in res.effects] == ["creep"]
    lo = res.effects[0].loro
    per = {r["recording"]: r for r in lo["per_recording"]}
    assert per["staircase"]["scored"] is False
    assert "cannot test creep" in per["staircase"]["why"]
    assert per["staircase"]["rmse_after"] > per["staircase"]["rmse_before"]
    assert all(r["scored"] and r["rmse_after"] < r["rmse_before"]
               for n, r in per.items() if n != "staircase")
    # every recording pooled, as before the rule: the effect would be dropped
    assert lo["mse_reduction_all"] < -RULE.max_loro_loss < 0 < lo["mse_reduction"]
    assert res.recording_specific == []


@pytest.mark.slow
def test_the_creep_total_carries_the_uncertainty_of_its_bank() -> None:
    """A creep bank of one lag per decade from 10 ms cannot hold a 5 ms relaxation exactly:
    on a Preisach actuator with creep lags 5 ms, 0.1 s and 5 s (6 % of a step in total) the
    total came out 0.054 +- 0.001 (block jackknife), -10 % off at 6 sigma. The accepted creep
    is refitted with its bank shifted half a decade down and up, and the change of the total
    widens its sigma: the truth is now inside it. Judged and fitted inside the holds, from
    the changes between blocks of 10 ms, the 10 ms lag that stands for the 5 ms one is less
    determined: 0.070 +- 0.033 (the bank's shift alone 0.030)."""
    from benchmarks.diagnosis.families import make_family

    sc = make_family("preisach", "creep", "large", seed=500)
    res = diagnose(sc.records, effects=["creep"])
    (e,) = res.effects
    total = float(np.sum(e.parameters["weights"]))
    sigma = e.uncertainty["gamma_per_decade"] * len(e.parameters["taus_s"])
    assert total == pytest.approx(0.06, rel=0.2)
    assert abs(total - 0.06) <= sigma < 0.6 * total
    assert "bank shifted by 0.5 decade" in e.uncertainty_method
