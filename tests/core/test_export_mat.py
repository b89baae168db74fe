"""MATLAB export, loaded back with scipy.io.loadmat."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.io import loadmat

from core.base import Chain
from core.export_mat import export_mat, mat_struct, read_mat
from core.paramset import FORMAT, ParameterSet
from core.pi import PIModel

EX1 = PIModel(0.72, [0.45 * i for i in range(1, 7)], [0.6, 0.48, 0.36, 0.24, 0.12, 0.012])


def test_pi_fields_and_inverse(tmp_path):
    ps = ParameterSet.from_model(EX1, units={"input": "V", "output": "um"}, source="ex1")
    path = export_mat(ps, tmp_path / "ex1")
    assert path.name == "ex1.mat"
    d = loadmat(path, squeeze_me=True, struct_as_record=False)
    assert d["format"] == FORMAT and d["version"] == 1.0
    m = d["model"]
    assert m.type == "pi"
    assert m.p0 == 0.72
    np.testing.assert_array_equal(m.thresholds, EX1.thresholds)
    np.testing.assert_array_equal(m.weights, EX1.weights)
    inv = EX1.inverse()
    assert d["inverse"].p0 == inv.p0
    np.testing.assert_array_equal(d["inverse"].thresholds, inv.thresholds)
    np.testing.assert_array_equal(d["inverse"].weights, inv.weights)
    assert (d["units"].input, d["units"].output, d["units"].time) == ("V", "um", "s")
    assert d["provenance"].source == "ex1"
    # row vectors in MATLAB
    raw = loadmat(path)
    assert raw["model"]["thresholds"][0, 0].shape == (1, 6)


def test_chain_is_a_cell_of_structs_and_json_round_trips(tmp_path):
    b = PIModel(1.0, [0.5, 1.0], [0.25, -0.5], state0=[0.1, 0.2])
    ch = Chain.of(EX1, b)
    path = export_mat(ch, tmp_path / "chain.mat")
    d = loadmat(path, squeeze_me=True, struct_as_record=False)
    stages = d["model"].stages
    assert d["model"].type == "chain" and len(stages) == 2
    np.testing.assert_array_equal(stages[1].state0, [0.1, 0.2])
    np.testing.assert_array_equal(stages[0].weights, EX1.weights)
    # the second stage has slope 1 + 0.25 - 0.5 = 0.75 > 0: the chain is invertible
    assert d["inverse"].type == "chain"
    back = read_mat(path)
    assert back.to_dict()["model"] == ch.to_dict()


def test_non_invertible_model_stores_empty_inverse(tmp_path):
    bad = PIModel(1.0, [1.0, 2.0], [-1.0, 0.5])
    d = loadmat(export_mat(bad, tmp_path / "bad.mat"))
    assert d["inverse"].size == 0


def test_mat_struct_conversions():
    assert mat_struct(None).shape == (0, 0)
    assert mat_struct({"a-b": [1, 2]})["a_b"].shape == (1, 2)
    assert mat_struct([[1, 2], [3, 4]]).shape == (2, 2)
    cell = mat_struct(["x", 1])
    assert cell.dtype == object and cell.shape == (1, 2)
    with pytest.raises(ValueError, match="cannot store a set"):
        mat_struct({1, 2})


def test_read_mat_rejects_foreign_files(tmp_path):
    from scipy.io import savemat

    p = tmp_path / "other.mat"
    savemat(p, {"x": 1.0})
    with pytest.raises(ValueError, match="not written by hyst export"):
        read_mat(p)


def test_every_model_type_exports_and_reads_back(tmp_path):
    from tests.core.test_paramset import INSTANCES

    for name, model in INSTANCES.items():
        path = export_mat(model, tmp_path / f"{name}.mat")
        d = loadmat(path, squeeze_me=True, struct_as_record=False)
        assert d["model"].type == name
        assert read_mat(path).model.to_dict() == model.to_dict()


def test_every_registered_type_exports_with_its_inverse(tmp_path):
    from tests.core.model_zoo import ZOO

    for name, model in ZOO.items():
        path = export_mat(model, tmp_path / f"{name}.mat")
        d = loadmat(path, squeeze_me=True, struct_as_record=False)
        assert d["model"].type == name
        assert d["inverse"].type == model.inverse().type_name, name
        assert read_mat(path).model.to_dict() == model.to_dict()


def test_menegotto_pinto_fields_rebuild_the_model_and_its_inverse(tmp_path):
    """The struct's fields alone (not the JSON copy) give back the bank: the model built from
    them, and the one under ``inverse.model``, run as the exported one on a bipolar history
    of growing amplitude (a non-Masing one: the curvature depends on each excursion)."""
    from core.nonmasing import MenegottoPintoModel
    from tests.core.model_zoo import ZOO

    m = ZOO["menegotto-pinto"]
    ps = ParameterSet.from_model(m, units={"input": "mm", "output": "kN"})
    d = loadmat(export_mat(ps, tmp_path / "mp"), squeeze_me=True, struct_as_record=False)
    names = ("thresholds", "weights", "curvature", "curvature_drop", "curvature_scale")

    def rebuilt(s) -> MenegottoPintoModel:
        return MenegottoPintoModel(float(s.k), *(np.atleast_1d(getattr(s, f)) for f in names))

    assert d["model"].type == "menegotto-pinto"
    assert d["inverse"].type == "menegotto-pinto-inverse"
    assert d["inverse"].model.type == "menegotto-pinto"
    raw = loadmat(tmp_path / "mp.mat")
    assert raw["model"]["curvature_drop"][0, 0].shape == (1, m.n)  # MATLAB row vectors
    t = np.linspace(0.0, 1.0, 3000)
    u = 3.0 * t * np.sin(2 * np.pi * 6 * t)
    for s in (d["model"], d["inverse"].model):
        np.testing.assert_array_equal(rebuilt(s)(u), m(u))
    y = m(u)
    np.testing.assert_allclose(rebuilt(d["inverse"].model).inverse()(y), u, rtol=0,
                               atol=1e-9 * np.ptp(u))
