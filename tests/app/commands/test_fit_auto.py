"""``hyst fit`` on a clockwise (friction-like) loop: the default ``--model auto`` reports the
orientation and the base choice, and a kind that misses the loop warns in its text, its JSON
and the explorer's fit report (what the REST API and the browser show)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from app.cli import main
from app.services.analysis.fitting import fit_recording
from app.services.analysis.recordings import recording_from_csv


def _clockwise_csv(path: Path) -> Path:
    """Stress of an elastic-perfectly-plastic bar (E = 100, yield 1) under a tapered strain
    sine, written by hand (not the project's operators), 0.3 % noise."""
    t = np.arange(5000) * 1e-3
    u = 0.03 * np.sin(2 * np.pi * t) * (0.5 + 0.5 * np.minimum(1, t / 2))
    y = np.empty(u.size)
    plastic = 0.0
    for k, e in enumerate(u):
        s = 100.0 * (e - plastic)
        if abs(s) > 1.0:
            plastic = e - np.sign(s) / 100.0
            s = np.sign(s)
        y[k] = s
    y = y + 0.006 * np.random.default_rng(4).standard_normal(y.size)
    rows = "\n".join(f"{a:.6f},{b:.8g},{c:.8g}" for a, b, c in zip(t, u, y, strict=True))
    path.write_text("t_s,u_strain,y_MPa\n" + rows + "\n", encoding="utf-8")
    return path


def test_default_auto_fits_the_clockwise_loop_and_says_so(tmp_path, capsys) -> None:
    src = _clockwise_csv(tmp_path / "epp.csv")
    assert main(["fit", str(src), "-o", str(tmp_path / "m.json"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["model"]["stages"][0]["type"] == "stop-pi"
    rep = doc["report"]
    assert "clockwise" in rep["extra"]["orientation"]
    assert "as hyst diagnose chooses it" in rep["extra"]["base_choice"]
    assert rep["test"]["rmse"] < 1.3 * 0.006 and doc["warnings"] == rep["warnings"]
    # a perfectly plastic bar has no spring beside its sliders: the slope-bound warning says
    # the inverse is steep; no misfit warning
    assert not any("white-noise floor" in m for m in doc["warnings"])


def test_a_misfitting_kind_warns_in_text_json_and_the_explorer_report(tmp_path, capsys):
    src = _clockwise_csv(tmp_path / "epp.csv")
    assert main(["fit", str(src), "--model", "preisach", "-o", str(tmp_path / "p.json")]) == 0
    text = capsys.readouterr().out
    assert "warning: the held-out RMSE" in text and "white-noise floor" in text
    assert main(["fit", str(src), "--model", "preisach", "-o", str(tmp_path / "p.json"),
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    (w,) = [m for m in doc["warnings"] if "white-noise floor" in m]
    assert w in doc["report"]["warnings"] and "Largest residuals" in w
    # the explorer's fit (REST /fit and the browser show its report's warnings)
    out = fit_recording(recording_from_csv(src.read_bytes(), name="epp.csv"), 10, "preisach")
    assert any("white-noise floor" in m for m in out.report.warnings)
