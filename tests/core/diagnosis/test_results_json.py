"""A diagnosis result written as JSON and read back is the same result: real diagnoses (the
shipped piezo recording, synthetic recordings with several effects, several recordings with
a base choice), compared field by field with a comparison of its own (arrays bit for bit,
models by their documents), and damaged documents refused saying where."""

from __future__ import annotations

import base64
import copy
import dataclasses
import gzip
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pytest

from core.base import Chain, Model
from core.diagnosis import diagnose
from core.diagnosis.results import RESULT_FORMAT as FORMAT
from core.diagnosis.results import RESULT_VERSION, DiagnosisResult
from core.diagnosis.typed_json import DocumentError

PIEZO = Path(__file__).parents[3] / "examples" / "data" / "piezo" / "piezo_150V_1Hz.csv"


def same(a: object, b: object, where: str = "result") -> None:
    """Assert ``a`` and ``b`` are equal, field by field (NaN equals NaN, arrays by dtype,
    shape and values, models by type and document), naming the first difference."""
    if isinstance(a, Model):
        assert type(a) is type(b), where
        assert json.dumps(a.to_dict()) == json.dumps(b.to_dict()), where  # type: ignore[union-attr]
    elif dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape, where
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), where
    elif isinstance(a, float):
        assert isinstance(b, float | int) and not isinstance(b, bool), where
        assert (math.isnan(a) and math.isnan(b)) or a == b, where
    elif isinstance(a, Mapping):
        assert isinstance(b, Mapping) and list(a) == list(b), where
        for k in a:
            same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, tuple):
        assert isinstance(b, tuple) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            same(x, y, f"{where}[{i}]")
    elif isinstance(a, Sequence) and not isinstance(a, str):  # lists (and resolved x_pi)
        assert isinstance(b, Sequence) and not isinstance(b, tuple | str), where
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            same(x, y, f"{where}[{i}]")
    else:
        assert type(a) is type(b) and a == b, (where, a, b)


def round_trip(res: DiagnosisResult) -> DiagnosisResult:
    text = json.dumps(res.to_json(), allow_nan=False)  # strict JSON: no NaN literals
    return DiagnosisResult.from_json(json.loads(text))


@pytest.fixture(scope="module")
def piezo() -> DiagnosisResult:
    return diagnose(PIEZO)


@pytest.fixture(scope="module")
def saturation_and_lag() -> DiagnosisResult:
    """Two effects on one recording: a tanh loop shape and an output lag (as in
    tests/core/diagnosis/test_shapes.py)."""
    from core.fitting.gpi import TanhEnvelope, TanhGPI
    from core.pi import PIModel
    from core.recordings import Recording
    from core.stages import Lag

    env = TanhEnvelope([1, 0.5, 0, 0], [1, 0.5, 0, 0])
    r = np.linspace(0.05, 0.8, 8)
    sat = TanhGPI(PIModel(1.0, r, 0.4 * np.exp(-2 * r)), env)
    dt = 2e-4
    turns = [0, 4, -4, 2, -3, 4, -1, 1, -4, 0]
    u = np.concatenate([np.linspace(a, b, 250, endpoint=False)
                        for a, b in zip(turns[:-1], turns[1:], strict=True)])
    y0 = 10 * Chain.of(sat, Lag(3e-3))(u, dt=dt)
    y = y0 + 0.002 * np.ptp(y0) * np.random.default_rng(5).standard_normal(u.size)
    return diagnose(Recording(np.arange(u.size) * dt, u, y, name="sat+lag"),
                    effects=["lag", "saturation"])


@pytest.fixture
def periodic_set(weak_rate_set_diagnosis) -> DiagnosisResult:
    """Four recordings at different rates: a base choice, between-recordings plans,
    leave-one-recording-out scores, suggestive rows (the diagnosis of
    ``make_periodic_set(0.0006, seed=201)``, shared with test_diagnosis_multi.py)."""
    return weak_rate_set_diagnosis


