"""Parameter-set documents: round trip, validation messages with JSON paths."""

from __future__ import annotations

import json

import numpy as np
import pytest

from core.base import Chain, registered_types
from core.exceptions import NotInvertibleError, ParameterError
from core.paramset import (
    FORMAT,
    SUPPORTED_VERSIONS,
    ParameterSet,
    ParameterSetError,
    Provenance,
    Units,
    ensure_model_types_registered,
    load_parameter_set,
)
from core.pi import PIModel

EX1 = PIModel(0.72, [0.45 * i for i in range(1, 7)], [0.6, 0.48, 0.36, 0.24, 0.12, 0.012])


def doc(model: dict | None = None, **top) -> dict:
    d = {"format": FORMAT, "version": 1, "model": model or EX1.to_dict()}
    d.update(top)
    return d


def test_round_trip_through_json_file_is_lossless(tmp_path, rng):
    m = PIModel(0.3, np.sort(rng.uniform(0.01, 3, 8)), rng.normal(size=8), state0=0.2)
    ps = ParameterSet.from_model(
        m, units={"input": "V", "output": "nm"}, source="unit test",
        fit={"rmse": np.float64(0.125), "n": np.int64(8), "per_file": [np.nan, 1.0]},
    )
    path = ps.save(tmp_path / "deep" / "m.json")
    back = load_parameter_set(path)
    assert isinstance(back.model, PIModel)
    np.testing.assert_array_equal(back.model.thresholds, m.thresholds)
    np.testing.assert_array_equal(back.model.weights, m.weights)
    np.testing.assert_array_equal(back.model.state0, m.state0)
    assert back.model.p0 == m.p0
    assert back.units == Units("V", "nm", "s")
    assert back.provenance.source == "unit test"
    # numpy scalars become JSON numbers, NaN (an undefined metric) becomes null
    assert dict(back.provenance.fit) == {"rmse": 0.125, "n": 8, "per_file": [None, 1.0]}
    assert back.provenance.created == ps.provenance.created
    assert back.provenance.tool.startswith("hysteresis-explorer ")
    # the document is exactly what to_dict() says, and simulates identically
    assert json.loads(path.read_text()) == ps.to_dict()
    u = np.sin(np.linspace(0, 20, 500)) * 4
    np.testing.assert_array_equal(back.model(u), m(u))


def test_a_parameter_set_pickles_as_it_is():
    """A job's worker sends a fit's outcome (its parameter set included) back to the
    server by pickling it: the read-only ``provenance.fit`` and ``extra`` come back equal
    and read-only, with the same creation time."""
    import pickle
    from types import MappingProxyType

    ps = ParameterSet.from_model(PIModel(0.72, [0.45, 0.9], [0.6, 0.48]), source="unit test",
                                 fit={"model": "pi", "report": {"rmse": 0.125}})
    ps = ps.with_provenance(extra={"kept": [1, 2]})
    back = pickle.loads(pickle.dumps(ps))
    assert back.to_dict() == ps.to_dict() and back.provenance == ps.provenance
    assert isinstance(back.provenance.fit, MappingProxyType)
    assert isinstance(back.provenance.extra, MappingProxyType)
    assert pickle.loads(pickle.dumps(ParameterSet(ps.model))).provenance.fit is None


def test_chain_round_trip_and_string_source():
    ch = Chain.of(EX1, PIModel(1.0, [0.5], [0.25]))
    ps = ParameterSet.from_model(ch)
    back = load_parameter_set(ps.to_json())
    assert isinstance(back.model, Chain) and len(back.model.stages) == 2
    assert back.to_dict()["model"] == ch.to_dict()


