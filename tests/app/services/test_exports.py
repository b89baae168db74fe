"""Session exports (``app.services.exports``) use the core parameter set."""

from __future__ import annotations

import json

import pytest

from app.services import config as S
from app.services import exports as E
from core.exceptions import ParameterError
from core.pi import PIModel


def test_exports_use_the_core_parameter_set() -> None:
    from core.paramset import FORMAT

    m = PIModel.from_dict(S.EXAMPLE1)
    name, payload = E.export_bytes(m, "json", "abc")
    doc = json.loads(payload)
    assert name == "hysteresis-pi-abc.json" and doc["format"] == FORMAT
    assert E.parameter_set_model(doc).to_dict() == m.to_dict()
    assert E.parameter_set_model(S.EXAMPLE1).to_dict() == m.to_dict()  # a bare model
    name, c = E.export_bytes(m, "c")
    assert b"hyst_inv_step" in c and b"hyst_fwd_step" in c
    with pytest.raises(ParameterError, match="format"):
        E.export_bytes(m, "xls")
