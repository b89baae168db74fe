"""``hyst export --format fmu``: the FMU a user gets from the command line, and its errors."""

from __future__ import annotations

import json
import shutil
import zipfile

import pytest

from app.cli import main
from core.paramset import ParameterSet
from tests.core.model_zoo import DIAGNOSED, EX1

fmpy = pytest.importorskip("fmpy")
from fmpy.validation import validate_fmu  # noqa: E402

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def files(tmp_path):
    ex1 = ParameterSet.from_model(EX1, source="paper 001 Example 1").save(tmp_path / "ex1.json")
    dyn = ParameterSet.from_model(DIAGNOSED["diag-creep-offset"]).save(tmp_path / "dyn.json")
    return ex1, dyn


def test_export_fmu_both_versions_and_directions(files, tmp_path, capsys) -> None:
    ex1, dyn = files
    code, out, err = run(capsys, "export", ex1, "--format", "fmu", "--inverse", "--fmi", "2",
                         "--output", tmp_path / "comp.fmu", "--json")
    assert code == 0, err
    assert json.loads(out) == {"format": "fmu", "fmi": "2.0", "inverse": True,
                               "files": [str(tmp_path / "comp.fmu")]}
    assert validate_fmu(str(tmp_path / "comp.fmu")) == []
    md = fmpy.read_model_description(str(tmp_path / "comp.fmu"))
    assert md.fmiVersion == "2.0" and "paper 001 Example 1" in md.description
    code, out, err = run(capsys, "export", dyn, "-f", "fmu", "--dt", "1e-4", "-o",
                         tmp_path / "plant.fmu")
    assert code == 0, err
    assert "FMI 3.0 co-simulation, model" in out
    with zipfile.ZipFile(tmp_path / "plant.fmu") as zf:
        assert "binaries/x86_64-linux/plant.so" in zf.namelist()
    assert validate_fmu(str(tmp_path / "plant.fmu")) == []


@pytest.mark.parametrize(("argv", "message"), [
    (["--fmi", "4"], "--fmi 4: unknown FMI version; use --fmi 3 (FMI 3.0) or --fmi 2 (FMI 2.0)"),
    (["--no-inverse"], "an FMU holds one direction"),
    (["-o", "x.zip"], "an FMU file name ends in .fmu, e.g. --output x.fmu"),
])
def test_bad_fmu_options_name_the_option(files, tmp_path, capsys, argv, message) -> None:
    ex1, _ = files
    base = ["export", ex1, "-f", "fmu", "-o", tmp_path / "a.fmu"]
    code, _, err = run(capsys, *base, *argv)
    assert code == 2 and message in err
    assert not (tmp_path / "a.fmu").exists()


def test_a_dynamic_model_needs_dt_and_fmu_options_need_fmu(files, tmp_path, capsys) -> None:
    ex1, dyn = files
    code, _, err = run(capsys, "export", dyn, "-f", "fmu", "-o", tmp_path / "d.fmu")
    assert code == 2 and "give it with --dt (seconds), e.g. --dt 1e-4" in err
    code, _, err = run(capsys, "export", ex1, "-f", "c", "--inverse", "-o", tmp_path / "c.c")
    assert code == 2 and "--inverse and --fmi are options of --format fmu" in err


def test_missing_compiler_is_a_clear_error(files, tmp_path, capsys, monkeypatch) -> None:
    ex1, _ = files
    monkeypatch.setenv("CC", "no-such-compiler")
    code, _, err = run(capsys, "export", ex1, "-f", "fmu", "-o", tmp_path / "a.fmu")
    assert code == 2
    assert "'no-such-compiler' was not found on the PATH; install gcc" in err


def test_a_model_without_inverse_says_to_export_the_model(tmp_path, capsys) -> None:
    from core.pi import PIModel

    bad = ParameterSet.from_model(PIModel(1.0, [1.0, 2.0], [-1.0, 0.5])).save(tmp_path / "n.json")
    code, _, err = run(capsys, "export", bad, "-f", "fmu", "--inverse", "-o", tmp_path / "n.fmu")
    assert code == 2 and "export the model itself (without --inverse)" in err
    code, _, err = run(capsys, "export", bad, "-f", "fmu", "-o", tmp_path / "n.fmu")
    assert code == 0, err
