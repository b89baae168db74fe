"""``hyst invert`` / ``hyst export`` / ``hyst simulate --inverse`` on every model type."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.io import loadmat

from app.cli import main
from core.base import Chain
from core.effects import Delay, Resonance
from core.paramset import ParameterSet, load_parameter_set
from core.presets import list_presets
from tests.core.model_zoo import EX1, ZOO

CASES = sorted(ZOO) + [f"preset:{p.name}" for p in list_presets()]


def _write(tmp_path, name: str):
    if name.startswith("preset:"):
        from core.presets import get_preset

        model = get_preset(name.split(":", 1)[1])
    else:
        model = ZOO[name]
    p = tmp_path / "model.json"
    ParameterSet.from_model(model, source=name).save(p)
    return p, model


@pytest.mark.parametrize("name", CASES)
def test_invert_and_export_succeed_on_every_type_and_preset(name, tmp_path, capsys) -> None:
    src, model = _write(tmp_path, name)
    inv = tmp_path / "inv.json"
    assert main(["invert", str(src), "-o", str(inv), "--dt", "1e-4"]) == 0
    assert load_parameter_set(inv).model.to_dict() == model.inverse().to_dict()
    c = tmp_path / "comp.c"
    args = ["export", str(src), "--format", "c", "-o", str(c), "--dt", "1e-4"]
    if name == "advance":  # the advance itself needs the future: export its inverse only
        args.append("--no-forward")
    assert main(args) == 0, capsys.readouterr().err
    assert "comp_inv_step" in c.read_text()
    m = tmp_path / "comp.mat"
    assert main(["export", str(src), "--format", "mat", "-o", str(m)]) == 0
    assert loadmat(m, squeeze_me=True, struct_as_record=False)["model"].type == model.type_name


def test_invert_states_the_resonance_bound_and_the_delay_preview(tmp_path, capsys) -> None:
    src = tmp_path / "m.json"
    ParameterSet.from_model(Chain.of(EX1, Resonance(400.0, 0.05), Delay(2.5e-4))).save(src)
    out = tmp_path / "inv.json"
    assert main(["invert", str(src), "-o", str(out), "--bandwidth", "1500", "--dt", "1e-4",
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["preview_samples"] == 3
    assert any("roll-off at 1500 Hz" in n for n in doc["notes"])
    assert any("3 sample(s)" in n for n in doc["notes"])
    assert load_parameter_set(out).model.stages[1].bandwidth_hz == 1500.0
    assert main(["invert", str(src), "-o", str(out), "--bandwidth", "-1"]) != 0
    assert "--bandwidth must be a positive" in capsys.readouterr().err


def test_simulate_inverse_uses_the_known_trajectory_ahead(tmp_path, capsys) -> None:
    plant = Chain.of(EX1, Delay(3e-4))
    src = tmp_path / "m.json"
    ParameterSet.from_model(plant).save(src)
    t = np.arange(2000) * 1e-4
    yd = 2 * np.sin(2 * np.pi * 5 * t)
    inp = tmp_path / "yd.csv"
    np.savetxt(inp, np.column_stack((t, yd)), delimiter=",", header="t,u", comments="")
    outp = tmp_path / "drive.csv"
    assert main(["simulate", str(src), "--inverse", "-i", str(inp), "-o", str(outp)]) == 0
    assert "preview of 3 sample(s)" in capsys.readouterr().err
    drive = np.loadtxt(outp, delimiter=",", skiprows=1)[:, -1]
    # the drive leads: the delayed plant then follows the desired trajectory exactly
    y = plant(drive, dt=1e-4)
    np.testing.assert_allclose(y[3:-3], yd[3:-3], rtol=0, atol=1e-12)
