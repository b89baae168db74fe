"""``hyst lesson``: list, write a shipped lesson, check a lesson file."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from app.cli import main
from app.services.teaching.lessons import builtin_lesson, parse_lesson


def test_list_write_and_check(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["lesson", "--list"]) == 0
    out = capsys.readouterr().out
    assert "pi-basics" in out and "what-a-diagnosis-finds" in out
    path = tmp_path / "pi.json"
    assert main(["lesson", "pi-basics", "-o", str(path)]) == 0
    assert parse_lesson(path.read_bytes()).to_dict() == builtin_lesson("pi-basics").to_dict()
    capsys.readouterr()
    assert main(["lesson", "--check", str(path), "--json"]) == 0
    assert len(json.loads(capsys.readouterr().out)["steps"]) == 6


def test_check_names_the_step_and_field(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                        ) -> None:
    doc = builtin_lesson("deadzone-gpi").to_dict()
    doc["steps"][2]["look_for"] = 7
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    assert main(["lesson", "--check", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "step 3 (The GPI inverts): look_for must be text, got 7" in err
    assert main(["lesson", "--check", str(tmp_path / "missing.toml")]) == 2
    assert "lesson file not found" in capsys.readouterr().err
    assert main(["lesson", "nope", "-o", str(tmp_path / "x.json")]) == 2
    assert "pi-basics" in capsys.readouterr().err
