"""Output dynamics look-alikes under further effects (issue 16): two stages in series (a lag
then a mode) and look-alikes that are not clearly beaten (acceptance rules 10 and 11)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.families import make_family
from core.base import Chain
from core.diagnosis import diagnose
from core.diagnosis.acceptance import RULE, clearly_better, pair_beats_single
from core.diagnosis.stats import HeldOut
from core.diagnosis.structure import Structure, _dyn_rows, build_model, dynamics_stages
from core.effects import Lag, Offset, Resonance
from core.pi import PIModel


def _h(before: float, after: float, z: float, p: float) -> HeldOut:
    return HeldOut(before, after, 1.0 - after / before, z, p, 40)


def test_two_stages_in_series_are_simulated_as_the_chain_of_their_models() -> None:
    """The structure's filtered design rows of ``lag then resonance`` equal the core models
    ``Lag`` and ``Resonance`` run one after the other (an independent implementation), the
    structure names both, and the saved chain holds both stages and inverts."""
    dyn = ("lag", 1e-3, "resonance", 200.0, 0.05)
    assert dynamics_stages(dyn) == [("lag", (1e-3,)), ("resonance", (200.0, 0.05))]
    dt = 1e-4
    t = np.arange(4000) * dt
    x = np.column_stack((np.sin(2 * np.pi * 20 * t), np.sign(np.sin(2 * np.pi * 7 * t))))
    rows = np.arange(0, 4000, 3)
    got = _dyn_rows(x, dyn, dt, rows)
    ref = np.column_stack([Resonance(200.0, 0.05)(Lag(1e-3)(x[:, j], dt=dt), dt=dt)
                           for j in range(2)])[rows]
    assert np.max(np.abs(got - ref)) < 1e-9 * np.max(np.abs(ref))
    s = Structure(thresholds=(10.0, 20.0), history=((),), dynamics=dyn)
    assert {"lag", "resonance"} <= set(s.effects)
    m = build_model(s, 0, 0.5, np.array([0.1, 0.05]), np.zeros(0), 0.0, 1.0, np.zeros(0),
                    np.zeros(1), [np.zeros(0)], None)  # type: ignore[arg-type]
    assert isinstance(m, Chain)
    kinds = [type(st) for st in m.stages]
    assert Lag in kinds and Resonance in kinds
    u = 75 + 70 * np.sin(2 * np.pi * 5 * t)
    ref_y = Offset(0.0)(Resonance(200.0, 0.05)(Lag(1e-3)(
        PIModel(0.5, np.array([10.0, 20.0]), np.array([0.1, 0.05]))(u), dt=dt), dt=dt))
    assert np.allclose(m(u, dt=dt), ref_y, rtol=0, atol=1e-9 * np.ptp(ref_y))
    assert m.inverse() is not None


def test_a_lookalike_stage_is_ruled_out_only_when_clearly_worse() -> None:
    """Rule 10: significant and more than 10 % more held-out MSE rules a look-alike out;
    significant but within the margin (or not significant) leaves it open."""
    assert RULE.clear_margin == 0.10
    assert clearly_better(_h(1.2, 1.0, 5.0, 1e-6))
    assert not clearly_better(_h(1.095, 1.0, 3.1, 0.0015))  # the B-PI delay vs lag
    assert not clearly_better(_h(2.0, 1.0, 2.0, 0.05))  # not significant
    assert clearly_better(_h(2.0, 1.0, 2.0, 0.001))  # the signed-rank test suffices


def test_two_stages_beat_one_only_by_size_and_significance() -> None:
    """Rule 11: the pair must reduce the single stage's held-out MSE by the effect size of
    rule 1 (5 %) and significantly."""
    assert pair_beats_single(_h(1.0, 0.18, 10.9, 1e-9))
    assert not pair_beats_single(_h(1.0, 0.96, 6.0, 1e-9))  # too small
    assert not pair_beats_single(_h(1.0, 0.5, 2.7, 0.0104))  # not significant


@pytest.fixture(scope="module")
def lag_and_mode_on_bouc_wen():
    """Bouc-Wen n = 1 actuator + a 1 ms lag, a 200 Hz mode (damping 0.05) and offsets (the
    benchmark's three-effect case, seed 500, 0.2 um noise); the output dynamics and the
    offset are tested."""
    sc = make_family("bouc-wen-1", "lag+resonance+offset", "large", seed=500)
    return diagnose(sc.records, effects=("delay", "lag", "resonance", "offset"))


def test_a_lag_and_a_mode_in_series_are_named_or_flagged(lag_and_mode_on_bouc_wen) -> None:
    """A single 1.1 ms delay stands in for the lag and the mode and is named; neither
    hidden stage was named or reported ambiguous with it (the look-alikes alone are
    significantly worse). Rule 11: the lag and the mode fitted together predict the
    held-out rows far better than the delay, so each hidden stage is named or reported
    ambiguous with the stage that is."""
    res = lag_and_mode_on_bouc_wen
    named = [f.name for f in res.effects]
    dyn = [f for f in res.effects if f.name in ("delay", "lag", "resonance")]
    assert dyn, named
    for hidden in ("lag", "resonance"):
        assert hidden in named or any(
            set(a["effects"]) == {dyn[0].name, hidden} for a in res.ambiguous), (
            hidden, named, [a["effects"] for a in res.ambiguous])
    pair = [r for r in res.rounds if r.effect == "recheck:lag+resonance"]
    assert pair, "the pair was not fitted"
    p = pair[0].parameters
    # the pair found the hidden stages (an independent check that it is not a fudge)
    assert abs(p["lag.tau_s"] / 1e-3 - 1) < 0.25
    assert abs(p["resonance.freq_hz"] / 200.0 - 1) < 0.10


def test_a_delay_under_creep_and_drift_is_not_ruled_out_by_a_small_difference() -> None:
    """B-PI plant + 0.1 ms delay, creep and drift (the benchmark's three-effect case,
    0.02 um noise): a lag is named, and the delay predicts the held-out rows only some per
    cent worse once the drift is in (DM z about 3.1). Rule 10 reports the delay ambiguous
    with the lag; before, the significant difference alone ruled it out."""
    from benchmarks.diagnosis.generator import make_combo

    sc = make_combo(("delay", "creep", "drift"), "white1", 100, level="L2")
    res = diagnose(sc.records, effects=("delay", "lag", "resonance", "creep", "drift"))
    named = [f.name for f in res.effects]
    assert "delay" in named or any(
        "delay" in a["effects"] and set(a["effects"]) & set(named) for a in res.ambiguous), (
        named, [a["effects"] for a in res.ambiguous])
