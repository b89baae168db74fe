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
from core.diagnosis.bases import bouc_wen_bank, bouc_wen_elements, bouc_wen_model, initial_state
from core.diagnosis.engine import BW_MIN_GAIN, PREISACH_MIN_GAIN
from core.export_c import generate_c


@pytest.fixture(scope="module")
def preisach_null():
    return diagnose(make_family("preisach", None, "large", seed=500).records)


def test_a_preisach_plant_gets_a_preisach_base_and_no_effect(preisach_null) -> None:
    res = preisach_null
    assert res.base_choice.kind == "preisach"
    assert max(t["cv_mse_reduction"] for t in res.base_choice.tried) >= PREISACH_MIN_GAIN
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
    assert all(t["cv_mse_reduction"] < PREISACH_MIN_GAIN for t in res.base_choice.tried)
    bw = [t for t in res.base_choice.tried if t["base"] == "bouc-wen"]
    assert len(bw) == 1 and bw[0]["cv_mse_reduction"] < BW_MIN_GAIN
    assert res.effects == []


@pytest.mark.parametrize(("effect", "param", "truth", "tol"), [
    ("creep", None, None, None),
    ("delay", "delay_s", 1e-3, 0.25),
])
def test_concealed_effects_on_a_preisach_plant(effect, param, truth, tol) -> None:
    """Before (main 33fdfe8, PI base): creep missed (the PI misses ~3 % of range); the delay
    was found. Now both are named first (a concealed resonance is still missed: DM z 2.8
    on the test rows)."""
    res = diagnose(make_family("preisach", effect, "large", seed=500).records)
    if effect == "creep":  # (the delay of the fast sines lowers the base's gain below 0.65)
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
    pre = [t for t in res.base_choice.tried if t["base"] == "preisach"]
    assert max(t["cv_mse_reduction"] for t in pre) >= PREISACH_MIN_GAIN
    assert any(t.get("preisach_mse_reduction_over_it", 1.0) < 0.3
               for t in res.base_choice.tried)
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
    bw = [t for t in res.base_choice.tried if t["base"] == "bouc-wen"]
    assert bw[0]["cv_mse_reduction"] >= BW_MIN_GAIN
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
    was named. Judged against the Bouc-Wen base it generalises and is named, its total
    (sum of the bank's weights) near the truth's 0.02."""
    res = diagnose(make_family("bouc-wen-2", "creep", "small", seed=500).records)
    assert res.base_choice.kind == "bouc-wen"
    assert [e.name for e in res.effects][:1] == ["creep"]
    assert sum(res.effects[0].parameters["weights"]) == pytest.approx(0.02, rel=0.25)


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
