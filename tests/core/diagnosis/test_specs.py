"""The untestable entry (core.diagnosis.specs.Untestable): its parameters are read-only, so
an entry shared by every run (core.diagnosis.basechoice.RATE_ON_STOP) cannot be changed by
one of them, nor by the caller's own dict after the entry is made."""

from __future__ import annotations

import copy
import json
import pickle

import pytest

from benchmarks.diagnosis.families import jsonable
from core.diagnosis.basechoice import RATE_ON_STOP
from core.diagnosis.specs import Untestable


def test_the_parameters_of_an_untestable_entry_are_read_only() -> None:
    given = {"freq_hz": 45.3, "damping": 0.04}
    u = Untestable("resonance", "why", "what", given)
    given["damping"] = 0.5  # the caller's dict changed afterwards: not the entry's
    assert u.parameters == {"freq_hz": 45.3, "damping": 0.04}
    with pytest.raises(TypeError):
        u.parameters["damping"] = 0.5  # type: ignore[index]
    with pytest.raises(TypeError):
        RATE_ON_STOP.parameters["x"] = 1.0  # type: ignore[index]
    assert not RATE_ON_STOP.parameters


def test_an_untestable_entry_copies_pickles_and_writes() -> None:
    u = Untestable("resonance", "why", "what", {"freq_hz": 45.3})
    for back in (copy.deepcopy(u), pickle.loads(pickle.dumps(u)), copy.copy(u)):
        assert back == u and back.parameters == {"freq_hz": 45.3}
        with pytest.raises(TypeError):
            back.parameters["freq_hz"] = 1.0  # type: ignore[index]
    # the benchmark's rows write it as a plain object
    assert json.dumps(jsonable(u.parameters)) == '{"freq_hz": 45.3}'
