"""One registry: each model type declares its fields once and everything derives from them."""

from __future__ import annotations

import ast
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from core import base
from core.base import Field, Model, model_from_dict, register_model
from core.export_c import generate_c
from core.export_mat import export_mat, read_mat
from core.models import model_type, model_types
from core.paramset import ParameterSet, ParameterSetError, load_parameter_set
from core.presets import get_preset, list_presets
from tests.core.model_zoo import DT, ZOO

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", sorted(ZOO))
def test_declared_fields_describe_the_json_form(name) -> None:
    model = ZOO[name]
    d = model.to_dict()
    fields = {f.name: f for f in type(model).fields}
    assert fields, f"{name} declares no fields"
    assert set(d) - {"type"} <= set(fields)
    assert {f.name for f in fields.values() if not f.optional} <= set(d)
    assert all(f.doc for f in fields.values())
    back = load_parameter_set(json.loads(ParameterSet.from_model(model).to_json())).model
    assert back.to_dict() == d


def test_validation_errors_come_from_the_declared_fields() -> None:
    doc = ParameterSet.from_model(ZOO["chain"]).to_dict()
    doc["model"]["stages"][1]["taus_s"][0] = "fast"
    with pytest.raises(ParameterSetError, match=r"^model\.stages\[1\]\.taus_s\[0\]: must be a"):
        load_parameter_set(doc)
    doc = ParameterSet.from_model(ZOO["resonance-inverse"]).to_dict()
    del doc["model"]["bandwidth_hz"]
    with pytest.raises(ParameterSetError,
                       match=r"^model\.bandwidth_hz: missing \(required by model type"):
        load_parameter_set(doc)
    doc = ParameterSet.from_model(ZOO["lag"]).to_dict()
    doc["model"]["tau"] = 1.0
    with pytest.raises(ParameterSetError,
                       match=r"^model\.tau: unknown field of model type 'lag'; its fields: tau_s"):
        load_parameter_set(doc)


def test_a_new_type_declaring_its_fields_is_picked_up_everywhere(tmp_path) -> None:
    @register_model
    @dataclass(frozen=True, eq=False)
    class Gain(Model):
        """Static gain ``y = k x`` (a stand-in for a type added by another module)."""

        type_name: ClassVar[str] = "test-gain"
        fields: ClassVar[tuple[Field, ...]] = (Field("k", "number", doc="gain"),)
        k: float

        def _run(self, u: Any, state: Any, dt: float | None) -> tuple[Any, Any]:
            return self.k * u, None

        def default_state(self) -> None:
            return None

    try:
        m = model_from_dict({"type": "test-gain", "k": 2.0})  # generic from_dict
        assert m.to_dict() == {"type": "test-gain", "k": 2.0}  # generic to_dict
        with pytest.raises(ParameterSetError, match=r"^model\.k: must be a number"):
            load_parameter_set({"format": "hysteresis-explorer/parameter-set", "version": 1,
                                "model": {"type": "test-gain", "k": "two"}})
        assert read_mat(export_mat(m, tmp_path / "g.mat")).model.to_dict() == m.to_dict()
        info = model_type("test-gain")
        assert info.title.startswith("Static gain") and not info.c_export
        with pytest.raises(ValueError, match="'test-gain'.*not supported; supported stage"):
            generate_c(m, inverse=False)
    finally:
        base._REGISTRY.pop("test-gain")


def test_model_types_carry_what_an_editor_needs() -> None:
    types = {t.name: t for t in model_types()}
    assert types["creep"].needs_dt and not types["pi"].needs_dt
    assert [f.name for f in types["resonance-inverse"].fields] == [
        "freq_hz", "damping", "bandwidth_hz"]
    assert "(Hz)" in types["resonance"].fields[0].doc


@pytest.mark.parametrize("info", list_presets(), ids=lambda p: p.name)
def test_every_preset_inverts_and_exports(info, tmp_path) -> None:
    model = get_preset(info.name)
    inv = model.inverse()
    u = np.linspace(-2, 2, 50)
    y = model(inv(u))
    assert np.all(np.isfinite(y))
    assert "_inv_step" in generate_c(model, "p", dt=DT).source
    assert read_mat(export_mat(model, tmp_path / "p.mat")).model.to_dict() == model.to_dict()


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    out: set[str] = set()
    for node in tree.body:  # module level only
        if isinstance(node, ast.ImportFrom):
            out |= {f"{node.module or ''}.{a.name}".strip(".") for a in node.names}
            out.add(node.module or "")
    return out


def test_no_import_cycle_and_one_place_imports_every_model_module() -> None:
    assert not any("digitized_deadzone" in i for i in _imports(ROOT / "core/digitized.py"))
    src = (ROOT / "core/presets.py").read_text()
    assert "except Exception" not in src and "importlib" not in src
    assert "_FIELD_RULES" not in (ROOT / "core/paramset.py").read_text()
    # every module that registers a model type is imported by core.models
    registering = {p.stem for p in (ROOT / "core").glob("*.py")
                   if "\n@register_model" in p.read_text() and p.stem not in ("base", "models")}
    imported = {i.split(".")[-1] for i in _imports(ROOT / "core/models.py")}
    assert registering <= imported, registering - imported
