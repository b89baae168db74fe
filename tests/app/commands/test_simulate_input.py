"""``hyst simulate`` reads its input file with ``core.csvio.read_input``."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from core.paramset import ParameterSet
from core.pi import PIModel

EX1 = PIModel(0.72, [0.45 * i for i in range(1, 7)], [0.6, 0.48, 0.36, 0.24, 0.12, 0.012])


def run(capsys, *argv: object) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def ex1_file(tmp_path) -> Path:
    return ParameterSet.from_model(EX1).save(tmp_path / "ex1.json")


def read_back(path: Path) -> tuple[list[str], list[list[str]]]:
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


def test_input_only_csv_end_to_end(ex1_file, tmp_path, capsys):
    t = np.arange(200) * 1e-3
    u = 4 * np.sin(2 * np.pi * 5 * t)
    inp = tmp_path / "in.csv"
    np.savetxt(inp, np.column_stack([t, u]), delimiter=",", header="t,u", comments="",
               fmt="%.17g")
    code, out, _ = run(capsys, "simulate", ex1_file, "-i", inp, "-o", tmp_path / "o.csv",
                       "--json")
    assert code == 0 and json.loads(out)["n_samples"] == 200
    data = np.genfromtxt(tmp_path / "o.csv", delimiter=",", names=True)
    assert data.dtype.names == ("t", "u", "y")
    np.testing.assert_array_equal(data["t"], t)
    np.testing.assert_array_equal(data["y"], EX1(u))
    # one column, no time: the column is the input
    (tmp_path / "u.csv").write_text("u\n" + "".join(f"{v!r}\n" for v in u.tolist()))
    assert run(capsys, "simulate", ex1_file, "-i", tmp_path / "u.csv",
               "-o", tmp_path / "o1.csv")[0] == 0
    data = np.genfromtxt(tmp_path / "o1.csv", delimiter=",", names=True)
    assert data.dtype.names == ("u", "y")
    np.testing.assert_array_equal(data["y"], EX1(u))


def test_csv_that_also_has_an_output_column(ex1_file, tmp_path, capsys):
    u = np.array([0.0, 1.0, 2.5, 1.0, -1.0, 0.5])
    y_meas = u * 0.9
    inp = tmp_path / "meas.csv"
    pairs = zip(y_meas.tolist(), u.tolist(), strict=True)
    inp.write_text("t,y,u\n" + "".join(f"{k * 0.01!r},{a!r},{b!r}\n"
                                       for k, (a, b) in enumerate(pairs)))
    code, _, err = run(capsys, "simulate", ex1_file, "-i", inp, "-o", tmp_path / "o.csv")
    assert code == 2 and "already has a column 'y'; choose --output-name" in err
    code, _, _ = run(capsys, "simulate", ex1_file, "-i", inp, "-o", tmp_path / "o.csv",
                     "--output-name", "y_model")
    assert code == 0
    data = np.genfromtxt(tmp_path / "o.csv", delimiter=",", names=True)
    assert data.dtype.names == ("t", "y", "u", "y_model")
    np.testing.assert_array_equal(data["y"], y_meas)  # copied through, not used as input
    np.testing.assert_array_equal(data["y_model"], EX1(u))


def test_semicolon_decimal_comma_comments_and_text_column(ex1_file, tmp_path, capsys):
    inp = tmp_path / "scope.csv"
    inp.write_text("# exported by a scope\nt [s];u [V];note\n0,0;0,5;start\n0,1;2,5;\n"
                   "0,2;-1;end\n", encoding="utf-8")
    code, _, err = run(capsys, "simulate", ex1_file, "-i", inp, "-o", tmp_path / "o.csv")
    assert code == 0 and "note: skipped 1 comment line(s)" in err
    header, rows = read_back(tmp_path / "o.csv")
    assert header == ["t [s]", "u [V]", "note", "y"]
    assert [r[:3] for r in rows] == [["0.0", "0.5", "start"], ["0.1", "2.5", ""],
                                     ["0.2", "-1.0", "end"]]
    np.testing.assert_array_equal([float(r[3]) for r in rows], EX1(np.array([0.5, 2.5, -1])))


def test_dynamic_model_reads_dt_in_the_time_unit(tmp_path, capsys):
    from core.base import Chain
    from core.stages import Lag

    model = Chain.of(EX1, Lag(0.05))
    path = ParameterSet.from_model(model).save(tmp_path / "dyn.json")
    k = np.arange(500)
    u = 3 * np.sin(2 * np.pi * k / 250)
    inp = tmp_path / "in.csv"
    inp.write_text("t_ms,u\n" + "".join(f"{a},{b!r}\n" for a, b in zip(k, u.tolist(), strict=True)))
    code, out, _ = run(capsys, "simulate", path, "-i", inp, "-o", tmp_path / "o.csv", "--json")
    assert code == 0 and json.loads(out)["dt"] == pytest.approx(1e-3)
    y = np.genfromtxt(tmp_path / "o.csv", delimiter=",", names=True)["y"]
    np.testing.assert_allclose(y, model(u, dt=1e-3), rtol=0, atol=1e-12)
    # a time column that goes backwards: the csvio error names the line
    inp.write_text("t,u\n0,1\n0.1,2\n0.05,3\n0.2,4\n")
    code, _, err = run(capsys, "simulate", path, "-i", inp, "-o", tmp_path / "o.csv")
    assert code == 2 and "line 4 has t = 0.05 s after t = 0.1 s at line 3" in err
    # --dt overrides the time column, and a static model does not use it: both run
    assert run(capsys, "simulate", path, "-i", inp, "-o", tmp_path / "o.csv",
               "--dt", "0.1")[0] == 0
    static = ParameterSet.from_model(EX1).save(tmp_path / "ex1.json")
    assert run(capsys, "simulate", static, "-i", inp, "-o", tmp_path / "o.csv")[0] == 0


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("t,u\n0,1\n1,\n2,3\n", "line 3, input column 'u' (column 1): '' is not a finite number"),
        ("t,u\n0,1\n1,1.5.2\n", "line 3, input column 'u' (column 1): '1.5.2' is not a number"),
        ("t,u\n0,1\n1,2,3\n2,3\n", "line 3 has 3 field(s) but the header (line 1) has 2"),
        ("\n\n", "in.csv is empty: it holds only blank lines"),
    ],
)
def test_bad_input_only_files_give_csvio_errors(text, message, ex1_file, tmp_path, capsys):
    bad = tmp_path / "in.csv"
    bad.write_text(text)
    code, _, err = run(capsys, "simulate", ex1_file, "-i", bad, "-o", tmp_path / "o.csv")
    assert code == 2 and message in err and err.startswith("hyst simulate: error: ")
    assert not (tmp_path / "o.csv").exists()
