"""``hyst fit --model auto`` and ``hyst diagnose`` choose the same base family on the same
recordings: the measured friction damper and a clockwise Maxwell-slip plant written
independently of the project's operators (``benchmarks/diagnosis/families.py``)."""

from __future__ import annotations

import warnings

import pytest

from benchmarks.diagnosis.families import make_family
from core.datasets import load_dataset
from core.diagnosis import diagnose
from core.fitting.choice import base_family, choose_base


def _diagnosis_family(recs: list) -> str:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnose(recs, effects=["offset"], max_effects=0)
    assert res.base_choice is not None
    return res.base_choice.kind


def test_families_of_the_fit_kinds() -> None:
    assert base_family("stop-pi") == "stop-pi" and base_family("pi") == "pi"
    assert base_family("preisach") == "preisach" and base_family("bouc-wen") == "bouc-wen"


@pytest.mark.parametrize("names", [("friction-1Hz-30lb", "friction-2Hz-30lb")])
def test_fit_and_diagnosis_choose_one_family_on_the_friction_damper(names) -> None:
    recs = [load_dataset(n) for n in names]
    fit = choose_base(recs)
    assert fit.orientation.clockwise and fit.kind == "stop-pi"
    assert "bouc-wen" in fit.cv_mse  # two recordings: the other families were tried
    assert fit.family == _diagnosis_family(recs) == "stop-pi"


def test_fit_and_diagnosis_choose_one_family_on_a_maxwell_slip_plant() -> None:
    recs = [r for r in make_family("maxwell-slip", None, seed=3).records
            if r.name in ("slow", "decaying")]
    fit = choose_base(recs)
    assert fit.orientation.clockwise and fit.family == "stop-pi"
    assert fit.family == _diagnosis_family(recs)