def test_document_layout():
    d = ParameterSet.from_model(EX1, source="paper 001 Example 1").to_dict()
    assert list(d) == ["format", "version", "model", "units", "provenance"]
    assert d["format"] == "hysteresis-explorer/parameter-set" and d["version"] == 1
    assert d["model"] == {
        "type": "pi", "p0": 0.72, "thresholds": [0.45, 0.9, 1.35, 1.8, 2.25, 2.7],
        "weights": [0.6, 0.48, 0.36, 0.24, 0.12, 0.012],
    }
    assert d["units"] == {"input": "V", "output": "um", "time": "s"}
    assert set(d["provenance"]) == {"created", "tool", "source", "fit", "notes"}


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d["model"]["weights"].__setitem__(3, "abc"),
         r'^model\.weights\[3\]: must be a number, got a string "abc"'),
        (lambda d: d["model"]["weights"].__setitem__(0, True),
         r"^model\.weights\[0\]: must be a number, got a boolean"),
        (lambda d: d["model"].__setitem__("p0", None), r"^model\.p0: missing"),
        (lambda d: d["model"].pop("thresholds"),
         r"^model\.thresholds: missing \(required by model type 'pi'\)"),
        (lambda d: d["model"].__setitem__("thresholds", [0.9, 0.45, 1, 2, 3, 4]),
         r"^model\.thresholds: must be strictly increasing"),
        (lambda d: d["model"].__setitem__("weights", [1.0]),
         r"^model\.weights: must have length 6"),
        (lambda d: d["model"].__setitem__("type", "nope"),
         r'^model\.type: unknown model type "nope"; known model types: .*pi'),
        (lambda d: d["model"].pop("type"), r"^model\.type: missing; known model types"),
        (lambda d: d.__setitem__("format", "something/else"),
         r'^format: "something/else" is not a parameter set; expected '
         r'"hysteresis-explorer/parameter-set"'),
        (lambda d: d.pop("format"), r"^format: missing"),
        (lambda d: d.__setitem__("version", 7),
         r"^version: unsupported version 7; this tool reads version\(s\) 1"),
        (lambda d: d.pop("version"), r"^version: missing; supported versions: 1"),
        (lambda d: d.pop("model"), r"^model: missing"),
        (lambda d: d.__setitem__("model", [1, 2]), r"^model: must be an object"),
        (lambda d: d.__setitem__("extra", 1), r"^extra: unknown top-level field"),
        (lambda d: d.__setitem__("units", {"input": 5}), r"^units\.input: must be a string"),
        (lambda d: d.__setitem__("units", {"force": "N"}), r"^units\.force: unknown unit key"),
        (lambda d: d.__setitem__("provenance", {"source": 3}),
         r"^provenance\.source: must be a string or null"),
    ],
)
def test_bad_documents_name_the_json_path(mutate, message):
    d = json.loads(ParameterSet.from_model(EX1).to_json())
    mutate(d)
    with pytest.raises(ParameterSetError, match=message):
        load_parameter_set(d)


def test_errors_inside_chains_name_the_stage():
    bad = doc({"type": "chain", "stages": [EX1.to_dict(), {"type": "pi", "p0": 1,
               "thresholds": [-1.0], "weights": [1.0]}]})
    with pytest.raises(ParameterSetError, match=r"^model\.stages\[1\]\.thresholds\[0\] = -1 is"):
        load_parameter_set(bad)
    with pytest.raises(ParameterSetError, match=r"^model\.stages: must be a non-empty array"):
        load_parameter_set(doc({"type": "chain", "stages": []}))


def test_bare_model_gets_a_hint_and_errors_are_parameter_errors():
    with pytest.raises(ParameterError, match="looks like a bare model"):
        load_parameter_set(EX1.to_dict())
    assert issubclass(ParameterSetError, ParameterError)


def test_json_text_problems(tmp_path):
    with pytest.raises(ParameterSetError, match=r"not valid JSON: .* line 1 column"):
        load_parameter_set('{"format": ')
    text = ParameterSet.from_model(EX1).to_json().replace("0.72", "NaN")
    with pytest.raises(ParameterSetError, match="NaN; every parameter must be a finite number"):
        load_parameter_set(text)
    p = tmp_path / "x.json"
    p.write_text("[1, 2]")
    with pytest.raises(ParameterSetError, match=r"x\.json: \(document\): .*JSON object"):
        load_parameter_set(p)
    with pytest.raises(FileNotFoundError, match="parameter-set file not found"):
        load_parameter_set(tmp_path / "missing.json")


