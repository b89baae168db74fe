"""The explorer's sliders are derived from the model registry's field declarations.

Every registered type declares, on each numeric field, a control (label, unit, range, step)
and its ordering rules; :func:`app.services.explore.controls.model_controls` turns any document into
sliders, so a new type gets them without UI code (a toy type registered here does). The
rules keep a moved value valid and speak in the labels the user sees (1-based ``r3``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import pytest

from app.services.explore import controls as C
from app.services.explore.simulation import preset_doc
from app.services.words import type_words
from core import base
from core.base import UNITS, Control, Field, Model, register_model
from core.exceptions import ParameterError
from core.models import model_types
from core.validation import as_finite_scalar, as_vector
from tests.core.model_zoo import ZOO

TYPES = [t.name for t in model_types()]


def _numeric(t: Any) -> list[Field]:
    return [f for f in t.fields if f.kind in ("number", "numbers", "matrix")]


@pytest.mark.parametrize("name", TYPES)
def test_every_numeric_field_declares_label_unit_range_and_step(name: str) -> None:
    t = next(t for t in model_types() if t.name == name)
    for f in _numeric(t):
        ctls = f.elements or (f.control,)
        assert all(c is not None for c in ctls), f"{name}.{f.name} declares no control"
        assert f.title, f"{name}.{f.name} has no group title"
        for c in ctls:
            assert c.label.strip(), (name, f.name)
            assert c.unit in UNITS, (name, f.name, c.unit)
            assert c.step > 0 and math.isfinite(c.step), (name, f.name)
            lo, hi = c.range
            assert math.isfinite(lo) and math.isfinite(hi), (name, f.name)
            assert lo < hi or c.count_of, (name, f.name, c.range)
            if f.kind != "number" and not f.elements:  # one label per element
                assert "{i}" in c.label, (name, f.name, c.label)
        for other in (*f.scale_with, *([f.index_zero] if f.index_zero else [])):
            assert other in {g.name for g in t.fields}, (name, f.name, other)


@pytest.mark.parametrize("name", TYPES)
def test_every_registered_type_gets_its_sliders(name: str) -> None:
    doc = ZOO[name].to_dict()
    ctl = C.model_controls(doc)
    sliders = list(ctl.sliders())
    assert sliders, f"{name}: no sliders"
    for s in sliders:
        assert C.get_leaf(doc, s.path) == s.value, s.path
        assert s.min <= s.value <= s.max and s.step > 0, s
        assert "[" not in s.label and "{" not in s.label, s.label
    for g in ctl.groups:  # labels are unique where they are shown together
        labels = [s.label for s in g.sliders]
        assert len(set(labels)) == len(labels), (g.title, labels)
    # every number of the document whose field has a control has a slider
    paths = {s.path for s in sliders}
    assert paths == set(_declared_leaves(doc)), name


def _declared_leaves(doc: Any, prefix: str = "") -> list[str]:
    """Paths of the numbers in ``doc`` held by declared numeric fields (an independent walk
    over the registry: ``Field.kind`` and the JSON document only)."""
    out: list[str] = []
    t = next(t for t in model_types() if t.name == doc["type"])
    for f in t.fields:
        v = doc.get(f.name)
        if v is None:
            continue
        p = f"{prefix}{f.name}"
        if f.kind == "model":
            out += _declared_leaves(v, p + ".")
        elif f.kind == "models":
            for i, sub in enumerate(v):
                out += _declared_leaves(sub, f"{p}[{i}].")
        elif f.kind == "number":
            out.append(p)
        elif f.kind == "numbers":
            out += [f"{p}[{i}]" for i in range(len(v))]
        elif f.kind == "matrix":
            out += [f"{p}[{i}][{j}]" for i, row in enumerate(v) for j in range(len(row))]
    return out


def test_ranges_follow_the_parameter_set_not_the_value() -> None:
    """Example 1's thresholds 0.45..2.7 span a 0..3.75 slider (round scale 3 times 1.25),
    so the thumbs spread over it instead of sitting at one spot; a set 100 times larger
    gets a range 100 times larger."""
    doc = preset_doc("paper001-example1")["model"]
    r = [s for s in C.model_controls(doc).sliders() if s.path.startswith("thresholds")]
    assert [s.label for s in r] == ["r1", "r2", "r3", "r4", "r5", "r6"]
    assert {(s.min, s.max) for s in r} == {(0.001, 3.75)}
    pos = [(s.value - s.min) / (s.max - s.min) for s in r]
    assert pos[0] < 0.15 and pos[-1] > 0.7 and len({round(p, 3) for p in pos}) == 6
    big = dict(doc, thresholds=[100 * x for x in doc["thresholds"]])
    rb = [s for s in C.model_controls(big).sliders() if s.path.startswith("thresholds")]
    assert rb[0].max == pytest.approx(375.0) and rb[0].step == pytest.approx(0.1)


def test_creep_time_constants_get_a_log_slider_whose_positions_map_to_values() -> None:
    """Creep τ 0.01, 0.1, 1 s on a linear 0.001..1.25 slider would sit at 0.7 %, 7.9 % and
    80 % of its width; declared logarithmic, the description says so and the thumbs sit a
    decade apart (equal spacing in log10), a position maps back to its value, and the
    strict limit τ > 0 still clamps. The weights stay linear."""
    doc = {"type": "creep", "taus_s": [0.01, 0.1, 1.0], "weights": [0.02, 0.02, 0.02]}
    ctl = C.model_controls(doc)
    taus = [s for s in ctl.sliders() if s.path.startswith("taus_s")]
    assert [s.log for s in taus] == [True] * 3
    assert not any(s.log for s in ctl.sliders() if s.path.startswith("weights"))
    s = ctl.slider("taus_s[0]")
    assert s is not None and s.min > 0
    lo, hi = C.slider_position(s, s.min), C.slider_position(s, s.max)
    frac = [(C.slider_position(s, v) - lo) / (hi - lo) for v in (0.01, 0.1, 1.0)]
    assert 0.2 < frac[0] < 0.4  # not bunched at the left (linear: 0.007)
    assert frac[1] - frac[0] == pytest.approx(frac[2] - frac[1])
    for v in (0.001, 0.0123, 0.5, 1.25):
        assert C.slider_value(s, C.slider_position(s, v)) == pytest.approx(v, rel=5e-3)
    assert C.slider_value(s, lo + (hi - lo) / 2) == pytest.approx(
        10 ** ((math.log10(s.min) + math.log10(s.max)) / 2), rel=5e-3)
    assert C.clamp(doc, "taus_s[0]", 0.0).value == pytest.approx(s.step)


@pytest.mark.parametrize("name", TYPES)
def test_log_sliders_have_a_positive_range(name: str) -> None:
    """Every field declared logarithmic is a positive quantity (strict lower limit 0), so
    log10 of its range and values exists."""
    for f in _numeric(next(t for t in model_types() if t.name == name)):
        for ctl in (f.control, *f.elements):
            if ctl is not None and ctl.log:
                assert ctl.lower == 0.0 and ctl.strict and ctl.range[0] > 0, (name, f.name)


def test_dead_zone_sliders_are_numbered_around_the_linear_term() -> None:
    doc = preset_doc("paper001-example4")["model"]
    ctl = C.model_controls(doc)
    rho = next(g for g in ctl.groups if g.key == "deadzone.thresholds")
    eta = next(g for g in ctl.groups if g.key == "deadzone.weights")
    assert [s.label for s in rho.sliders][:2] == ["ρ-11", "ρ-10"]
    assert rho.sliders[11].label == "ρ0" and rho.sliders[11].fixed
    assert eta.sliders[11].label == "η0" and eta.sliders[11].value == 4.765
    assert "Dead-zone input map" in rho.title and rho.unit == "input units"


def test_clamp_keeps_order_and_limits_in_the_users_labels() -> None:
    doc = preset_doc("paper001-example1")["model"]
    c = C.clamp(doc, "thresholds[2]", 3.345)
    assert c.value == pytest.approx(1.799)
    assert c.note == "r3 stops at 1.799, just below r4 = 1.8: the thresholds r_i must increase"
    c = C.clamp(doc, "thresholds[3]", 0.2)
    assert c.value == pytest.approx(1.351) and "just above r3 = 1.35" in c.note
    c = C.clamp(doc, "thresholds[0]", -1.0)
    assert c.value == pytest.approx(0.001) and c.note == "r1 stops at 0.001: it must be > 0"
    assert C.clamp(doc, "weights[1]", -0.3) == C.Clamped(-0.3, "")
    gpi = preset_doc("paper001-example4")["model"]
    assert C.clamp(gpi, "deadzone.thresholds[11]", 0.3).value == 0.0  # rho_0 stays 0
    assert C.clamp(gpi, "deadzone.thresholds[12]", -0.2).value == pytest.approx(0.001)
    seg = ZOO["digitized-deadzone"].to_dict()
    assert C.clamp(seg, "state0", 2.6).value == 3.0  # a whole segment number
    with pytest.raises(ParameterError, match="no slider"):
        C.clamp(doc, "type", 1.0)
    with pytest.raises(ParameterError, match="finite"):
        C.clamp(doc, "p0", float("nan"))


def test_check_rules_names_the_slider_not_the_json_index() -> None:
    doc = dict(preset_doc("paper001-example1")["model"])
    doc["thresholds"] = [0.45, 0.9, 3.345, 1.8, 2.25, 2.7]
    with pytest.raises(ParameterError) as e:
        C.check_rules(doc)
    assert str(e.value) == ("r3 = 3.345 must stay below r4 = 1.8: the thresholds r_i must be "
                            "increasing")
    gpi = preset_doc("paper001-example4")["model"]
    gpi["deadzone"]["thresholds"][13] = 0.3
    with pytest.raises(ParameterError, match=r"^Dead-zone input map γ: ρ1 = 0.4 must stay "
                                              r"below ρ2 = 0.3"):
        C.check_rules(gpi)


@pytest.mark.parametrize("value", [[0.0], [[1.0]], {"a": 1}])
def test_check_rules_leaves_a_wrong_kind_of_value_to_the_models_check(value: Any) -> None:
    # a list (or object, text, bool) where a number belongs was a TypeError (a 500 in the
    # fuzz); the rules skip it and the model's own check refuses it with a ParameterError
    doc = {"type": "advance", "delay_s": value}
    C.check_rules(doc)
    with pytest.raises(ParameterError):
        base.model_from_dict(doc)


# ----------------------------------------------------------------------------- a new type
@dataclass(frozen=True, eq=False)
class Springs(Model):
    """Toy model: a row of springs with gaps (only here to see it get sliders)."""

    type_name: ClassVar[str] = "toy-springs"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("stiffness", "number", doc="spring rate", title="Stiffness k",
              control=Control("k", "output/input", (0.0, 2.0), lower=0.0, strict=True)),
        Field("gaps", "numbers", doc="gaps, increasing", title="Gaps g_i", increasing=True,
              control=Control("g{i}", "input", (0.0, 1.25), lower=0.0)),
    )
    stiffness: float
    gaps: Any

    def __post_init__(self) -> None:
        object.__setattr__(self, "stiffness",
                           as_finite_scalar(self.stiffness, "stiffness", positive=True))
        object.__setattr__(self, "gaps", as_vector(self.gaps, "gaps", increasing=True))

    def default_state(self) -> None:
        return None

    def _run(self, u: Any, state: Any, dt: float | None) -> tuple[Any, None]:
        return self.stiffness * np.asarray(u), None


@pytest.fixture
def toy(monkeypatch: pytest.MonkeyPatch) -> type[Model]:
    monkeypatch.setitem(base._REGISTRY, Springs.type_name, Springs)
    return Springs


def test_a_newly_registered_type_gets_sliders_and_rules(toy: type[Model]) -> None:
    doc = {"type": "toy-springs", "stiffness": 40.0, "gaps": [1.0, 2.0, 4.0]}
    ctl = C.model_controls(doc)
    assert [g.title for g in ctl.groups] == ["Stiffness k", "Gaps g_i"]
    k, g1, g2, g3 = ctl.sliders()
    # round scale 40 (4 x 10) times (0, 2); step 0.001 x 40 rounded to a power of ten;
    # k > 0 starts one step above 0
    assert (k.label, k.min, k.max, k.step) == ("k", 0.1, 80.0, 0.1)
    assert [g1.label, g2.label, g3.label] == ["g1", "g2", "g3"]
    assert C.clamp(doc, "gaps[0]", 3.0).note.startswith("g1 stops at 1.99, just below g2 = 2")
    register_model(toy)  # the registry accepts it like any model module's type
    chain = {"type": "chain", "stages": [preset_doc("paper001-example1")["model"], doc]}
    groups = [g.title for g in C.model_controls(chain).groups]
    # the stage in the registry's words (its docstring's title), not its type name
    assert f"Stage 2, {type_words('toy-springs')}: Gaps g_i" in groups
    assert "toy-springs" not in " ".join(groups)


@pytest.mark.parametrize(("name", "path", "value", "says", "not_says"), [
    ("deadzone", "thresholds[2]", 0.5, "ρ0 = 0 exactly once", "rho"),
    ("tanh-envelope", "direction0", 0, "initial direction must be +1", "direction0"),
    ("lti", "den[0]", 0.0, "a0 = 0", "deg(num)"),
    ("preisach-inverse", "model.weights[0][0]", 0.0, "W0,0 = 0 must be > 0", "weights["),
    ("digitized-mpi", "deadzone.state0", 9, "initial segment = 9", "state0"),
])
def test_the_models_own_refusals_use_the_slider_labels(name: str, path: str, value: float,
                                                       says: str, not_says: str) -> None:
    """A value typed into the JSON box that the declared rules pass but the model refuses
    (ρ0 moved off 0, direction 0, a leading a0 = 0, a zero reversible slope, a segment past
    the end) is refused in the labels the sliders show, not in JSON names or indices."""
    doc = ZOO[name].to_dict()
    C.get_leaf(doc, path)
    doc = C.with_leaf(doc, path, value)
    C.check_rules(doc)  # not a declared rule: the model's own check words it
    with pytest.raises(ValueError) as err:  # ParameterError or NotInvertibleError
        base.model_from_dict(doc)
    assert says in str(err.value) and not_says not in str(err.value), str(err.value)
