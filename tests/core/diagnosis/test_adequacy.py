"""The base-model verdict names what the better class found and what it leaves."""

from __future__ import annotations

import numpy as np

from core.datasets import load_dataset
from core.diagnosis.adequacy import assess
from core.fitting import PIRegressor, StopPIRegressor


def test_friction_damper_verdict_names_plateau_backlash_and_what_is_left() -> None:
    rec = load_dataset("friction-1Hz-30lb")
    n = rec.n_samples
    train = np.arange(n) < int(0.8 * n)
    test = ~train
    base = PIRegressor(constraint="slopes").fit(rec.u, rec.y, train=train, test=test)
    pred = base.predict(rec.u)
    ad = assess([rec], [train], [test], [pred], 0.03, ["delay"], free_weights=True)
    assert not ad.adequate
    assert ad.loop_shapes[0].model == "stop-pi"
    text = ad.text
    assert "friction plateau" in text and " kip " in text
    width = float(text.split("backlash dead band ")[1].split(" in wide")[0])
    assert 0.1 < width < 0.17  # the shelf at zero force, 0.10-0.15 in per transition
    # what the stop-operator base with its gap leaves repeats from cycle to cycle
    assert "repeats between input cycles with the same input" in text
    assert "deterministic, not noise" in text and "sliding plateaus" in text


def test_the_friction_class_is_named_even_when_it_is_not_clearly_better() -> None:
    # a final model as good as the stop-operator class itself (it is that fit): no class is
    # clearly better, and the verdict still says what the friction class finds in the loops
    rec = load_dataset("friction-2Hz-30lb")
    n = rec.n_samples
    train = np.arange(n) < int(0.8 * n)
    test = ~train
    final = StopPIRegressor().fit(rec.u, rec.y, train=train, test=test).predict(rec.u)
    ad = assess([rec], [train], [test], [final], 0.03, ["delay"], free_weights=True)
    assert "No loop-shape class does clearly better" in ad.text
    assert "The friction class (hyst fit --model stop-pi" in ad.text
    assert "friction plateau" in ad.text and "backlash dead band" in ad.text