def test_inverse_and_require_inverse():
    ps = ParameterSet.from_model(EX1, source="paper 001 Example 1")
    inv = ps.inverse()
    # paper 001 Example 2 (printed to 4 decimals)
    np.testing.assert_allclose(inv.model.thresholds, [0.324, 0.918, 1.728, 2.7, 3.78, 4.914])
    np.testing.assert_allclose(inv.model.p0, 1.3889, atol=5e-5)
    assert inv.units == Units("um", "V", "s")
    assert inv.provenance.source == "inverse of paper 001 Example 1"
    assert inv.provenance.extra["inverse_of"]["model"] == EX1.to_dict()
    again = load_parameter_set(inv.to_json())
    assert again.provenance.extra["inverse_of"]["model"]["type"] == "pi"

    bad = doc({"type": "pi", "p0": 1.0, "thresholds": [1.0, 2.0], "weights": [-1.0, 0.5]})
    assert load_parameter_set(bad).model.p0 == 1.0  # loading alone is fine
    with pytest.raises(NotInvertibleError, match=r"^model: not invertible \(pi\): .*S2"):
        load_parameter_set(bad, require_inverse=True)


def test_every_registered_type_is_known_to_the_loader():
    with pytest.raises(ParameterSetError) as exc:
        load_parameter_set(doc({"type": "zzz"}))
    for t in registered_types():
        assert t in str(exc.value)
    assert SUPPORTED_VERSIONS == (1,)


def test_value_objects_are_frozen():
    ps = ParameterSet.from_model(EX1)
    with pytest.raises(AttributeError):
        ps.model = EX1  # type: ignore[misc]
    with pytest.raises(TypeError):
        ps.provenance.fit["x"] = 1  # type: ignore[index]
    p2 = ps.with_provenance(notes="checked")
    assert p2.provenance.notes == "checked" and ps.provenance.notes is None
    assert Provenance(fit={"a": 1}).to_dict()["fit"] == {"a": 1}


def _instances() -> dict[str, object]:
    """One instance of every model type whose module exists, keyed by type name."""
    from core.base import Chain

    out: dict[str, object] = {"pi": EX1, "chain": Chain.of(EX1, PIModel(1.0, [0.5], [0.2]))}
    try:
        from core.stages import Delay, Lag, Offset, Resonance

        out.update(offset=Offset(0.5), lag=Lag(0.01), resonance=Resonance(100.0, 0.1),
                   delay=Delay(0.002))
    except ImportError:  # pragma: no cover
        pass
    try:
        from core.stages import Asymmetry, Creep, Drift, InitialMemory, RateDependentPI

        out.update({
            "creep": Creep([0.01, 0.1], [0.02, 0.01]),
            "drift": Drift([0.1, -0.05], 2.0),
            "asymmetry": Asymmetry([0.1, 0.02], 0.5, 2.0),
            "rate": RateDependentPI(1.0, [0.5, 1.0], [0.3, 0.2], 1e-3),
            "initial-memory": InitialMemory(EX1, [2.0, -1.0]),
        })
    except ImportError:  # pragma: no cover
        pass
    try:
        from core.deadzone import DeadZoneMap
        from core.gpi import DeadZoneGPI, ModifiedPI, TanhEnvelope, TanhGPI

        g = DeadZoneMap.symmetric([0.8, 1.6], 0.9, [0.4, -0.3])
        env = TanhEnvelope([6.0, 0.4, 0.0, -0.2], [6.0, 0.4, 0.0, 0.2], direction0=-1)
        out.update({"deadzone": g, "gpi-deadzone": DeadZoneGPI(EX1, g), "mpi": ModifiedPI(EX1, g),
                    "tanh-envelope": env, "tanh-envelope-inverse": env.inverse(),
                    "gpi-tanh": TanhGPI(EX1, env)})
    except ImportError:  # pragma: no cover
        pass
    try:
        from core.digitized import DigitizedPI

        out["digitized"] = DigitizedPI.from_pi(EX1, (-5.0, 5.0), state0="0110101")
    except ImportError:  # pragma: no cover
        pass
    try:
        from core.lti import LinearSystem

        out["lti"] = LinearSystem([1.0], [1e-3, 1.0])
    except ImportError:  # pragma: no cover
        pass
    return out


