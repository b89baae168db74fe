"""The Menegotto-Pinto base of the diagnosis (non-Masing loops): its bank is the registered
model, and on a steel plant it is chosen and lets a concealed drift be named."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.families import make_family
from core.diagnosis import diagnose
from core.diagnosis.bases import (
    MP_MIN_GAIN,
    element_bank,
    menegotto_pinto_elements,
    menegotto_pinto_model,
)
from core.nonmasing import MenegottoPintoModel


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_the_bank_is_the_registered_model_and_inverts(sign: float) -> None:
    """Columns times weights ``k' >= 0, w_i >= 0`` are the registered model's output (with
    and without a virtual history), in both orientations, and that model inverts: its
    smallest branch slope is ``k'``."""
    el = menegotto_pinto_elements(150.0, sign)
    rng = np.random.default_rng(3)
    u = np.cumsum(rng.normal(0.0, 3.0, 3000)) % 150.0
    k, w = 0.05, rng.uniform(0.0, 0.1, len(el))
    for hist in (None, (0.0, 150.0, 40.0)):
        B = element_bank(u, el, None if hist is None else np.asarray(hist))
        m = menegotto_pinto_model(k, w, el, None if hist is None else np.asarray(hist))
        assert isinstance(m, MenegottoPintoModel)
        np.testing.assert_allclose(B @ np.r_[k, w], m(u), rtol=0, atol=1e-9)
        assert m.slope_bounds()[0] == pytest.approx(k)
        np.testing.assert_allclose(m.inverse()(m(u)), u, rtol=0, atol=1e-9 * np.ptp(u))
        assert (sign * m.weights >= 0).all()


@pytest.fixture(scope="module")
def steel_drift():
    return diagnose(make_family("menegotto-pinto", "drift", "large", seed=500).records)


def test_a_steel_plant_gets_the_menegotto_pinto_base_and_its_drift_is_named(steel_drift) -> None:
    """The benchmark's Menegotto-Pinto plant (its own implementation of the steel law, four
    recordings) with a concealed drift: the stop base (Masing) missed 2.47 % of the range
    on the held-out rows, 11 times the noise, and the drift was named ``offset``. The
    Menegotto-Pinto base predicts each recording from the others better than the PI by
    more than the margin, misses < 1 % (0.45 %), and the drift is named first; the saved
    model's base is the registered model, which inverts."""
    res = steel_drift
    assert res.base_choice.kind == "menegotto-pinto"
    mp = [t for t in res.base_choice.tried if t.base == "menegotto-pinto"]
    assert mp[0].cv_mse_reduction >= MP_MIN_GAIN
    base = res.to_dict()["baseline"]
    assert base["model"] == "menegotto-pinto"
    rng = max(float(np.ptp(r.y)) for r in res.records)
    assert base["heldout_rmse"] < 0.01 * rng
    assert [e.name for e in res.effects][:1] == ["drift"]
    assert "Menegotto-Pinto" in res.summary()
    assert res.model.stages[0].type_name == "menegotto-pinto"
    rec = res.records[0]
    hyst = res.model.stages[0]
    y = hyst(rec.u)
    np.testing.assert_allclose(hyst.inverse()(y), rec.u, rtol=0,
                               atol=1e-9 * float(np.ptp(rec.u)))


def test_the_bank_does_not_replace_a_pi_a_loop_shape_explains() -> None:
    """The shipped MnZn ferrite B-H loops (four recordings): the bank predicts them 45 %
    better than the bare PI, more than its margin, but the PI with a tanh envelope (the
    saturation the effect search then names) predicts them far better still; the PI is kept
    and saturation is named (before the rule: the bank was chosen and its final model missed
    11 % of the range against 1 % for the PI with saturation)."""
    from pathlib import Path

    from core.fitting.choice import PREISACH_OVER_MAP

    path = Path(__file__).parents[3] / "examples" / "data" / "bh_loops" / "MnZn_HP_ferrite.csv"
    res = diagnose([path], effects=["saturation"])
    assert len(res.records) == 4
    mp = [t for t in res.base_choice.tried if t.base == "menegotto-pinto"]
    assert mp[0].cv_mse_reduction >= MP_MIN_GAIN
    sat = [t for t in res.base_choice.tried if t.base == "pi + saturation"]
    assert sat[0].rival is not None and sat[0].rival.base == "menegotto-pinto"
    assert sat[0].rival.mse_reduction < PREISACH_OVER_MAP
    assert res.base_choice.kind == "pi"
    assert [e.name for e in res.effects] == ["saturation"]
    assert "the Menegotto-Pinto" in res.base_choice.text


def test_a_mode_in_the_fast_recordings_does_not_hide_the_bank() -> None:
    """The benchmark's Menegotto-Pinto plant under the bipolar recordings with a concealed
    200 Hz mode (damping 0.05, the generator's truth). The mode's error in the 40-120 Hz
    recording is shared by every base and dilutes the bank's reduction against the stop
    base below its margin (33 %: the stop base was kept and the mode only suggested).
    Compared again with each base given its best output dynamics the bank is chosen, and the
    mode's search, started from a simplex spanning the grid cell (scipy's default stopped at
    damping 0.16), names it at the truth."""
    from benchmarks.diagnosis.bipolar import make_bipolar

    sc = make_bipolar("menegotto-pinto", "resonance", "large", seed=500)
    truth = sc.extras["hidden"]["resonance"]
    res = diagnose(sc.records, effects=["resonance"])
    mp = [t for t in res.base_choice.tried if t.base == "menegotto-pinto"]
    assert 0.0 < mp[0].cv_mse_reduction < MP_MIN_GAIN
    assert mp[0].cv_mse_reduction_with_dynamics is not None
    assert mp[0].cv_mse_reduction_with_dynamics >= MP_MIN_GAIN
    assert res.base_choice.kind == "menegotto-pinto"
    assert "with each its best output dynamics" in res.base_choice.text
    assert [e.name for e in res.effects] == ["resonance"]
    found = res.effects[0].parameters
    assert found["freq_hz"] == pytest.approx(truth["freq_hz"], rel=0.01)
    assert found["damping"] == pytest.approx(truth["damping"], rel=0.1)
