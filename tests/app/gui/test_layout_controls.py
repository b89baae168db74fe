"""The explorer's parameter controls are the registry's declared fields, for every model type.

The viser sliders of a non-PI model are built from the numbers of its JSON document
(``numeric_leaves``), which ``Model.to_dict`` writes from the class's ``Field`` declarations;
there is no second table of model fields for the GUI. Checked here against
:func:`core.models.model_types` on one instance of every registered type.
"""

from __future__ import annotations

import re
from typing import Any

import pytest

from app.gui.layout import numeric_leaves, set_leaf
from core.models import model_type, model_types
from tests.core.model_zoo import ZOO

_TOKENS = re.compile(r"[^.\[\]]+|\[\d+\]")


def _field_of_leaf(doc: dict[str, Any], path: str) -> tuple[str, str]:
    """``(type, field kind)`` of the declared field that holds the number at ``path``."""
    node: Any = doc
    owner = kind = ""
    for tok in _TOKENS.findall(path):
        if tok.startswith("["):
            node = node[int(tok[1:-1])]
            continue
        owner = node["type"]
        fields = {f.name: f for f in model_type(owner).fields}
        assert tok in fields, f"slider {path!r}: {tok!r} is not a declared field of {owner}"
        kind = fields[tok].kind
        node = node[tok]
    return owner, kind


@pytest.mark.parametrize("name", [t.name for t in model_types()])
def test_every_slider_is_a_declared_number_field(name: str) -> None:
    doc = ZOO[name].to_dict()
    leaves = numeric_leaves(doc)
    assert leaves, f"{name}: no controls"
    seen: set[tuple[str, str]] = set()
    for path, _ in leaves:
        owner, kind = _field_of_leaf(doc, path)
        assert kind in ("number", "numbers", "matrix", "any"), (path, kind)
        seen.add((owner, [t for t in _TOKENS.findall(path) if t[0] != "["][-1]))
    # and every declared number field of the top-level type present in the document has one
    top = {f.name for f in model_type(name).fields if f.kind in ("number", "numbers", "matrix")
           and doc.get(f.name) is not None}
    assert top <= {f for o, f in seen if o == name}
    # a slider writes back where it was read
    path, v = leaves[-1]
    set_leaf(doc, path, v + 1.0)
    assert dict(numeric_leaves(doc))[path] == v + 1.0
