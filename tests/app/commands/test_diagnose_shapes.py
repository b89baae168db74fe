"""Command-line journey of a loop-shape diagnosis: diagnose -> save -> invert -> export C."""

from __future__ import annotations

from pathlib import Path

from app.cli import main

BH = Path(__file__).parents[3] / "examples" / "data" / "bh_loops"


def test_cli_saved_loop_shape_model_inverts_and_exports(tmp_path, capsys) -> None:
    """The journey: `hyst diagnose --save-model` on a B-H file, then `hyst invert` and
    `hyst export --format c` of what it wrote (the model is a gpi-tanh chain)."""
    saved = tmp_path / "ext.json"
    assert main(["diagnose", str(BH / "MnZn_HP_ferrite.csv"), "-q", "--effects",
                 "saturation,dead-zone", "--save-model", str(saved)]) == 0
    assert "saturation" in capsys.readouterr().out
    doc = saved.read_text()
    assert '"gpi-tanh"' in doc
    assert main(["invert", str(saved), "-o", str(tmp_path / "inv.json")]) == 0
    assert main(["export", str(saved), "--format", "c", "-o", str(tmp_path / "comp")]) == 0
    assert "tanh" in (tmp_path / "comp.c").read_text()