def test_the_shipped_piezo_diagnosis_round_trips(piezo) -> None:
    assert [e.name for e in piezo.effects] == ["initial-memory"]  # a finding to carry
    back = round_trip(piezo)
    same(piezo, back)
    # what is derived from it is derived alike: the report, the text, the saved model
    assert json.dumps(back.to_dict()) == json.dumps(piezo.to_dict())
    assert back.summary() == piezo.summary()
    u = piezo.records[0].u
    np.testing.assert_array_equal(back.model(u), piezo.model(u))
    assert json.dumps(back.to_json()) == json.dumps(piezo.to_json())  # a fixed point


def test_several_effects_round_trip(saturation_and_lag) -> None:
    res = saturation_and_lag
    assert [e.name for e in res.effects] == ["saturation", "lag"]
    back = round_trip(res)
    same(res, back)
    assert back.summary() == res.summary()
    assert json.dumps(back.to_dict()) == json.dumps(res.to_dict())


def test_several_recordings_round_trip(periodic_set) -> None:
    res = periodic_set
    assert len(res.records) > 1 and res.rounds
    back = round_trip(res)
    same(res, back)
    assert json.dumps(back.to_dict()) == json.dumps(res.to_dict())


@pytest.mark.slow
def test_two_hidden_effects_round_trip(resonance_and_drift_diagnosis) -> None:
    """Resonance and drift found together (test_diagnosis_multi.py, the same diagnosis): fits
    with dynamics stages and per-recording drift terms."""
    res = resonance_and_drift_diagnosis
    assert [e.name for e in res.effects] == ["resonance", "drift"]
    same(res, round_trip(res))


def test_a_creep_fitted_on_all_rows_is_said_and_round_trips(saturation_and_lag) -> None:
    """An effect whose cycle-to-cycle fit fell back to all the training rows (the fit's
    ``raw_fallback``, the finding's ``fitted_on_all_rows``): its report line says so in
    words, the report's JSON carries it, and the stored document keeps it; an effect
    without it says nothing of the kind."""
    from core.diagnosis.report import ALL_ROWS_WORDS

    res = copy.copy(saturation_and_lag)
    assert ALL_ROWS_WORDS not in res.summary()
    res.effects = [dataclasses.replace(res.effects[0], fitted_on_all_rows=True),
                   *res.effects[1:]]
    res.final = dataclasses.replace(res.final, raw_fallback=("creep",))
    line = next(t for t in res.summary().splitlines() if t.startswith("1. saturation: "))
    assert line.endswith(f"({ALL_ROWS_WORDS})")
    assert "cycle to cycle" in ALL_ROWS_WORDS and "training rows" in ALL_ROWS_WORDS
    assert [e["fitted_on_all_rows"] for e in res.to_dict()["effects"]] == [True, False]
    back = round_trip(res)
    same(res, back)
    assert back.final.raw_fallback == ("creep",) and back.effects[0].fitted_on_all_rows
    assert back.summary() == res.summary()


def _version_1() -> dict:
    """A document as version 1 stored it: ``DiagnosisResult.to_json`` of main 0672ff3 (its
    writer, the untestable entries plain ``{"name", "reason", "experiment"}`` objects) of a
    recording without a time axis (seven entries): 360 samples of a PI loop, turning points
    0, 1, -1, 0.6, -0.8, 1, -0.3, 0.2, -1, 0 with 40 samples per ramp, radii
    ``linspace(0.05, 0.8, 6)``, weights ``0.4 exp(-2 r)``, noise 0.002 (seed 3),
    ``has_time=False``."""
    path = Path(__file__).parent / "data" / "diagnosis_result_v1.json.gz"
    with gzip.open(path, "rt", encoding="utf-8") as f:
        doc: dict = json.load(f)
    return doc


def test_a_version_1_document_still_reads() -> None:
    """A version 1 document (a stored session's result, written by the version 1 writer)
    reads: its untestable entries typed (:class:`~core.diagnosis.specs.Untestable`, no
    parameters), the report's entries those stored, and written again it is the version
    written now."""
    from core.diagnosis.specs import Untestable

    doc = _version_1()
    stored = _fields(doc)["untestable"]
    assert doc["version"] == 1 and len(stored) == 7
    assert all(isinstance(u, dict) and set(u) == {"name", "reason", "experiment"}
               for u in stored)
    res = DiagnosisResult.from_json(copy.deepcopy(doc))
    assert all(type(u) is Untestable and not u.parameters for u in res.untestable)
    # written before fits recorded a fall-back to all the training rows: none recorded
    assert res.final.raw_fallback == () and res.baseline.raw_fallback == ()
    assert not any(e.fitted_on_all_rows for e in res.effects)
    assert res.to_dict()["untestable"] == stored
    again = json.loads(json.dumps(res.to_json()))
    assert again["version"] == RESULT_VERSION == 3
    same(res, DiagnosisResult.from_json(again))
    # the same entries in a version 2 document are damaged, not read
    v2 = copy.deepcopy(doc)
    v2["version"] = 2
    with pytest.raises(DocumentError):
        DiagnosisResult.from_json(v2)


