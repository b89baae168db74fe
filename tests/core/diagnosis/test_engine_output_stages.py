"""Output dynamics look-alikes under further effects (issue 16): two stages in series (a lag
then a mode), look-alikes that are not clearly beaten, and both stages of a pair named
(acceptance rules 10, 11 and 12)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.families import make_family
from core.base import Chain
from core.diagnosis import diagnose
from core.diagnosis.acceptance import (
    RULE,
    clearly_better,
    pair_beats_single,
    second_stage_named,
)
from core.diagnosis.registry import EFFECTS
from core.diagnosis.stats import HeldOut
from core.diagnosis.structure import Structure, _dyn_rows, build_model, dynamics_stages
from core.pi import PIModel
from core.stages import Lag, Offset, Resonance


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
    m = build_model(s, 0, 0.5, np.array([0.1, 0.05]), {"offset": np.zeros(1)},
                    None)  # type: ignore[arg-type]
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


def test_a_lag_and_a_mode_in_series_are_both_named_and_saved(lag_and_mode_on_bouc_wen) -> None:
    """Rule 12 on the same plant: the lag and the mode each beat the other alone,
    re-optimised alone, on the held-out rows and on cross-fitted training blocks in every
    recording, so both are named (before: a delay named, the pair only flagged), with the
    hidden values, no longer ambiguous with each other. The saved model runs the lag then
    the mode, inverts and exports to C."""
    from core.export_c import generate_c

    res = lag_and_mode_on_bouc_wen
    found = {f.name: f.parameters for f in res.effects}
    assert {"lag", "resonance"} <= set(found), found
    assert "delay" not in found
    assert abs(found["lag"]["tau_s"] / 1e-3 - 1) < 0.15
    assert abs(found["resonance"]["freq_hz"] / 200.0 - 1) < 0.10
    assert found["resonance"]["damping"] < 0.2  # rings, as the hidden 0.05 mode does
    assert not any({"lag", "resonance"} <= set(a["effects"]) for a in res.ambiguous)
    kinds = [type(st) for st in res.model.stages]
    assert Lag in kinds and Resonance in kinds
    assert kinds.index(Lag) < kinds.index(Resonance)
    assert res.model.inverse() is not None
    dt = min(r.dt for r in res.records)
    src = generate_c(res.model, "lr", dt=dt).source
    assert src.lower().count("lag") and src.lower().count("reson")


def test_one_of_two_stages_is_switched_off_alone() -> None:
    """``Structure.without`` takes one stage of two out and keeps the other (the LORO and
    recording-specific checks judge each named stage)."""
    s = Structure(thresholds=(10.0,), history=((),), dynamics=("lag", 1e-3, "resonance",
                                                                 200.0, 0.05))
    base = s.with_(dynamics=())
    assert s.without("lag", base).dynamics == ("resonance", 200.0, 0.05)
    assert s.without("resonance", base).dynamics == ("lag", 1e-3)
    assert Structure(thresholds=(10.0,), history=((),), dynamics=("lag", 1e-3)).without(
        "lag", base).dynamics == ()


def test_a_lag_is_named_before_a_mode_only_with_its_corner_near_the_mode() -> None:
    """Rule 12's signature of a lag in series with a mode: its corner frequency
    ``1 / (2 pi tau)`` within two octaves above the mode (beyond, the mode has cut the
    output to about 1/15, |H| = 1 / ((f / f_n)^2 - 1) at 4 f_n, and the lag adds only a
    delay-like phase) and at least half a sample period. The 3 ns "lag" credited with a
    refit of the mode's damping has none; the benchmark's hidden lags have it."""
    lacks = EFFECTS["lag"].dynamics.lacks_signature_in_series
    mode = (200.0, 0.05)
    f_n, z = mode
    gain_4 = 1.0 / np.hypot(1 - 16.0, 2 * z * 4.0)  # the mode's gain at 4 f_n
    assert gain_4 < 1.0 / 14  # (about 1/15: the mode passes almost nothing beyond)
    assert lacks((3e-9,), (230.0, 0.1), 1e-4)  # the reverted run's "lag"
    assert lacks((1.0 / (2 * np.pi * 5 * f_n),), mode, 1e-5)  # corner at 5 f_n
    assert lacks((1.0 / (2 * np.pi * 3 * f_n),), mode, 1e-5) is None  # corner at 3 f_n
    assert lacks((0.4e-4,), (10.0, 0.05), 1e-4)  # below half a sample
    assert lacks((1e-3,), mode, 1e-4) is None  # Bouc-Wen case: 1 ms, 200 Hz, 10 kHz
    assert lacks((150e-6,), (400.0, 0.05), 2e-4) is None  # B-PI L2: 0.15 ms, 400 Hz, 5 kHz


def test_a_second_stage_needs_size_and_significance_on_test_rows_and_blocks() -> None:
    """Rule 12's comparison with the other stage alone: rules 1-2 on the held-out rows and
    on the cross-fitted training blocks (measured values: the Bouc-Wen lag, 87 % / z 10.4
    on the test rows; the Maxwell-slip lag, 28 % / z 10.6 there but -2 % on the blocks; the
    B-PI L2 lag, 43 % but z 1.9, p 0.07 on the blocks)."""
    assert second_stage_named(_h(1.0, 0.13, 10.4, 1e-12), _h(1.0, 0.5, 4.0, 1e-6))
    assert not second_stage_named(_h(1.0, 0.72, 10.6, 3e-8), _h(1.0, 1.02, -3.7, 1.0))
    assert not second_stage_named(_h(1.0, 0.57, 4.6, 9e-9), _h(1.0, 0.57, 1.9, 0.075))
    assert not second_stage_named(_h(1.0, 0.97, 10.0, 1e-9), _h(1.0, 0.5, 4.0, 1e-6))


def _mode_alone_on_bouc_wen(monkeypatch=None):
    """Bouc-Wen n = 1 actuator + a 568 Hz mode (damping 0.05) and no lag (the benchmark's
    eighth case, seed 500, 0.2 um noise): a lag of a few us fitted with the mode beats the
    mode as first fitted (rule 11). With ``monkeypatch``, the mode's search starts from the
    7-point grid of round 4: the mode as first fitted is then poorer than the finer grid's
    and the pair with a lag is tried (rule 12 is exercised); with the finer grid it is not
    needed. The refinement from that grid is round 4's too (16 evaluations from a simplex
    like scipy's default, 5 % of each coordinate of ``(log f, log zeta)``): from a simplex
    spanning the grid cell the mode is fitted well enough that no pair is tried."""
    from benchmarks.diagnosis.classes import _scenario

    if monkeypatch is not None:
        from core.diagnosis.effects import resonance

        monkeypatch.setattr(resonance, "grid_frequencies",
                            lambda fmin, fmax: np.geomspace(fmin, fmax, 7))
        monkeypatch.setattr(resonance, "SEARCH_MAXFEV", 16)
        monkeypatch.setattr(resonance, "_simplex_steps",
                            lambda fs, zs: np.array([[0.0, 0.0], [0.32, 0.0], [0.0, -0.08]]))
    sc = _scenario("eighth", "bouc-wen-1/resonance/eighth", "white1", 500)
    return diagnose(sc.records, effects=("delay", "lag", "resonance"))


def test_a_mode_alone_gets_no_lag_in_series(monkeypatch) -> None:
    """Rule 12 on a plant without a lag: the pair with a 2.9 us "lag" beats the mode as
    first fitted, but the lag has no signature of its own (its corner lies far beyond the
    mode) and is not named; the mode is."""
    named = [f.name for f in _mode_alone_on_bouc_wen().effects]
    assert "resonance" in named and "lag" not in named, named  # the search grid of now
    res = _mode_alone_on_bouc_wen(monkeypatch)  # the coarser grid: rule 12 decides
    named = [f.name for f in res.effects]
    assert "resonance" in named and "lag" not in named, named
    row = next(r for r in res.rounds if r.effect == "second stage:lag")
    assert row.decision == "rejected"


def test_a_second_stage_is_credited_only_with_what_it_adds(monkeypatch) -> None:
    """Rule 12's baseline: with the lag's signature condition switched off, the pair is
    compared with the mode re-optimised alone (the optimiser budget the pair had), and the
    few-us "lag" on a plant without one adds nothing over it (before: the comparison with
    the mode as first fitted credited the lag with the joint refit of the mode: 26 % less
    held-out MSE, DM z 10.2)."""
    import core.diagnosis.effects.lag as lag_module

    monkeypatch.setattr(lag_module, "LAG_CORNER_MAX_OVER_MODE", 1e12)
    monkeypatch.setattr(lag_module, "LAG_MIN_SAMPLES", 0.0)
    res = _mode_alone_on_bouc_wen(monkeypatch)
    assert "lag" not in [f.name for f in res.effects]
    row = next(r for r in res.rounds if r.effect == "second stage:lag")
    assert row.heldout_mse_reduction < RULE.min_gain, row  # the truth holds no lag


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