INSTANCES = _instances()


@pytest.mark.parametrize("type_name", sorted(INSTANCES))
def test_every_model_type_round_trips(type_name):
    model = INSTANCES[type_name]
    doc = json.loads(ParameterSet.from_model(model).to_json())
    assert doc["model"]["type"] == type_name
    back = load_parameter_set(doc).model
    assert type(back) is type(model)
    assert back.to_dict() == model.to_dict()
    u = 3 * np.sin(np.linspace(0, 6 * np.pi, 300))
    dt = 1e-3 if model.is_dynamic else None
    np.testing.assert_array_equal(back(u, dt=dt), model(u, dt=dt))


def test_nested_model_errors_carry_their_path():
    if "gpi-deadzone" not in INSTANCES:
        pytest.skip("core.gpi not available")
    d = ParameterSet.from_model(INSTANCES["gpi-deadzone"]).to_dict()
    d["model"]["pi"]["weights"][1] = None
    with pytest.raises(ParameterSetError, match=r"^model\.pi\.weights\[1\]: must be a number"):
        load_parameter_set(d)
    d = ParameterSet.from_model(INSTANCES["gpi-deadzone"]).to_dict()
    d["model"]["deadzone"]["thresholds"] = [-1.0, 1.0, 2.0, 3.0, 4.0]
    with pytest.raises(ParameterSetError, match=r"^model\.deadzone: .*ρ0 = 0"):
        load_parameter_set(d)
    d = ParameterSet.from_model(INSTANCES["gpi-deadzone"]).to_dict()
    d["model"]["pi"] = {"type": "deadzone", "thresholds": [0.0], "weights": [1.0]}
    with pytest.raises(ParameterSetError, match=r"^model: .*pi must be a PIModel"):
        load_parameter_set(d)


def test_json_examples_in_the_format_documentation_load(root):
    import re

    text = (root / "docs" / "pages" / "parameter-set.md").read_text()
    blocks = re.findall(r"```json\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 6
    for block in blocks:
        d = json.loads(block)
        if "format" in d:
            ps = load_parameter_set(d)
        else:
            if d["type"] not in ensure_model_types_registered():
                continue  # pragma: no cover - module not present
            ps = load_parameter_set({"format": FORMAT, "version": 1, "model": d})
        assert ps.model.to_dict()["type"] == (d.get("model") or d)["type"]


@pytest.mark.parametrize(
    ("type_name", "field", "value", "message"),
    [
        ("delay", "delay_s", "1 ms", r"^model\.stages\[1\]\.delay_s: must be a number"),
        ("lag", "tau_s", None, r"^model\.stages\[1\]\.tau_s: missing \(required by model type"),
        ("resonance", "damping", [0.1], r"^model\.stages\[1\]\.damping: must be a number"),
        ("creep", "weights", [0.1, "x"], r"^model\.stages\[1\]\.weights\[1\]: must be a number"),
        ("drift", "coefficients", [], r"^model\.stages\[1\]\.coefficients: must not be empty"),
        ("asymmetry", "scale", True, r"^model\.stages\[1\]\.scale: must be a number"),
        ("rate", "beta_s", None, r"^model\.stages\[1\]\.beta_s: missing"),
        ("rate", "state0", [0.0, "a"], r"^model\.stages\[1\]\.state0\[1\]: must be a number"),
        ("initial-memory", "model", 3, r"^model\.stages\[1\]\.model: must be an object"),
        ("initial-memory", "history", 1.0, r"^model\.stages\[1\]\.history: must be an array"),
    ],
)
def test_bad_effect_fields_name_the_json_path(type_name, field, value, message):
    from core.base import Chain

    stage = INSTANCES[type_name].to_dict()
    if value is None:
        stage.pop(field)
    else:
        stage[field] = value
    d = ParameterSet.from_model(Chain.of(EX1, INSTANCES["offset"])).to_dict()
    d["model"]["stages"][1] = stage
    with pytest.raises(ParameterSetError, match=message):
        load_parameter_set(d)