def _version_2() -> dict:
    """A document as version 2 stored it: ``DiagnosisResult.to_json`` of main 01959c4 (its
    writer, the base choice's ``tried`` rows and ``stop`` plain objects) of
    ``diagnose([examples/data/bh_loops/MnZn_HP_ferrite.csv], effects=["saturation"])``
    (four loops: the Preisach, Bouc-Wen and Menegotto-Pinto bases tried, the PI with a loop
    shape compared with the Menegotto-Pinto bank, once also with output dynamics)."""
    path = Path(__file__).parent / "data" / "diagnosis_result_v2.json.gz"
    with gzip.open(path, "rt", encoding="utf-8") as f:
        doc: dict = json.load(f)
    return doc


def _choice(doc: dict) -> dict:
    return _fields(doc)["base_choice"]["fields"]


def test_a_version_2_document_still_reads() -> None:
    """A version 2 document reads: its base choice's rows typed (:class:`BaseTrial`, the
    richer base each static-map alternative was compared with a :class:`BaseRival`), the
    report's rows those stored (keys and numbers), and written again it is version 3."""
    from core.diagnosis.results import BaseRival, BaseTrial

    doc = _version_2()
    stored = _choice(doc)["tried"]["$tuple"]
    assert doc["version"] == 2 and len(stored) == 5
    assert all(isinstance(t, dict) and "$type" not in t for t in stored)
    res = DiagnosisResult.from_json(copy.deepcopy(doc))
    bc = res.base_choice
    assert bc is not None and all(type(t) is BaseTrial for t in bc.tried)
    assert [t.base for t in bc.tried] == ["preisach", "bouc-wen", "menegotto-pinto",
                                          "pi + asymmetry", "pi + saturation"]
    assert bc.tried[3].rival == BaseRival("menegotto-pinto", stored[3][
        "menegotto_pinto_mse_reduction_over_it"])
    assert bc.tried[4].rival is not None and bc.tried[4].rival.mse_reduction_with_dynamics \
        == stored[4]["menegotto_pinto_mse_reduction_over_it_with_dynamics"]
    assert res.to_dict()["baseline"]["base_choice"]["tried"] == stored
    assert "the Menegotto-Pinto -99 % against it" in bc.text
    again = json.loads(json.dumps(res.to_json()))
    assert again["version"] == 3
    same(res, DiagnosisResult.from_json(again))
    # the same rows in a version 3 document are damaged, not read
    v3 = copy.deepcopy(doc)
    v3["version"] = 3
    with pytest.raises(DocumentError, match="tried"):
        DiagnosisResult.from_json(v3)


def test_a_version_2_stop_base_still_reads() -> None:
    """A version 2 stop base (a plain object; with two slip forces also
    ``slip_force_ratio`` and ``friction_plateau_falling``, the plateau times the ratio)
    reads as a :class:`StopBase`, whose JSON form is the object stored."""
    from core.diagnosis.results import StopBase

    for extra in ({}, {"slip_force_ratio": 1.5, "friction_plateau_falling": 3.0}):
        stop = {"gap": 0.1, "elements": 25, "friction_plateau": 2.0,
                "heldout_mse_reduction": 0.4, "chosen": True, **extra}
        doc = _version_2()
        _choice(doc)["stop"] = copy.deepcopy(stop)
        res = DiagnosisResult.from_json(doc)
        assert res.base_choice is not None and type(res.base_choice.stop) is StopBase
        assert res.base_choice.stop.to_dict() == stop
        assert res.to_dict()["baseline"]["base_choice"]["stop"] == stop
    # a stop of other keys is damage
    doc = _version_2()
    _choice(doc)["stop"] = {"gap": 0.1}
    with pytest.raises(DocumentError, match="stop"):
        DiagnosisResult.from_json(doc)


