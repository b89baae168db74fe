"""The ``hyst`` command line, called in-process through ``app.cli.main``."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from core.paramset import ParameterSet, load_parameter_set
from core.pi import PIModel

ROOT = Path(__file__).resolve().parents[2]
PIEZO = ROOT / "examples" / "data" / "piezo" / "piezo_150V_1Hz.csv"
EX1 = PIModel(0.72, [0.45 * i for i in range(1, 7)], [0.6, 0.48, 0.36, 0.24, 0.12, 0.012])
COMMANDS = ("demo", "export", "fit", "invert", "preset", "simulate")


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def ex1_file(tmp_path) -> Path:
    return ParameterSet.from_model(EX1, source="paper 001 Example 1").save(tmp_path / "ex1.json")


def write_csv(path: Path, header: str, data: np.ndarray) -> Path:
    np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.17g")
    return path


# ----------------------------------------------------------------------------- help
@pytest.mark.parametrize("cmd", COMMANDS)
def test_every_subcommand_has_help(cmd, capsys):
    with pytest.raises(SystemExit) as exc:
        main([cmd, "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith(f"usage: hyst {cmd}")


def test_hyst_help_subprocess_lists_commands():
    exe = ROOT / ".venv" / "bin" / "hyst"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "app"]
    res = subprocess.run([*cmd, "--help"], capture_output=True, text=True, cwd=ROOT)
    assert res.returncode == 0, res.stderr
    for c in COMMANDS:
        assert c in res.stdout


def test_no_command_prints_help_and_fails(capsys):
    assert main([]) == 2
    assert "usage: hyst" in capsys.readouterr().out


# ----------------------------------------------------------------------------- preset
def test_preset_list_and_write(tmp_path, capsys):
    code, out, _ = run(capsys, "preset", "--list", "--json")
    assert code == 0
    names = [p["name"] for p in json.loads(out)["presets"]]
    assert names
    code, out, _ = run(capsys, "preset", names[0], "--output", tmp_path / "p.json")
    assert code == 0 and "wrote" in out
    ps = load_parameter_set(tmp_path / "p.json")
    assert ps.provenance.source and names[0] in ps.provenance.source


def test_preset_paper001_example1_when_available(tmp_path, capsys):
    from app.commands.preset import available_presets

    names = [p["name"] for p in available_presets()]
    assert "paper001-example1" in names
    assert run(capsys, "preset", "paper001-example1", "-o", tmp_path / "e.json")[0] == 0
    ps = load_parameter_set(tmp_path / "e.json")
    assert isinstance(ps.model, PIModel)
    np.testing.assert_allclose(ps.model.slopes, [0.72, 1.32, 1.8, 2.16, 2.4, 2.52, 2.532])
    assert "Example 1" in ps.provenance.source


def test_preset_errors(tmp_path, capsys):
    code, _, err = run(capsys, "preset", "no-such-preset", "-o", tmp_path / "x.json")
    assert code == 2
    assert "unknown preset 'no-such-preset'; known presets:" in err
    code, _, err = run(capsys, "preset")
    assert code == 2 and "give a preset NAME" in err
    assert not (tmp_path / "x.json").exists()


# ----------------------------------------------------------------------------- invert
def test_invert_writes_paper001_example2(ex1_file, tmp_path, capsys):
    code, out, _ = run(capsys, "invert", ex1_file, "--output", tmp_path / "inv.json", "--json")
    assert code == 0
    summary = json.loads(out)
    inv = load_parameter_set(tmp_path / "inv.json")
    # paper 001 Example 2 (printed to 3-4 decimals)
    np.testing.assert_allclose(inv.model.thresholds, [0.324, 0.918, 1.728, 2.7, 3.78, 4.914])
    np.testing.assert_allclose(
        inv.model.weights, [-0.6313, -0.2020, -0.0926, -0.0463, -0.0198, -0.0019], atol=6e-5
    )
    assert summary["units"] == {"input": "um", "output": "V", "time": "s"}
    u = 10 * np.sin(np.linspace(0, 4 * np.pi, 400))
    np.testing.assert_allclose(EX1(inv.model(u)), u, atol=1e-12)


def test_invert_accepts_a_bare_model(tmp_path, capsys):
    p = tmp_path / "bare.json"
    p.write_text(json.dumps(EX1.to_dict()))
    assert run(capsys, "invert", p, "-o", tmp_path / "inv.json")[0] == 0
    assert load_parameter_set(tmp_path / "inv.json").model.p0 == pytest.approx(1 / 0.72)


def test_invert_errors(tmp_path, capsys):
    code, _, err = run(capsys, "invert", tmp_path / "missing.json", "-o", tmp_path / "o.json")
    assert code == 2 and "model file not found" in err and "missing.json" in err

    bad_json = tmp_path / "bad.json"
    bad_json.write_text('{"format": "hysteresis-explorer/parameter-set", "version": 1,')
    code, _, err = run(capsys, "invert", bad_json, "-o", tmp_path / "o.json")
    assert code == 2 and "bad.json: not valid JSON" in err and "line 1" in err

    d = ParameterSet.from_model(EX1).to_dict()
    d["model"]["weights"][3] = "x"
    bad_field = tmp_path / "field.json"
    bad_field.write_text(json.dumps(d))
    code, _, err = run(capsys, "invert", bad_field, "-o", tmp_path / "o.json")
    assert code == 2 and 'model.weights[3]: must be a number, got a string "x"' in err

    non_inv = ParameterSet.from_model(PIModel(1.0, [1.0, 2.0], [-1.0, 0.5]))
    path = non_inv.save(tmp_path / "noninv.json")
    code, _, err = run(capsys, "invert", path, "-o", tmp_path / "o.json")
    assert code == 2
    assert "not invertible" in err and "S2" in err
    assert not (tmp_path / "o.json").exists()


# ----------------------------------------------------------------------------- export
def test_export_json_mat_and_c(ex1_file, tmp_path, capsys):
    from scipy.io import loadmat

    assert run(capsys, "export", ex1_file, "--format", "json", "-o", tmp_path / "a.json")[0] == 0
    assert load_parameter_set(tmp_path / "a.json").to_dict()["model"] == EX1.to_dict()

    assert run(capsys, "export", ex1_file, "--format", "mat", "-o", tmp_path / "a.mat")[0] == 0
    d = loadmat(tmp_path / "a.mat", squeeze_me=True, struct_as_record=False)
    np.testing.assert_array_equal(d["model"].weights, EX1.weights)

    code, out, _ = run(capsys, "export", ex1_file, "-f", "c", "-o", tmp_path / "c" / "comp.c",
                       "--json")
    assert code == 0
    files = json.loads(out)["files"]
    assert [Path(f).name for f in files] == ["comp.h", "comp.c"]
    assert "double comp_inv_step(comp_inv_state *st, double u);" in Path(files[0]).read_text()
    if shutil.which("gcc"):
        res = subprocess.run(
            ["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-c", files[1], "-o",
             str(tmp_path / "comp.o")], capture_output=True, text=True,
        )
        assert res.returncode == 0, res.stderr


def test_export_errors(ex1_file, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["export", str(ex1_file), "--format", "xlsx", "-o", str(tmp_path / "a")])
    assert exc.value.code == 2
    assert "invalid choice: 'xlsx'" in capsys.readouterr().err
    non_inv = ParameterSet.from_model(PIModel(1.0, [1.0, 2.0], [-1.0, 0.5])).save(
        tmp_path / "n.json"
    )
    code, _, err = run(capsys, "export", non_inv, "-f", "c", "-o", tmp_path / "n.c")
    assert code == 2 and "not invertible" in err and "use --no-inverse" in err
    code, _, err = run(capsys, "export", non_inv, "-f", "c", "--no-inverse", "-o",
                       tmp_path / "n.c")
    assert code == 0
    code, _, err = run(capsys, "export", ex1_file, "-f", "c", "--name", "9bad",
                       "-o", tmp_path / "x.c")
    assert code == 2 and "not a valid C identifier" in err


# ----------------------------------------------------------------------------- simulate
def test_simulate_writes_output_column(ex1_file, tmp_path, capsys):
    t = np.linspace(0, 2, 801)
    u = 4 * np.sin(2 * np.pi * t)
    inp = write_csv(tmp_path / "in.csv", "t,u", np.column_stack([t, u]))
    code, out, _ = run(capsys, "simulate", ex1_file, "--input", inp, "--output",
                       tmp_path / "out.csv", "--json")
    assert code == 0
    assert json.loads(out)["n_samples"] == 801
    data = np.genfromtxt(tmp_path / "out.csv", delimiter=",", names=True)
    assert data.dtype.names == ("t", "u", "y")
    np.testing.assert_array_equal(data["u"], u)  # written losslessly
    np.testing.assert_array_equal(data["y"], EX1(u))

    code, _, _ = run(capsys, "simulate", ex1_file, "-i", inp, "-o", tmp_path / "inv.csv",
                     "--inverse", "--output-name", "v")
    assert code == 0
    v = np.genfromtxt(tmp_path / "inv.csv", delimiter=",", names=True)["v"]
    np.testing.assert_allclose(EX1(v), u, atol=1e-12)


def test_simulate_dynamic_model_uses_dt_from_time_column(tmp_path, capsys):
    from core.base import Chain
    from core.stages import Lag

    model = Chain.of(EX1, Lag(0.05))
    path = ParameterSet.from_model(model).save(tmp_path / "dyn.json")
    t = np.arange(0, 1, 1e-3)
    u = 3 * np.sin(2 * np.pi * 2 * t)
    inp = write_csv(tmp_path / "in.csv", "t,u", np.column_stack([t, u]))
    assert run(capsys, "simulate", path, "-i", inp, "-o", tmp_path / "o.csv")[0] == 0
    y = np.genfromtxt(tmp_path / "o.csv", delimiter=",", names=True)["y"]
    np.testing.assert_allclose(y, model(u, dt=1e-3), rtol=0, atol=1e-12)
    # non-uniform time column: a clear error
    t2 = t.copy()
    t2[500:] += 0.01
    write_csv(inp, "t,u", np.column_stack([t2, u]))
    code, _, err = run(capsys, "simulate", path, "-i", inp, "-o", tmp_path / "o.csv")
    assert code == 2 and "not uniformly sampled" in err


def test_simulate_errors(ex1_file, tmp_path, capsys):
    code, _, err = run(capsys, "simulate", ex1_file, "-i", tmp_path / "none.csv",
                       "-o", tmp_path / "o.csv")
    assert code == 2 and "CSV file not found" in err
    bad = tmp_path / "bad.csv"
    bad.write_text("t,u\n0,1\n0.1,abc\n")
    code, _, err = run(capsys, "simulate", ex1_file, "-i", bad, "-o", tmp_path / "o.csv")
    # core.csvio's message: line, role and column, the cell, what to do
    assert code == 2 and "line 3, input column 'u' (column 1): 'abc' is not a number" in err
    assert "fix or delete that row" in err
    ok = write_csv(tmp_path / "ok.csv", "time,drive", np.array([[0, 1.0], [1, 2.0]]))
    code, _, err = run(capsys, "simulate", ex1_file, "-i", ok, "-o", tmp_path / "o.csv",
                       "--input-column", "volts")
    assert code == 2 and "no input column 'volts'; columns are: time, drive" in err


# ----------------------------------------------------------------------------- fit
def synthetic_recording(path: Path, n: int = 6000) -> Path:
    t = np.arange(n) * 1e-3
    u = 3.0 * np.sin(2 * np.pi * t) * (1 - 0.5 * t / t[-1])
    true = PIModel(0.5, [0.5, 1.0, 1.5, 2.0], [0.3, 0.2, 0.15, 0.1])
    y = true(u) + 0.25
    return write_csv(path, "t_s,u_V,y_um", np.column_stack([t, u, y]))


def test_fit_recovers_a_known_model_and_records_provenance(tmp_path, capsys):
    rec = synthetic_recording(tmp_path / "rec.csv")
    code, out, err = run(capsys, "fit", rec, "--model", "pi", "-n", "4", "--train", ":4.5",
                         "--test", "4.5:", "--output", tmp_path / "m.json", "--json")
    assert code == 0, err
    summary = json.loads(out)
    # same model class (thresholds placed by rule, not the true ones): small error
    assert summary["report"]["train"]["rmse_pct"] < 0.5
    assert summary["report"]["test"]["n_samples"] == 1500
    ps = load_parameter_set(tmp_path / "m.json")
    assert ps.units.to_dict() == {"input": "V", "output": "µm", "time": "s"}
    assert ps.provenance.fit["columns"] == {"time": "t_s", "input": "u_V", "output": "y_um"}
    # the saved model is the one the report scored (offset included)
    data = np.genfromtxt(rec, delimiter=",", names=True)
    e = ps.model(data["u_V"]) - data["y_um"]
    train = data["t_s"] < 4.5
    assert np.sqrt(np.mean(e[train] ** 2)) == pytest.approx(
        summary["report"]["train"]["rmse"], rel=1e-6
    )


def test_fit_progress_goes_to_stderr(tmp_path, capsys):
    rec = synthetic_recording(tmp_path / "rec.csv", 3000)
    code, out, err = run(capsys, "fit", rec, rec, "-n", "3", "-o", tmp_path / "m.json")
    assert code == 0
    assert "[hyst fit" in err and "fitting the base hyst diagnose would choose" in err
    assert "with n = 3" in err and "base chosen: " in err
    assert "[hyst fit" not in out and "train: RMSE" in out


@pytest.mark.skipif(not PIEZO.exists(), reason="shipped piezo recording missing")
def test_fit_real_piezo_recording(tmp_path, capsys):
    code, out, _ = run(capsys, "fit", PIEZO, "-n", "8", "--test", "8:", "-o",
                       tmp_path / "p.json", "--json")
    assert code == 0
    rep = json.loads(out)["report"]
    # a rate-independent PI explains this 150 V piezo loop to a few % of the stroke
    assert rep["test"]["rmse_pct"] < 5.0
    assert rep["invertible"] is True


def test_fit_errors(tmp_path, capsys):
    rec = synthetic_recording(tmp_path / "rec.csv", 2000)
    code, _, err = run(capsys, "fit", rec, "--train", "5-6", "-o", tmp_path / "m.json")
    assert code == 2 and "expected T0:T1" in err
    code, _, err = run(capsys, "fit", rec, "--train", "100:200", "-o", tmp_path / "m.json")
    assert code == 2 and "--train window selects no samples" in err
    code, _, err = run(capsys, "fit", tmp_path / "nope.csv", "-o", tmp_path / "m.json")
    assert code == 2 and "CSV file not found" in err
    code, _, err = run(capsys, "fit", rec, "--output-column", "force", "-o", tmp_path / "m.json")
    assert code == 2 and "no column named 'force' for output" in err
    with pytest.raises(SystemExit):
        main(["fit", str(rec), "--model", "neural-net", "-o", str(tmp_path / "m.json")])
    assert "invalid choice" in capsys.readouterr().err


# ----------------------------------------------------------------------------- demo
def test_demo_prints_example1_and_writes_html(tmp_path, capsys):
    code, out, _ = run(capsys, "demo", "--out", tmp_path, "--no-open")
    assert code == 0
    assert "S_1..S_7 = {0.72, 1.32, 1.8, 2.16, 2.4, 2.52, 2.532}" in out
    assert "= 1.518" in out
    assert "z_i = {0.324, 0.918, 1.728, 2.7, 3.78, 4.914}" in out
    assert "q0 = 1.3889" in out
    html = (tmp_path / "demo.html").read_text()
    assert "<html" in html and "Plotly.newPlot" in html
    assert '<script src="http' not in html  # plotly.js is inlined: works offline
    code, out, _ = run(capsys, "demo", "--out", tmp_path, "--no-open", "--json")
    d = json.loads(out)
    assert d["max_loop_width"] == pytest.approx(1.518, abs=5e-4)
    assert d["compensation_max_abs_error"] < 1e-12


def test_fit_splits_runs_and_accepts_constraint(tmp_path, capsys):
    # one file, two runs told apart by a "loop" column (like the shared B-H loops)
    k = np.arange(800)
    true = PIModel(1.0, [0.5, 1.0, 1.5], [-0.3, -0.3, -0.2])  # saturating loop
    rows = []
    for run_id, amp in enumerate((3.0, 2.0)):
        u = amp * np.sin(2 * np.pi * k / 400)
        rows.append(np.column_stack([np.full(k.size, run_id), k * 1e-3, u, true(u)]))
    rec = write_csv(tmp_path / "runs.csv", "loop,t,u,y", np.vstack(rows))
    code, out, err = run(capsys, "fit", rec, "--model", "pi", "-n", "3", "--constraint",
                         "slopes", "-o", tmp_path / "m.json", "--json")
    assert code == 0, err
    ps = load_parameter_set(tmp_path / "m.json")
    assert len(ps.provenance.fit["recordings"]) == 2
    slopes = ps.model.stages[0].slopes
    assert (slopes > 0).all() and np.diff(slopes).min() < -0.1  # negative weights allowed


@pytest.mark.parametrize("family", ["gpi-deadzone", "mpi", "gpi-tanh", "digitized", "preisach",
                                    "bouc-wen"])
def test_fit_other_model_families(family, tmp_path, capsys):
    rec = synthetic_recording(tmp_path / "rec.csv", 3000)
    code, out, err = run(capsys, "fit", rec, "--model", family, "-n", "4", "-o",
                         tmp_path / "m.json", "--json")
    assert code == 0, err
    summary = json.loads(out)
    assert summary["report"]["invertible"] is True
    ps = load_parameter_set(tmp_path / "m.json", require_inverse=True)
    assert ps.provenance.fit["model"] == family
    data = np.genfromtxt(rec, delimiter=",", names=True)
    e = ps.model(data["u_V"]) - data["y_um"]
    assert np.sqrt(np.mean(e**2)) < 0.05 * np.ptp(data["y_um"])
    # the saved model can be inverted and exported to C by the other sub-commands
    assert run(capsys, "invert", tmp_path / "m.json", "-o", tmp_path / "inv.json")[0] == 0
    code, _, err = run(capsys, "export", tmp_path / "m.json", "-f", "c", "-o", tmp_path / "c.c")
    assert code == 0, err
    if shutil.which("gcc"):
        res = subprocess.run(
            ["gcc", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-c",
             str(tmp_path / "c.c"), "-o", str(tmp_path / "c.o")], capture_output=True, text=True,
        )
        assert res.returncode == 0, res.stderr


def test_export_c_of_a_dynamic_model_needs_dt(tmp_path, capsys):
    from core.lti import LinearSystem

    ps = ParameterSet.from_model(EX1 >> LinearSystem([0.5, 1.0], [0.01, 1.0]))
    path = ps.save(tmp_path / "dyn.json")
    code, _, err = run(capsys, "export", path, "-f", "c", "-o", tmp_path / "d.c")
    assert code == 2 and "--dt" in err
    code, _, err = run(capsys, "export", path, "-f", "c", "--dt", "1e-4", "-o", tmp_path / "d.c")
    assert code == 0, err
    assert "dt = 0.0001" in (tmp_path / "d.h").read_text()


def test_progress_heartbeat_repeats_on_stderr_until_the_block_ends(capsys):
    import time

    from app.services.runs.progress import Progress

    seen = ""
    with Progress("fit").heartbeat("still fitting...", every=0.01):
        deadline = time.monotonic() + 10.0
        while seen.count("still fitting...") < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
            seen += capsys.readouterr().err
    seen += capsys.readouterr().err  # beats written before the block ended (worker joined)
    assert seen.count("[hyst fit") >= 2
    time.sleep(0.05)
    assert "still fitting" not in capsys.readouterr().err  # nothing after the block ended
    with Progress("fit", quiet=True).heartbeat("x", every=0.001):
        time.sleep(0.02)
    assert capsys.readouterr().err == ""


def test_every_preset_round_trips_through_its_parameter_set(tmp_path, capsys):
    from core.presets import get_preset, list_presets

    for info in list_presets():
        path = tmp_path / f"{info.name}.json"
        assert run(capsys, "preset", info.name, "-o", path)[0] == 0
        ps = load_parameter_set(path)
        assert ps.model.to_dict() == get_preset(info.name).to_dict()
        assert ps.provenance.source == f"hyst preset {info.name}: {info.title}"


def test_demo_opens_a_browser_only_with_a_display(tmp_path, capsys, monkeypatch):
    import webbrowser

    opened: list[str] = []
    monkeypatch.setattr(webbrowser, "open", lambda url, *a, **k: opened.append(url) or True)
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    code, _, err = run(capsys, "demo", "--out", tmp_path)
    assert code == 0 and opened == [] and "no display: open file://" in err
    monkeypatch.setenv("DISPLAY", ":0")
    assert run(capsys, "demo", "--out", tmp_path)[0] == 0
    assert opened == [(tmp_path / "demo.html").resolve().as_uri()]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "the file is empty"),
        ("1,2\n3,4\n", "the first row must name the columns"),
        ("t,u\n", "no data rows after the header"),
        ("t,u\n0,1\n1,2,3\n", "line 3 has 3 field(s) but the header (line 1) has 2"),
    ],
)
def test_simulate_reports_bad_csv_layouts(text, message, ex1_file, tmp_path, capsys):
    bad = tmp_path / "in.csv"
    bad.write_text(text)
    code, _, err = run(capsys, "simulate", ex1_file, "-i", bad, "-o", tmp_path / "o.csv")
    assert code == 2 and message in err and "in.csv" in err
