"""Input-only CSV files (a signal to simulate, no output column): ``core.csvio.read_input``."""

from __future__ import annotations

import numpy as np
import pytest

from core.csvio import CSVError, InputSignal, inspect_csv, read_csv, read_input


def test_time_and_input_with_units():
    sig = read_input("t_ms,u_V\n0,0\n1,2.5\n2,-1\n3,4\n")
    assert isinstance(sig, InputSignal)
    np.testing.assert_allclose(sig.t, [0, 1e-3, 2e-3, 3e-3])
    np.testing.assert_array_equal(sig.u, [0, 2.5, -1, 4])
    assert sig.units == {"time": "s", "input": "V"} and sig.has_time
    assert sig.columns == {"time": "t_ms", "input": "u_V"}
    assert sig.names == ("t_ms", "u_V") and sig.n_samples == 4
    np.testing.assert_array_equal(sig.values[0], [0, 1, 2, 3])  # as written, in ms
    assert any("from ms to s" in c for c in sig.cleaning)
    np.testing.assert_array_equal(sig.lines, [2, 3, 4, 5])
    assert not sig.u.flags.writeable


def test_one_column_file_is_the_input():
    sig = read_input("u\n1\n2\n2\n")  # a constant stretch and 3 samples are fine here
    np.testing.assert_array_equal(sig.u, [1, 2, 2])
    assert not sig.has_time and sig.units["time"] == "sample"
    np.testing.assert_array_equal(sig.t, [0, 1, 2])
    assert inspect_csv("u\n1\n2\n", min_columns=1).columns[0].raw == "u"
    with pytest.raises(CSVError, match="has a single column"):  # recordings still need two
        inspect_csv("u\n1\n2\n")


def test_output_column_is_kept_never_taken_as_input():
    sig = read_input("t,y,u\n0,5,1\n1,6,2\n2,7,3\n")
    assert sig.columns == {"time": "t", "input": "u"}
    np.testing.assert_array_equal(sig.extra["y"], [5, 6, 7])
    assert [list(v) for v in sig.values] == [[0, 1, 2], [5, 6, 7], [1, 2, 3]]
    # two unnamed columns: time then input, like read_csv's layouts
    sig = read_input("a,b\n0,3\n1,4\n2,5\n")
    assert sig.columns == {"time": "a", "input": "b"}


def test_layout_detection_is_shared_with_read_csv():
    text = "# scope dump\nsep=;\nt [s];u [V];label\n0,0;1,5;a\n0,1;-2,5;b\n0,2;3;c\n"
    sig = read_input(text)
    np.testing.assert_allclose(sig.t, [0, 0.1, 0.2])
    np.testing.assert_array_equal(sig.u, [1.5, -2.5, 3.0])
    assert sig.layout.delimiter == ";" and sig.layout.decimal == ","
    assert list(sig.extra["label"]) == ["a", "b", "c"]
    assert any("comment line" in c for c in sig.cleaning)


def test_fs_and_explicit_columns():
    sig = read_input("x,v\n3,1\n1,2\n2,3\n", time=False, input="v", fs=100.0)
    np.testing.assert_allclose(sig.t, [0, 0.01, 0.02])
    assert sig.columns == {"time": "", "input": "v"} and sig.has_time
    with pytest.raises(CSVError, match="fs=100.0 was given but column"):
        read_input("t,u\n0,1\n1,2\n", fs=100.0)


def test_bad_cell_names_line_column_and_fix():
    with pytest.raises(CSVError, match=r"line 3, input column 'u' \(column 1\): 'abc' is not "
                                       r"a number; fix or delete that row") as ei:
        read_input("t,u\n0,1\n1,abc\n2,3\n")
    assert (ei.value.line, ei.value.column, ei.value.column_index) == (3, "u", 1)
    with pytest.raises(CSVError, match=r"'1\.5' is not a number; the file uses decimal commas"):
        read_input("t;u\n0;1,5\n1;1.5\n2;2,5\n")


@pytest.mark.parametrize(
    ("text", "pattern", "line"),
    [
        ("", r"the file is empty \(0 bytes\)", None),
        ("t,u\n", r"only a header \(line 1: t, u\) and no data rows after the header", 1),
        ("t,u\n0,1\n1,2,3\n2,3\n", r"line 3 has 3 field\(s\) but the header \(line 1\) has 2",
         3),
        ("a,b\n0,1\n2,2\n1,3\n", r"column 'a' \(column 0\) is not monotone increasing.*"
         r"time=False if the file has no time column, together with input=$", 4),
        ("t,u\n0,1\n0,2\n1,3\n", r"line 3 repeats t = 0 s of line 2", 3),
        ("t,u\n0,1\n1,2\n5,3\n6,4\n", r"time stamps in column 't' \(column 0\) are uneven", 4),
        ("t,u\n0,1\n\n1,\n2,3\n", r"line 4, input column 'u' \(column 1\): '' is not a finite "
         r"number", 4),
        ("u\n1\n\x00\n", r"not a text CSV: NUL byte", 3),
    ],
)
def test_bad_input_only_files_raise_clear_errors(text, pattern, line):
    kw = {"nan": "error"} if "finite" in pattern else {}
    with pytest.raises(CSVError, match=pattern) as ei:
        read_input(text.encode() if "\x00" in text or not text else text, **kw)
    assert ei.value.line == line


def test_nan_rows_dropped_and_listed():
    sig = read_input("t,u\n" + "".join(f"{k},{'' if k == 7 else k}\n" for k in range(40)))
    assert sig.n_samples == 39 and 9 not in sig.lines.tolist()
    assert any("removed 1 row(s) with empty/NaN/inf input at line(s) 9" in c
               for c in sig.cleaning)
    assert all(v.size == 39 for v in sig.values)
    with pytest.raises(CSVError, match=r"1 of 3 rows .* more than max_dropped=0.05"):
        read_input("t,u\n0,1\n1,nan\n2,3\n")


def test_uneven_keep_and_option_checks():
    sig = read_input("t,u\n0,1\n1,2\n5,3\n6,4\n", uneven="keep")
    assert any("kept as measured" in c for c in sig.cleaning)
    with pytest.raises(CSVError, match="min_samples=0 must be"):
        read_input("u\n1\n", min_samples=0)
    with pytest.raises(CSVError, match=r"only 2 usable sample\(s\).*min_samples=3"):
        read_input("u\n1\n2\n", min_samples=3)
    with pytest.raises(CSVError, match="nan='x' must be"):
        read_input("u\n1\n", nan="x")  # type: ignore[arg-type]


def test_read_csv_output_false_points_to_read_input():
    with pytest.raises(CSVError, match=r"output=False: .* read_input\(\)"):
        read_csv("t,u\n0,1\n1,2\n", output=False)