def test_a_boolean_version_is_not_version_1() -> None:
    """``"version": true`` equals 1 in Python; it is not upgraded as version 1 (the reader
    refuses a boolean version, and does here)."""
    doc = _version_1()
    doc["version"] = True
    with pytest.raises(DocumentError):
        DiagnosisResult.from_json(doc)
    assert doc["version"] is True and isinstance(_fields(doc)["untestable"][0], dict)


def test_an_untestable_entry_keeps_its_parameters(periodic_set) -> None:
    """A typed untestable entry with parameters (a mode seen in the residual's spectrum)
    round-trips; the report's JSON entry is still ``{"name", "reason", "experiment"}``."""
    from core.diagnosis.specs import Untestable

    res = copy.copy(periodic_set)
    res.untestable = [*res.untestable,
                      Untestable("resonance", "why", "what", {"freq_hz": 45.3, "damping": 0.04})]
    back = round_trip(res)
    same(res, back)
    assert back.untestable[-1].parameters == {"freq_hz": 45.3, "damping": 0.04}
    assert back.to_dict()["untestable"][-1] == {"name": "resonance", "reason": "why",
                                                "experiment": "what"}


def test_each_test_gets_its_own_copy_of_a_shared_diagnosis(
        weak_rate_set_diagnosis, _weak_rate_set_original) -> None:
    """The diagnoses conftest.py shares between modules are run once and handed out as deep
    copies: what a test changes in its copy (a list, a fit's prediction in place; the
    recordings are read-only) leaves the diagnosis the next test gets as it was run."""
    mine, shared = weak_rate_set_diagnosis, _weak_rate_set_original
    assert mine is not shared
    same(mine, shared)
    mine.untestable.clear()
    mine.rounds.pop()
    mine.final.pred[0][:] = 0.0
    assert shared.untestable and shared.rounds and np.any(shared.final.pred[0] != 0.0)
    assert not np.shares_memory(mine.final.pred[0], shared.final.pred[0])
    with pytest.raises(AssertionError):
        same(mine, shared)


def test_the_comparison_sees_a_difference(periodic_set) -> None:
    """The comparison above can fail: one sample of one prediction changed is found."""
    back = round_trip(periodic_set)
    back.final.pred[0] = back.final.pred[0].copy()
    back.final.pred[0][3] += 1e-12
    with pytest.raises(AssertionError, match=r"result.final.pred\[0\]"):
        same(periodic_set, back)


# ------------------------------------------------------------------------------ damage
def _damaged(doc: dict, change) -> str:
    bad = copy.deepcopy(doc)
    change(bad)
    with pytest.raises(DocumentError) as err:
        DiagnosisResult.from_json(bad)
    assert "run the diagnosis again" in str(err.value)
    return err.value.where + ": " + err.value.what


def _fields(doc: dict) -> dict:
    return doc["result"]["fields"]


def test_damaged_documents_are_refused_saying_where(periodic_set) -> None:
    doc = json.loads(json.dumps(periodic_set.to_json()))
    assert doc["format"] == FORMAT and doc["version"] == 3
    assert "newer" in _damaged(doc, lambda d: d.update(version=4))
    assert "format" in _damaged(doc, lambda d: d.update(format="hysteresis-explorer/model"))
    assert _damaged(doc, lambda d: _fields(d).pop("split")).endswith("lacks its field 'split'")
    assert "has no field 'colour'" in _damaged(doc, lambda d: _fields(d).update(colour=1))
    where = _damaged(doc, lambda d: _fields(d).update(noise_rms="small"))
    assert where.startswith("result.noise_rms: a str is not a float")
    where = _damaged(doc, lambda d: _fields(d)["baseline"].update({"$type": "Popen"}))
    assert where == "result.baseline: unknown type 'Popen'"

    def cut(d: dict) -> None:
        arr = _fields(d)["final"]["fields"]["pred"][0]["$array"]
        arr["base64"] = base64.b64encode(base64.b64decode(arr["base64"])[:-8]).decode()

    assert _damaged(doc, cut).startswith("result.final.pred[0]: the array's data holds")

    def not_base64(d: dict) -> None:
        _fields(d)["train"][0]["$array"]["base64"] = "@@@"

    assert "base64" in _damaged(doc, not_base64)

    def bad_model(d: dict) -> None:
        _fields(d)["final"]["fields"]["models"][0]["$model"] = {"type": "no-such-model"}

    assert "the model does not build" in _damaged(doc, bad_model)
    assert _damaged(doc, lambda d: d.update(result=[1, 2])) == "result: a list, not a result"
    with pytest.raises(DocumentError, match="not an object"):
        DiagnosisResult.from_json([doc])


