"""Session exports (``app.services.session.exports``) use the core parameter set."""

from __future__ import annotations

import json

import pytest

from app.services.explore import config as S
from app.services.session import exports as E
from core.exceptions import ParameterError
from core.pi import PIModel


def test_exports_use_the_core_parameter_set() -> None:
    from core.paramset import FORMAT

    m = PIModel.from_dict(S.EXAMPLE1)
    name, payload = E.export_bytes(m, "json", "abc")
    doc = json.loads(payload)
    assert name == "hysteresis-classical-pi-model-abc.json" and doc["format"] == FORMAT
    assert E.parameter_set_model(doc).to_dict() == m.to_dict()
    assert E.parameter_set_model(S.EXAMPLE1).to_dict() == m.to_dict()  # a bare model
    name, c = E.export_bytes(m, "c")
    assert b"hyst_inv_step" in c and b"hyst_fwd_step" in c
    with pytest.raises(ParameterError, match="format"):
        E.export_bytes(m, "xls")


def test_fmi_version_of_a_request() -> None:
    assert [E.fmi_version(v) for v in ("3", "3.0", " 2 ", "2.0", 3, 2)] == [3, 3, 2, 2, 3, 2]
    for bad in ("1", "3.1", "", "x" * 1000, None):
        with pytest.raises(ParameterError, match=r"unknown FMI version .*choose 3 \(FMI 3.0\) "
                                                 r"or 2 \(FMI 2.0\)"):
            E.fmi_version(bad)
