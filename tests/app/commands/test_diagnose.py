"""``hyst diagnose``: JSON document, saved parameter set used by ``hyst simulate``, HTML report."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from core.paramset import load_parameter_set
from core.pi import PIModel
from core.stages import Lag

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
    page = report.read_text(encoding="utf-8")  # its toolbar has nothing that leaves the machine
    assert '"displaylogo": false' in page and '"showSendToCloud": false' in page
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
    # the decaying sine: a 2.5 s record whose input cycle does not repeat cannot test a drift
    # (the 40 Hz sine repeats its cycle, so a drift is testable there from cycle to cycle)
    code = main(["diagnose", str(lag_files[0]), "--operators", "10", "--effects", "lag,drift",
                 "--train", "0:1.5", "--test", "1.5:2.5", "--fixed-grid"])
    out, _ = capsys.readouterr()
    assert code == 0
    assert "Baseline PI" in out and "held-out RMSE" in out
    assert "Untestable: drift" in out
    assert "Baseline PI (10 operators)" in out  # --fixed-grid keeps the requested grid


@pytest.mark.parametrize(
    "argv, msg",
    [
        (["diagnose", "missing.csv"], "recording not found: missing.csv"),
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


def test_reads_what_hyst_fit_reads_semicolon_decimal_comma_units_and_column_order(
        lag_files, tmp_path, capsys) -> None:
    """Same recording written as 'y;t;u' with decimal commas and a units row: same diagnosis
    as the plain file (core.csvio reads both); a gap in the time stamps is located."""
    d = np.loadtxt(lag_files[1], delimiter=",", skiprows=1)[::4]
    plain = _write(tmp_path / "plain.csv", d[:, 0], d[:, 1], d[:, 2])
    lines = ["output;time;input", "um;s;V"] + [
        f"{y:.10g};{t:.10g};{u:.10g}".replace(".", ",") for t, u, y in d]
    odd = tmp_path / "odd.csv"
    odd.write_text("\n".join(lines) + "\n", encoding="utf-8")
    docs = []
    for f in (plain, odd):
        assert main(["diagnose", str(f), "--json", "-q", "--effects", "lag",
                     "--operators", "10", "--fixed-grid"]) == 0
        docs.append(json.loads(capsys.readouterr().out))
    assert docs[0]["recordings"][0]["samples"] == docs[1]["recordings"][0]["samples"]
    assert docs[0]["baseline"]["heldout_rmse"] == pytest.approx(
        docs[1]["baseline"]["heldout_rmse"], rel=1e-6)
    gap = np.delete(d, np.s_[300:340], axis=0)
    gf = _write(tmp_path / "gap.csv", gap[:, 0], gap[:, 1], gap[:, 2])
    assert main(["diagnose", str(gf), "-q"]) == 2
    err = capsys.readouterr().err
    assert f"t = {d[299, 0]:.6g} s to t = {d[340, 0]:.6g} s" in err and "line 302" in err
    assert main(["diagnose", str(gf), "--resample", "--effects", "lag",
                 "--operators", "8", "--fixed-grid"]) == 0
    assert "note: resampled by linear interpolation" in capsys.readouterr().err


def test_a_time_gap_is_refused_with_this_commands_own_resample_option(tmp_path,
                                                                      capsys) -> None:
    """A 0.5 s jump in 10 ms time stamps: hyst diagnose says what to do with its own options
    (``--resample``, ``--resample=DT``) and the usual spacing, not the Python keyword."""
    t = np.arange(400) * 0.01
    t[200:] += 0.5
    u = np.sin(2 * np.pi * t)
    gf = _write(tmp_path / "gap.csv", t, u, u)
    assert main(["diagnose", str(gf), "-q"]) == 2
    err = capsys.readouterr().err
    assert "jump by 0.51 s" in err and "line 202" in err
    assert "hyst diagnose FILE.csv --resample (onto the usual spacing of 0.01 s)" in err
    assert "--resample=DT" in err and "resample=True" not in err


def test_quasi_static_loops_without_time_axis_are_diagnosed(capsys) -> None:
    """The shipped B-H loops (loop column, no time axis): rate-independent effects are tested,
    time-dependent ones reported untestable with the reason."""
    f = Path(__file__).parents[3] / "examples/data/bh_loops/MnZn_ferrite.csv"
    assert main(["diagnose", str(f), "--json", "--effects", "asymmetry,lag,creep",
                 "--operators", "10", "--fixed-grid"]) == 0
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    assert len(doc["recordings"]) >= 2 and not doc["recordings"][0]["time_axis"]
    why = {u["name"]: u["reason"] for u in doc["untestable"]}
    assert {"lag", "creep", "delay", "drift"} <= set(why) and "no time axis" in why["lag"]
    assert "asymmetry" in {t["effect"] for t in doc["tested"]}
    assert "%" in cap.err  # progress on stderr
    # the PI family misses the saturating loop well above the noise floor: the verdict says so
    # and names the loop shape that the generalized fits of ex13 reach (1.3-4.6 % of range)
    ad = doc["adequacy"]
    assert not ad["adequate"] and ad["pct"] > 5.0
    best = min(ad["loop_shapes"], key=lambda f: f["pct"])
    assert best["pct"] <= 4.6 and "saturation" in best["physics"]
    assert "saturation" in ad["text"] and "not adequate" in ad["text"]


def test_a_preisach_actuator_gets_a_preisach_base_that_inverts_and_exports(tmp_path,
                                                                           capsys) -> None:
    """Issue 16 from the command line: four recordings of a Preisach actuator (the
    benchmark's relay bank, density off-centre); the report names the base, the saved model
    inverts (hyst invert) and compiles (hyst export --format c); --base pi keeps the PI."""
    from benchmarks.diagnosis.families import make_family

    sc = make_family("preisach", None, "large", seed=500)
    files = [_write(tmp_path / f"{r.name}.csv", r.t, r.u, r.y) for r in sc.records]
    model = tmp_path / "m.json"
    assert main(["diagnose", *map(str, files), "--json", "-q", "--save-model",
                 str(model)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["baseline"]["model"] == "preisach"
    assert "level-dependent memory" in doc["baseline"]["base_choice"]["text"]
    assert doc["effects"] == []
    from app.services.analysis.diagnosis import (
        diagnosis_summary as _diagnosis_summary,  # the findings the web page and batch show
    )

    found = _diagnosis_summary(doc).findings
    assert any(f.endswith("the Preisach model explains the data") for f in found)
    assert any(f.startswith("Base model: level-dependent memory") for f in found)
    inv = tmp_path / "inv.json"
    assert main(["invert", str(model), "-o", str(inv)]) == 0
    assert main(["export", str(model), "--format", "c", "-o", str(tmp_path / "m")]) == 0
    if shutil.which("gcc"):
        res = subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-c",
                              str(tmp_path / "m.c"), "-o", str(tmp_path / "m.o")],
                             capture_output=True, text=True)
        assert res.returncode == 0, res.stderr
    capsys.readouterr()
    # --base pi holds the base to the PI whatever the effects searched: one effect suffices
    assert main(["diagnose", *map(str, files), "--json", "-q", "--base", "pi",
                 "--effects", "offset"]) == 0
    assert json.loads(capsys.readouterr().out)["baseline"]["model"] == "pi"


def test_the_findings_name_a_bouc_wen_base() -> None:
    """A diagnosis document whose base is the Bouc-Wen bank (core.diagnosis.bases): the
    findings the web page and batch show name it, not the PI (the base's text is the core's)."""
    from app.services.analysis.diagnosis import diagnosis_summary

    text = "Bouc-Wen: a bank of Bouc-Wen elements of fixed shapes"
    doc = {"baseline": {"model": "bouc-wen", "heldout_rmse": 0.2,
                        "base_choice": {"kind": "bouc-wen", "text": text}},
           "final": {"heldout_rmse": 0.2}, "effects": [], "adequacy": {"adequate": True}}
    found = diagnosis_summary(doc).findings
    assert found[0].endswith("the Bouc-Wen model explains the data")
    assert f"Base model: {text}" in found


def test_the_findings_do_not_say_the_model_explains_data_it_misses() -> None:
    """Nothing found while the residual is far above the noise floor (the real friction
    damper: 5.8 % of range, 10.9 times the floor): the findings say that nothing was found
    and what is not explained, never that the model explains the data; without a verdict
    they claim neither."""
    from app.services.analysis.diagnosis import diagnosis_summary

    verdict = ("the base model is not adequate: the final model still misses 5.78 % of the "
               "output range on the held-out rows (RMS 0.5405, 10.9 times the white-noise "
               "floor 0.0497)")
    doc = {"baseline": {"model": "pi", "heldout_rmse": 0.54, "heldout_rmse_pct": 5.78},
           "final": {"heldout_rmse": 0.54}, "effects": [],
           "adequacy": {"adequate": False, "text": verdict}}
    found = diagnosis_summary(doc).findings
    assert not any("explains the data" in f for f in found)
    assert "No effect of the list improved the held-out fit significantly." in found
    assert f"Not explained: {verdict}" in found
    del doc["adequacy"]
    found = diagnosis_summary(doc).findings
    assert not any("explains the data" in f or f.startswith("Not explained") for f in found)


def test_the_html_report_says_what_the_model_does_not_explain() -> None:
    """The MnZn ferrite loops without the loop-shape effects stay inadequate (core test
    ``test_adequacy_tries_every_registered_fit_kind``): the HTML report states the verdict
    and never "No missing physics detected"."""
    from app.services.analysis.diagnosis import diagnosis_html
    from core.datasets import DATA_DIR
    from core.diagnosis import diagnose

    res = diagnose(str(DATA_DIR / "bh_loops" / "MnZn_ferrite.csv"), effects=["asymmetry"],
                   n_operators=10, auto_resolution=False)
    assert res.adequacy is not None and not res.adequacy.adequate
    page = diagnosis_html(res)
    assert "<b>Not explained:</b> the base model is not adequate" in page
    assert "No missing physics detected" not in page