def test_what_a_result_cannot_hold_is_named_when_written(periodic_set) -> None:
    res = copy.copy(periodic_set)
    res.maps_before = {"where": object()}
    with pytest.raises(DocumentError, match=r"result.maps_before.where: a object"):
        res.to_json()


# ------------------------------------------------------------------------------ property
def _values():
    """What a result's free-form fields hold: numbers (NaN and infinities too), text, None,
    arrays, and tuples, lists and mappings of them."""
    from hypothesis import strategies as st
    from hypothesis.extra import numpy as hnp

    arrays = hnp.arrays(st.sampled_from([np.float64, np.int64, np.bool_]),
                        hnp.array_shapes(min_dims=0, max_dims=2, max_side=4))
    leaves = (st.none() | st.booleans() | st.integers(-2**62, 2**62) | st.floats()
              | st.text(max_size=8) | arrays)
    return st.recursive(leaves, lambda inner: (
        st.lists(inner, max_size=4) | st.tuples(inner, inner)
        | st.dictionaries(st.text(max_size=6).filter(lambda k: not k.startswith("$")), inner,
                          max_size=4)), max_leaves=12)


def test_any_round_row_round_trips() -> None:
    """Property: a round row whose parameters and details hold any such values is read back
    equal (tuples stay tuples, NaN stays NaN, arrays keep their type and shape)."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from core.diagnosis.results import RoundRow
    from core.diagnosis.typed_json import read_document, write_document

    @settings(max_examples=150, deadline=None)
    @given(params=st.dictionaries(st.text(max_size=6).filter(lambda k: not k.startswith("$")),
                                  _values(), max_size=4),
           extra=st.lists(st.tuples(st.text(max_size=6), _values()), max_size=3),
           z=st.floats())
    def check(params, extra, z) -> None:
        row = RoundRow(1, "lag", 0.25, z, 1e-3, True, "accepted", params, "test rows",
                       ("why",), tuple(extra))
        text = json.dumps(write_document(row, "x", 1, (RoundRow,)), allow_nan=False)
        same(row, read_document(json.loads(text), "x", 1, (RoundRow,), RoundRow), "row")

    check()


def test_the_report_says_when_the_final_model_fitted_the_term_otherwise(saturation_and_lag
                                                                        ) -> None:
    """The effect's line gives the parameters of the fit it was judged with and whether that
    fit fell back to all the training rows; the final model, refitted with every effect
    named, may have fitted the term the other way, and the model the user gets is that one:
    the report says so in both directions, and nothing when the two agree. Before, the
    final model's fallback was in the JSON only."""
    from core.diagnosis.report import ALL_ROWS_WORDS

    res = copy.copy(saturation_and_lag)
    name = res.effects[0].name
    assert name in res.final.structure.effects
    assert "final model: " not in res.summary()

    def said(judged: bool, final: bool) -> list[str]:
        r = copy.copy(res)
        r.effects = [dataclasses.replace(res.effects[0], fitted_on_all_rows=judged),
                     *res.effects[1:]]
        r.final = dataclasses.replace(res.final, raw_fallback=(name,) if final else ())
        return [t for t in r.summary().splitlines() if t.startswith("   final model: ")]

    assert said(False, False) == [] and said(True, True) == []
    (fell,) = said(False, True)
    assert ALL_ROWS_WORDS in fell and "judged with, on its changes from cycle to cycle" in fell
    (kept,) = said(True, False)
    assert ALL_ROWS_WORDS not in kept and "did not need to fit this term on all" in kept
