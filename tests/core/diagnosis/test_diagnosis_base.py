"""The base hysteresis is chosen before effects are judged (issue 16): on a plant that is not
a PI, a Preisach base (level-dependent memory, E10) is cross-validated on training blocks
against the PI, and concealed effects are judged against the better one. Truth plants from
the benchmark's non-PI families (an independent relay-bank Preisach, not the core model)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.families import make_family
from benchmarks.diagnosis.generator import make_scenario, make_shape
from core.boucwen import BoucWenModel
from core.diagnosis import diagnose
from core.diagnosis.basechoice import BW_MIN_GAIN, PREISACH_MIN_GAIN
from core.diagnosis.bases import bouc_wen_bank, bouc_wen_elements, bouc_wen_model, initial_state
from core.export_c import generate_c


@pytest.fixture(scope="module")
def preisach_null():
    return diagnose(make_family("preisach", None, "large", seed=500).records)


def test_a_preisach_plant_gets_a_preisach_base_and_no_effect(preisach_null) -> None:
    res = preisach_null
    assert res.base_choice.kind == "preisach"
    assert max(t.cv_mse_reduction for t in res.base_choice.tried) >= PREISACH_MIN_GAIN
    assert res.effects == []
    assert res.baseline.structure.levels
    # the saved model holds the registered Preisach stage, and inverts
    kinds = [getattr(s, "model", s).type_name for s in res.model.stages]
    assert "preisach" in kinds
    rec = res.records[0]
    y = res.model(rec.u, dt=rec.dt)
    u_back = res.model.inverse()(y, dt=rec.dt)
    np.testing.assert_allclose(u_back, rec.u, atol=1e-6 * float(np.ptp(rec.u)))
    assert res.to_dict()["baseline"]["model"] == "preisach"
    assert "level-dependent memory (E10)" in res.summary()


def test_a_pi_plant_keeps_its_pi_base() -> None:
    """The benchmark's B-PI null: neither the Preisach nor the Bouc-Wen alternative clears
    its margin."""
    res = diagnose(make_scenario(None, "white1", 1000).records)
    assert res.base_choice.kind == "pi"
    assert all(t.cv_mse_reduction < PREISACH_MIN_GAIN for t in res.base_choice.tried)
    bw = [t for t in res.base_choice.tried if t.base == "bouc-wen"]
    assert len(bw) == 1 and bw[0].cv_mse_reduction < BW_MIN_GAIN
    assert res.effects == []
    # the report says which bases were tried and how they did, not only when one replaces
    # the PI (a user whose model stays inadequate should see that the others were tried)
    lines = res.summary().splitlines()
    base = [ln for ln in lines if ln.startswith("Base: PI, kept")]
    assert len(base) == 1 and "bouc-wen" in base[0] and "preisach" in base[0]
    assert lines.index(base[0]) == 1 + next(i for i, ln in enumerate(lines)
                                            if ln.startswith("Baseline"))


@pytest.mark.parametrize(("effect", "param", "truth", "tol"), [
    ("creep", None, None, None),
    ("delay", "delay_s", 1e-3, 0.25),
    ("resonance", "freq_hz", 200.0, 0.10),
])
def test_concealed_effects_on_a_preisach_plant(effect, param, truth, tol) -> None:
    """Before (main 33fdfe8, PI base): creep missed (the PI misses ~3 % of range); the delay
    was found. Now both are named first. The 200 Hz resonance was missed until the base
    choice compared the Preisach with the PI + loop shape each with its best output
    dynamics: without it the resonance of the fast sines made the PI + asymmetry look as
    good as the Preisach (over it 0.23 < 0.3), the PI stayed and missed 6.5 % of range."""
    res = diagnose(make_family("preisach", effect, "large", seed=500).records)
    if effect in ("creep", "resonance"):  # (the delay lowers the base's gain below 0.65)
        assert res.base_choice.kind == "preisach"
    assert [e.name for e in res.effects][:1] == [effect]
    if param is not None:
        assert res.effects[0].parameters[param] == pytest.approx(truth, rel=tol)


@pytest.mark.parametrize(("make", "name"), [
    (lambda: make_scenario("asymmetry", "white1", 100), "asymmetry"),
    (lambda: make_shape("saturation", "white1", 100), "saturation"),
])
def test_a_static_output_map_is_named_not_taken_for_level_dependent_memory(make, name) -> None:
    """B-PI + a quadratic output map, B-PI + a saturating output map: a Preisach base predicts
    each recording from the others 89-98 % better than the PI, but no better than the PI with
    a static output map (PI + asymmetry; Kuhnen's MPI), so the PI stays and the map is named
    (notes 4.2). Without that comparison both became 'level-dependent memory'."""
    res = diagnose(make().records)
    assert res.base_choice.kind == "pi"
    pre = [t for t in res.base_choice.tried if t.base == "preisach"]
    assert max(t.cv_mse_reduction for t in pre) >= PREISACH_MIN_GAIN
    assert any(t.rival is not None and t.rival.base == "preisach"
               and t.rival.mse_reduction < 0.3 for t in res.base_choice.tried)
    assert [e.name for e in res.effects][:1] == [name]


def test_a_delay_that_lives_in_the_fast_recording_is_named() -> None:
    """Maxwell-slip (friction) plant with a 1 ms delay: the delay removes 61 % of the held-out
    MSE, but almost all of it in the fast sines, so the Diebold-Mariano z on all the test
    rows is 2.8 and the signed-rank p 0.38: before, only "suggestive". Tested also on the
    20 % of the test rows where it changes the prediction most, it is named, within 25 %."""
    res = diagnose(make_family("maxwell-slip", "delay", "large", seed=500).records)
    assert [e.name for e in res.effects][:1] == ["delay"]
    assert res.effects[0].parameters["delay_s"] == pytest.approx(1e-3, rel=0.25)


@pytest.fixture(scope="module")
def bouc_wen_null():
    return diagnose(make_family("bouc-wen-2", None, "large", seed=500).records)


def test_a_virgin_curve_unlike_the_pis_is_not_an_initial_memory(bouc_wen_null) -> None:
    """Bouc-Wen n = 2 null: its virgin curve differs from every PI's; the history search
    imitated it with a virtual excursion to -34.5 V, below every recorded input (0-150 V),
    and claimed initial-memory on a plant that had none. Virtual extrema now stay inside
    the recorded input range."""
    assert "initial-memory" not in [e.name for e in bouc_wen_null.effects]


def test_a_bouc_wen_plant_gets_a_bouc_wen_base_and_no_effect(bouc_wen_null) -> None:
    """The benchmark's Bouc-Wen plant (the benchmark's own RK4 integration, n = 2, four
    recordings): the Bouc-Wen base predicts each recording from the others better than the
    PI by more than the margin; the saved model holds the registered Bouc-Wen stage, which
    inverts and exports to C."""
    res = bouc_wen_null
    assert res.base_choice.kind == "bouc-wen"
    bw = [t for t in res.base_choice.tried if t.base == "bouc-wen"]
    assert bw[0].cv_mse_reduction >= BW_MIN_GAIN
    assert res.effects == []
    assert res.to_dict()["baseline"]["model"] == "bouc-wen"
    assert "Bouc-Wen" in res.summary()
    kinds = [s.type_name for s in res.model.stages]
    assert kinds[0] == "bouc-wen"
    rec = res.records[1]  # the fast sines
    y = res.model(rec.u, dt=rec.dt)
    u_back = res.model.inverse()(y, dt=rec.dt)
    np.testing.assert_allclose(u_back, rec.u, atol=1e-6 * float(np.ptp(rec.u)))
    assert "bouc" in generate_c(res.model, "bw").source.lower()
    # the final model predicts the recordings to the noise (0.2 um; the PI missed ~1.4 %)
    assert float(np.sqrt(np.mean((rec.y - res.model(rec.u, dt=rec.dt)) ** 2))) < 0.3


@pytest.mark.slow
def test_concealed_creep_on_a_bouc_wen_plant_is_named() -> None:
    """Bouc-Wen n = 2 plant + the small creep (three lags, 2 % of the stroke): on the PI base
    the creep absorbed part of the PI's misfit of the loop and did not carry over to other
    recordings (leave-one-recording-out MSE +233 %), so it was recording-specific and nothing
    was named. Judged against the Bouc-Wen base it generalises and is named, judged and
    fitted inside the holds, its total (sum of the bank's weights) the truth's 0.02 within
    its stated uncertainty (0.030 +- 0.021: the bank's fastest lag, 10 ms, stands for the
    truth's 5 ms one, which moves little from one block of the holds to the next)."""
    res = diagnose(make_family("bouc-wen-2", "creep", "small", seed=500).records)
    assert res.base_choice.kind == "bouc-wen"
    assert [e.name for e in res.effects][:1] == ["creep"]
    e = res.effects[0]
    total = float(np.sum(e.parameters["weights"]))
    sigma = e.uncertainty["gamma_per_decade"] * len(e.parameters["taus_s"])
    assert abs(total - 0.02) <= sigma and 0.01 < total < 0.04


def test_the_bouc_wen_bank_is_the_registered_model() -> None:
    """The diagnosis' columns times the weights are the registered model's output (its own
    integration, with and without a virtual history), and the weights it allows give an
    invertible model: the constraint k' >= 0, w_j >= 0 maps onto k - sum_j |c_j| m_j > 0."""
    el = bouc_wen_elements(150.0)
    rng = np.random.default_rng(3)
    u = np.cumsum(rng.normal(0.0, 3.0, 3000)) % 150.0
    k, w = 0.05, rng.uniform(0.0, 0.1, len(el))
    for hist in (None, (0.0, 150.0, 40.0)):
        B = bouc_wen_bank(u, el, hist)
        m = bouc_wen_model(k, w, el, initial_state(el, hist))
        assert isinstance(m, BoucWenModel)
        np.testing.assert_allclose(B @ np.r_[k, w], m(u), rtol=0, atol=1e-9)
        assert m.slope_bounds()[0] == pytest.approx(k)


def test_rate_dependent_relays_are_a_candidate_on_a_preisach_base() -> None:
    """The benchmark's Preisach plant with relay thresholds widened by 0.3 ms x |du/dt| (an
    independent relay bank), a slow and a fast sine: on a Preisach base (levelled plays) the
    rate candidate widens the plays' thresholds, finds beta near the truth, lowers the held-
    out error, and its saved stage is the registered rate-dependent Preisach, whose simulation
    is the fit's prediction. Before, the candidate was not built on a Preisach base (the run
    named lag and only flagged rate as 'not modelled')."""
    from benchmarks.diagnosis.families import make_base
    from core.diagnosis.candidates import build_candidate
    from core.diagnosis.context import FitContext
    from core.diagnosis.data import split_masks
    from core.diagnosis.grid import baseline_thresholds
    from core.diagnosis.structure import Structure
    from core.preisach import RateDependentPreisach
    from core.recordings import Recording

    plant = make_base("preisach", beta_s=3e-4, n_grid=40)
    rng = np.random.default_rng(1)
    recs = []
    for name, f, fs, dur in (("slow", 1.0, 2000.0, 2.0), ("fast", 50.0, 10000.0, 0.2)):
        t = np.arange(0, dur, 1 / fs)
        u = 75.0 - 75.0 * np.cos(2 * np.pi * f * t)
        recs.append(Recording(t, u, plant(u, dt=1 / fs) + rng.normal(0, 0.2, t.size), name))
    tr, te, _ = split_masks(recs, None, None)
    ctx = FitContext(recs, tr, te)
    # a base as fine as the diagnosis' Preisach choice (25 plays x 5 level segments): with
    # 12 plays x 3 segments the base misfit (held-out MSE 4 um^2 against 0.04 of noise) pulls
    # the full fit's beta to 4.7e-4; here the fit's optimum is within 17 % of the truth
    r = tuple(float(x) for x in baseline_thresholds(recs, tr, 25))
    cur = ctx.fit(Structure(r, ((),) * 2, levels=(30.0, 60.0, 90.0, 120.0), level_smooth=0.01))
    got = build_candidate(ctx, "rate", cur)
    assert got is not None
    fit, par, _ = got
    assert par["beta_s"] == pytest.approx(3e-4, rel=0.25)
    held = [np.concatenate([(rec.y - p)[m] for rec, p, m in zip(recs, f.pred, te, strict=True)])
            for f in (cur, fit)]
    assert np.mean(held[1] ** 2) < 0.8 * np.mean(held[0] ** 2)
    for model, rec, p in zip(fit.models, recs, fit.pred, strict=True):
        assert isinstance(model.stages[0], RateDependentPreisach)
        np.testing.assert_allclose(model(rec.u, dt=rec.dt), p, atol=1e-9)


def test_the_search_ranks_a_true_mode_above_none_on_a_preisach_base() -> None:
    """The benchmark's Duhem plant with the small concealed mode (346 Hz, zeta 0.05), on the
    Preisach base the diagnosis chooses for it (25 plays x 5 level segments): the training
    RSS that ranks nonlinear parameters (``FitContext.rss``) must rank the true mode above
    none and above a 3.7 kHz over-damped one, as the full fit does. Before, that RSS used
    24 leading directions of the 130 levelled columns: the true mode ranked worse than none
    (4745 against 4095), the search ended at 3.7 kHz and the run stayed 'suggestive'."""
    from core.diagnosis.context import FitContext
    from core.diagnosis.data import split_masks
    from core.diagnosis.grid import baseline_thresholds
    from core.diagnosis.structure import Structure

    recs = make_family("duhem", "resonance", "small", seed=500).records
    tr, te, _ = split_masks(recs, None, None)
    ctx = FitContext(recs, tr, te)
    lo = min(float(r.u[m].min()) for r, m in zip(recs, tr, strict=True))
    hi = max(float(r.u[m].max()) for r, m in zip(recs, tr, strict=True))
    knots = tuple(float(x) for x in lo + (hi - lo) * np.arange(1, 5) / 5)
    s = Structure(tuple(float(x) for x in baseline_thresholds(recs, tr, 25)),
                  tuple(() for _ in recs), levels=knots, level_smooth=0.01)
    cur = ctx.fit(s)
    none = ctx.rss(s, cur)
    true = ctx.rss(s.with_(dynamics=("resonance", 346.0, 0.05)), cur)
    wrong = ctx.rss(s.with_(dynamics=("resonance", 3730.0, 0.34)), cur)
    assert true < 0.8 * min(none, wrong)


def test_the_resolution_refinement_counts_a_preisach_base_s_weights() -> None:
    """The refinement after an accepted effect doubles the play grid while the bank's weights
    stay within its ceiling (4 x 25 in the diagnosis): on a Preisach base they are the plays
    times the level segments, so 25 plays x 5 segments (125 weights) are not doubled, while
    a PI of 25 plays is tried at 50. Counted in plays, the development Preisach plant with a
    200 Hz mode was refined to 100 plays x 5 segments and its diagnosis took 8 times the CPU
    time."""
    from benchmarks.diagnosis.families import make_base
    from core.diagnosis.accept import _refine_resolution
    from core.diagnosis.context import FitContext
    from core.diagnosis.data import split_masks
    from core.diagnosis.grid import baseline_thresholds
    from core.diagnosis.structure import Structure
    from core.recordings import Recording

    plant = make_base("preisach", n_grid=40)
    fs = 2000.0
    t = np.arange(0, 2.0, 1 / fs)
    u = 75.0 - 75.0 * np.cos(2 * np.pi * t)
    recs = [Recording(t, u, plant(u, dt=1 / fs) + np.random.default_rng(1).normal(0, 0.2, t.size),
                      "slow")]
    tr, te, _ = split_masks(recs, None, None)
    ctx = FitContext(recs, tr, te)
    r = tuple(float(x) for x in baseline_thresholds(recs, tr, 25))
    pi = ctx.fit(Structure(r, ((),)))
    preisach = ctx.fit(Structure(r, ((),), levels=(30.0, 60.0, 90.0, 120.0), level_smooth=0.01))
    rows: list = []
    assert _refine_resolution(ctx, preisach, 100, rows, 1) is preisach
    assert rows == []
    _refine_resolution(ctx, pi, 100, rows, 1)
    assert rows[0].effect == "resolution:50"
