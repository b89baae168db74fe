"""``hyst invert`` / ``hyst export`` / ``hyst simulate --inverse`` on every model type."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat

from app.cli import main
from core.base import Chain
from core.models import fit_kinds
from core.paramset import ParameterSet, load_parameter_set
from core.presets import list_presets
from core.stages import Delay, Resonance
from tests.core.model_zoo import EX1, ZOO

CASES = sorted(ZOO) + [f"preset:{p.name}" for p in list_presets()]
#: A shipped recording (1 Hz friction damper loops, 7 168 samples, CC BY 4.0).
DAMPER = (Path(__file__).resolve().parents[3] / "examples" / "data" / "friction_damper"
          / "1Hz30lbtension0.5amplitude.csv")
GCC = shutil.which("gcc")
#: Reads "u yd" lines; prints the C forward model of u and the C compensator of yd.
DRIVER = """#include <stdio.h>
#include "comp.h"
int main(void) {
    comp_fwd_state f; comp_inv_state i; double u, yd;
    comp_fwd_init(&f); comp_inv_init(&i);
    while (scanf("%lf %lf", &u, &yd) == 2)
        printf("%.17g %.17g\\n", comp_fwd_step(&f, u), comp_inv_step(&i, yd));
    return 0;
}
"""


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


@pytest.mark.parametrize("kind", fit_kinds())
def test_every_fit_kind_fitted_on_a_recording_inverts_and_exports(kind, tmp_path, capsys) -> None:
    """``hyst fit --model KIND`` on a shipped recording -> ``invert``, C (compiled strictly,
    run, matched against Python) and MAT, for every kind the registry declares."""
    src, inv = tmp_path / "model.json", tmp_path / "inv.json"
    assert main(["fit", str(DAMPER), "--model", kind, "-n", "6", "-o", str(src), "-q"]) == 0
    capsys.readouterr()
    model = load_parameter_set(src).model
    assert main(["invert", str(src), "-o", str(inv)]) == 0, capsys.readouterr().err
    comp = load_parameter_set(inv).model
    data = np.genfromtxt(DAMPER, delimiter=",", names=True)
    u = data["u_disp_in"]
    y = model(u)
    span = float(np.ptp(y))
    yd = y[0] + 0.9 * (y - y[0])  # a desired trajectory inside the fitted output range
    # the compensator makes the fitted model follow the desired trajectory
    assert np.max(np.abs(model(comp(yd)) - yd)) < 1e-9 * span
    c = tmp_path / "comp.c"
    assert main(["export", str(src), "--format", "c", "-o", str(c)]) == 0, capsys.readouterr().err
    m = tmp_path / "comp.mat"
    assert main(["export", str(src), "--format", "mat", "-o", str(m)]) == 0
    assert loadmat(m, squeeze_me=True, struct_as_record=False)["model"].type == model.type_name
    if GCC is None:
        pytest.skip("gcc not installed")
    (tmp_path / "main.c").write_text(DRIVER)
    exe = tmp_path / "comp"
    res = subprocess.run([GCC, "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2",
                          str(c), str(tmp_path / "main.c"), "-o", str(exe), "-lm"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    lines = "\n".join(f"{a:.17g} {b:.17g}" for a, b in zip(u, yd, strict=True))
    out = subprocess.run([str(exe)], input=lines, capture_output=True, text=True, check=True)
    got = np.loadtxt(out.stdout.splitlines())
    np.testing.assert_allclose(got[:, 0], y, rtol=0, atol=1e-9 * span)
    np.testing.assert_allclose(got[:, 1], comp(yd), rtol=0, atol=1e-9 * float(np.ptp(u)))


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


DYNAMICS = [(), ("delay", 2.5e-4), ("lag", 1e-3), ("resonance", 300.0, 0.1)]


@pytest.mark.parametrize("rate", [None, 2e-5], ids=["pi", "rate"])
@pytest.mark.parametrize("dynamics", DYNAMICS, ids=lambda d: d[0] if d else "static")
def test_every_chain_layout_the_diagnosis_writes_inverts_and_exports(rate, dynamics, tmp_path,
                                                                     capsys) -> None:
    """The diagnosis' own model builder (``hyst diagnose --save-model`` writes its chain) with
    every effect switched on, per hysteresis kind and dynamics: invert, C (compiled) and MAT."""
    from core.diagnosis.effects.asymmetry import MapCoefficients
    from core.diagnosis.structure import Structure, build_model
    from core.recordings import Recording

    s = (Structure(thresholds=tuple(EX1.thresholds), history=((2.0, -1.0),), beta_s=rate,
                   dynamics=dynamics)
         .with_term("asymmetry", True).with_term("creep", (0.01, 0.1, 1.0))
         .with_term("drift", 2))
    t = np.arange(2000) * 1e-4
    rec = Recording(t=t, u=3 * np.sin(2 * np.pi * 5 * t), y=np.zeros_like(t))
    model = build_model(s, 0, float(EX1.p0), EX1.weights, {
        "asymmetry": MapCoefficients(np.array([0.1, 0.02]), 0.5, 2.0),
        "creep": np.array([0.02, 0.01, 0.03]), "offset": np.array([0.2]),
        "drift": [np.array([0.1, -0.05])]}, rec)
    expected = {"initial-memory", "asymmetry", "creep", "offset", "drift",
                *(dynamics[:1] or ())}
    assert expected <= {st.type_name for st in model.stages}
    src = tmp_path / "model.json"
    ParameterSet.from_model(model, source="diagnosis layout").save(src)
    inv = tmp_path / "inv.json"
    assert main(["invert", str(src), "-o", str(inv), "--dt", "1e-4"]) == 0
    assert load_parameter_set(inv).model.to_dict() == model.inverse().to_dict()
    c = tmp_path / "comp.c"
    assert main(["export", str(src), "--format", "c", "-o", str(c), "--dt", "1e-4"]) == 0, \
        capsys.readouterr().err
    m = tmp_path / "comp.mat"
    assert main(["export", str(src), "--format", "mat", "-o", str(m)]) == 0
    assert loadmat(m, squeeze_me=True, struct_as_record=False)["model"].type == "chain"
    if GCC is None:
        pytest.skip("gcc not installed")
    res = subprocess.run([GCC, "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-c",
                          str(c), "-o", str(tmp_path / "comp.o")], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr


DATA = Path(__file__).resolve().parents[3] / "examples" / "data"


@pytest.mark.slow
@pytest.mark.parametrize("recording", [
    "piezo/piezo_150V_1Hz.csv",
    "bh_loops/MnZn_ferrite.csv",
    "bh_loops/M130-27s_GO_steel.csv",
    "friction_damper/1Hz30lbtension0.5amplitude.csv",
])
def test_diagnose_save_model_of_shipped_recordings_inverts_and_exports(recording, tmp_path,
                                                                       capsys) -> None:
    src = tmp_path / "model.json"
    assert main(["diagnose", str(DATA / recording), "--save-model", str(src), "-q"]) == 0
    capsys.readouterr()
    code = main(["invert", str(src), "-o", str(tmp_path / "inv.json"), "--dt", "1e-4"])
    assert code == 0, capsys.readouterr().err
    c = tmp_path / "comp.c"
    assert main(["export", str(src), "--format", "c", "-o", str(c), "--dt", "1e-4"]) == 0
    assert main(["export", str(src), "--format", "mat", "-o", str(tmp_path / "c.mat")]) == 0
    if GCC is not None:
        res = subprocess.run([GCC, "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror",
                              "-c", str(c), "-o", str(tmp_path / "c.o")], capture_output=True,
                             text=True)
        assert res.returncode == 0, res.stderr
