"""``hyst diagnose``: JSON document, saved parameter set used by ``hyst simulate``, HTML report."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from core.effects import Lag
from core.paramset import load_parameter_set
from core.pi import PIModel

FS = 2000.0
TRUTH = PIModel(0.4, [6.0, 12.0, 18.0, 24.0, 30.0, 36.0, 42.0, 48.0, 54.0, 60.0],
                0.05 * np.exp(-np.arange(1, 11) * 6.0 / 30.0))


def _write(path: Path, t: np.ndarray, u: np.ndarray, y: np.ndarray) -> Path:
    np.savetxt(path, np.column_stack((t, u, y)), delimiter=",", header="t_s,u_V,y_um",
               comments="", fmt="%.10g")
    return path


@pytest.fixture
def lag_files(tmp_path) -> list[Path]:
    rng = np.random.default_rng(5)
    chain = TRUTH >> Lag(1e-3)
    files = []
    t = np.arange(0, 2.5, 1 / FS)
    for k, f in enumerate((2.0, 40.0)):
        u = 63.2 * np.sin(2 * np.pi * f * t) * (np.exp(-t / 2) if k == 0 else 1.0)
        y = chain(u, dt=1 / FS) + 0.01 * rng.standard_normal(u.size)
        files.append(_write(tmp_path / f"rec{k}.csv", t, u, y))
    return files


def test_json_is_one_object_with_effects_and_save_model_simulates(lag_files, tmp_path,
                                                                  capsys) -> None:
    model_path = tmp_path / "model.json"
    report = tmp_path / "report.html"
    code = main(["diagnose", *map(str, lag_files), "--json", "--operators", "10",
                 "--effects", "delay,lag,asymmetry", "--save-model", str(model_path),
                 "--report", str(report)])
    out, err = capsys.readouterr()
    assert code == 0, err
    doc = json.loads(out)  # exactly one JSON object on stdout
    assert [e["name"] for e in doc["effects"]][:1] == ["lag"]
    e = doc["effects"][0]
    for key in ("name", "parameters", "where", "explanation", "heldout_rmse_before",
                "heldout_rmse_after"):
        assert key in e
    assert e["heldout_rmse_after"] < e["heldout_rmse_before"]
    assert e["parameters"]["tau_s"] == pytest.approx(1e-3, rel=0.2)
    for key in ("untestable", "ambiguous", "baseline", "final"):
        assert key in doc
    # the parameter set loads and predicts a NEW input with the lag included
    ps = load_parameter_set(model_path)
    assert ps.provenance.fit["effects"][:1] == ["lag"]
    t = np.arange(0, 0.5, 1 / FS)
    u_new = 50 * np.sin(2 * np.pi * 25 * t)
    inp = tmp_path / "in.csv"
    np.savetxt(inp, np.column_stack((t, u_new)), delimiter=",", header="t,u", comments="")
    outp = tmp_path / "out.csv"
    assert main(["simulate", str(model_path), "--input", str(inp), "--output", str(outp)]) == 0
    y_sim = np.loadtxt(outp, delimiter=",", skiprows=1)[:, -1]
    y_true = (TRUTH >> Lag(1e-3))(u_new, dt=1 / FS)
    y_nolag = TRUTH(u_new)
    err_model = np.sqrt(np.mean((y_sim - y_true) ** 2))
    err_nolag = np.sqrt(np.mean((y_nolag - y_true) ** 2))
    assert err_model < 0.3 * err_nolag
    html = report.read_text(encoding="utf-8")
    assert "cdn.plot.ly" not in html and '<script src="http' not in html
    assert "Plotly.newPlot" in html and "lag" in html
    # two recordings: leave-one-recording-out scores in the JSON and the report
    lo = doc["final"]["leave_one_recording_out"]
    assert [p["recording"] for p in lo["per_recording"]] == ["rec0", "rec1"]
    assert lo["rmse"] < doc["baseline"]["leave_one_recording_out"]["rmse"]
    assert "Leave-one-recording-out" in html


def test_readable_report_without_json(lag_files, capsys) -> None:
    code = main(["diagnose", str(lag_files[1]), "--operators", "10", "--effects", "lag,drift",
                 "--train", "0:1.5", "--test", "1.5:2.5", "--fixed-grid"])
    out, _ = capsys.readouterr()
    assert code == 0
    assert "Baseline PI" in out and "held-out RMSE" in out
    assert "Untestable: drift" in out
    assert "Baseline PI (10 operators)" in out  # --fixed-grid keeps the requested grid


@pytest.mark.parametrize(
    "argv, msg",
    [
        (["diagnose", "missing.csv"], "does not exist"),
        (["diagnose", "{f}", "--effects", "teleport"], "unknown effect"),
    ],
)
def test_errors_exit_2_with_a_message(lag_files, capsys, argv, msg) -> None:
    argv = [a.format(f=lag_files[0]) for a in argv]
    assert main(argv) == 2
    assert msg in capsys.readouterr().err


def test_bad_range_is_rejected_by_the_parser(lag_files, capsys) -> None:
    with pytest.raises(SystemExit):
        main(["diagnose", str(lag_files[0]), "--train", "5:1", "--test", "1:2"])
    assert "T0 must be smaller than T1" in capsys.readouterr().err
