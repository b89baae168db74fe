"""The words both commands say about physics no rate-independent base follows."""

from __future__ import annotations

import numpy as np

from benchmarks.diagnosis.families import family_signals, make_base
from core.fitting import fit_recordings
from core.fitting.physicsleft import physics_left, physics_left_sentence
from core.recordings import Recording

NOISE = 0.2


def _records(plant) -> list[Recording]:
    rng = np.random.default_rng(4)
    return [Recording(t, u, plant(u) + NOISE * rng.standard_normal(u.size), name,
                      units={"input": "V", "output": "um"})
            for name, t, u in family_signals()[:3]]


def test_nothing_is_said_of_a_stop_operator_plant() -> None:
    recs = _records(make_base("maxwell-slip"))
    assert not physics_left(recs, NOISE).found
    assert physics_left_sentence(recs, NOISE) == ""


def test_a_degrading_pinched_element_gets_both() -> None:
    recs = _records(make_base("bouc-wen-baber-noori", delta_nu=0.0005, delta_eta=0.0005))
    left = physics_left(recs, NOISE)
    assert left.found and left.cycle is not None and left.cycle.changes
    assert left.masing.non_masing
    said = left.text()
    assert said.index("changes from cycle to cycle") < said.index("non-Masing")


def test_hyst_fit_says_it_in_its_misfit_warning() -> None:
    # the stop-operator fit of Menegotto-Pinto steel misses far above the noise floor; the
    # warning with the largest residual region now says which physics is left
    recs = _records(make_base("menegotto-pinto"))
    out = fit_recordings(recs, "stop-pi")
    (msg,) = [w for w in out.warnings if "white-noise floor" in w]
    assert "non-Masing" in msg and "Menegotto-Pinto" in msg
