"""CSV reading: layouts, units, runs, cleaning reports, every error path, Recording helpers."""

from __future__ import annotations

import io
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.csvio import (
    CSVError,
    TimeOrderError,
    inspect_csv,
    parse_column_name,
    read_csv,
    read_csvs,
    read_recording,
)
from core.exceptions import ParameterError
from core.recordings import Recording

N = 40
T = np.arange(N) * 0.01  # 100 Hz
U = np.sin(2 * np.pi * T * 2.5) * 10.0  # a few reversals
Y = 0.5 * U + np.cos(2 * np.pi * T * 2.5)


def table(header: str | None = "t_s,u_V,y_um", sep: str = ",", dec: str = ".",
          rows: list[list[float]] | None = None, fmt: str = "{:.6f}") -> str:
    """CSV text of (T, U, Y) or ``rows`` with the given separator and decimal mark."""
    rows = rows if rows is not None else list(zip(T, U, Y, strict=True))
    lines = [] if header is None else [header.replace(",", sep)]
    for r in rows:
        lines.append(sep.join(fmt.format(v).replace(".", dec) for v in r))
    return "\n".join(lines) + "\n"


def with_line(text: str, line: int, new: str) -> str:
    """Replace 1-based ``line`` of ``text``."""
    ls = text.split("\n")
    ls[line - 1] = new
    return "\n".join(ls)


# ------------------------------------------------------------------------------ happy paths
def test_header_comma_file_reads_values_units_and_rate(tmp_path):
    p = tmp_path / "rec.csv"
    p.write_text(table())
    (r,) = read_csv(p)
    np.testing.assert_allclose(r.t, T, atol=1e-9)
    np.testing.assert_allclose(r.u, U, atol=1e-6)
    np.testing.assert_allclose(r.y, Y, atol=1e-6)
    assert dict(r.units) == {"time": "s", "input": "V", "output": "µm"}
    assert dict(r.columns) == {"time": "t_s", "input": "u_V", "output": "y_um"}
    assert r.fs == pytest.approx(100.0) and r.dt == pytest.approx(0.01)
    assert r.n_samples == N and r.duration == pytest.approx(0.39)
    assert r.is_uniform and r.has_time and r.run is None and r.cleaning == ()
    assert r.name == "rec" and r.source == str(p)
    assert r.lines is not None and r.lines[0] == 2 and r.lines[-1] == N + 1


def test_path_text_bytes_and_file_objects_give_the_same_recording(tmp_path):
    text = table()
    p = tmp_path / "a.csv"
    p.write_text(text)
    recs = [read_recording(p), read_recording(str(p)), read_recording(text),
            read_recording(text.encode()), read_recording(io.StringIO(text)),
            read_recording(io.BytesIO(text.encode()))]
    for r in recs[1:]:
        np.testing.assert_array_equal(r.y, recs[0].y)
    assert recs[2].source == "<text>" and recs[3].source == "<bytes>"


def test_headerless_three_columns_are_time_input_output():
    (r,) = read_csv(table(header=None))
    assert r.has_time and r.fs == pytest.approx(100.0)
    assert dict(r.columns) == {"time": "column 0", "input": "column 1", "output": "column 2"}
    np.testing.assert_allclose(r.u, U, atol=1e-6)


def test_headerless_two_columns_are_input_output_without_time():
    rows = [[u, y] for u, y in zip(U, Y, strict=True)]
    (r,) = read_csv(table(header=None, rows=rows))
    assert not r.has_time and r.units["time"] == "sample"
    np.testing.assert_array_equal(r.t, np.arange(N))
    assert any("sample index" in c for c in r.cleaning)
    (r2,) = read_csv(table(header=None, rows=rows), fs=250.0)
    assert r2.has_time and r2.fs == pytest.approx(250.0)
    assert any("fs = 250 Hz" in c for c in r2.cleaning)
    with pytest.raises(CSVError, match=r"fs=250\.0 was given but column 't_s' \(column 0\) is the "
                                       r"time axis; pass time=False"):
        read_csv(table(), fs=250.0)
    (r3,) = read_csv(table(), fs=250.0, time=False)
    assert r3.fs == pytest.approx(250.0) and list(r3.extra) == ["t"]
    with pytest.raises(ParameterError, match="no time axis"):
        r.resampled()


@pytest.mark.parametrize("sep", [",", ";", "\t", "|", " ", "   "])
def test_each_delimiter_is_detected(sep):
    text = table(sep=sep)
    lay = inspect_csv(text)
    want = "whitespace" if sep.startswith(" ") else sep
    assert lay.delimiter == want and lay.header and lay.n_rows == N
    (r,) = read_csv(text)
    np.testing.assert_allclose(r.y, Y, atol=1e-6)
    (r2,) = read_csv(text, delimiter=want)
    np.testing.assert_array_equal(r2.y, r.y)


@pytest.mark.parametrize("sep", [";", "\t", " "])
def test_decimal_comma_is_detected(sep):
    text = table(sep=sep, dec=",")
    assert inspect_csv(text).decimal == ","
    (r,) = read_csv(text)
    np.testing.assert_allclose(r.u, U, atol=1e-6)
    np.testing.assert_allclose(r.t, T, atol=1e-9)


def test_decimal_comma_small_example_and_forced():
    text = "u;y\n" + "".join(f"{k},5;{k + 1},7\n" for k in range(-6, 6))
    (r,) = read_csv(text)
    assert r.u[0] == -6.5 and r.y[0] == -5.7 and r.u[-1] == 5.5
    (r2,) = read_csv(text, decimal=",", delimiter=";")
    np.testing.assert_array_equal(r2.u, r.u)
    with pytest.raises(CSVError, match="decimal=',' needs a delimiter other than ','"):
        read_csv("u,y\n1,2\n", decimal=",", delimiter=",")


@pytest.mark.parametrize(
    ("raw", "name", "unit"),
    [
        ("t_s", "t", "s"), ("u_V", "u", "V"), ("y_um", "y", "µm"), ("t [s]", "t", "s"),
        ("Force (kN)", "Force", "kN"), ("u/V", "u", "V"), ("u_disp_in", "u_disp", "in"),
        ("velocity_in_per_s", "velocity", "in/s"), ("u_H_Am", "u_H", "A/m"),
        ("y_B_T", "y_B", "T"), ("u_disp", "u_disp", ""), ("Time", "Time", ""),
        ("  y [ mm ] ", "y", "mm"), ("Time_sec", "Time", "s"), ("Zeit/s", "Zeit", "s"),
        ("act_force1_lb", "act_force1", "lb"), ("loop", "loop", ""),
    ],
)
def test_unit_suffixes_are_parsed(raw, name, unit):
    assert parse_column_name(raw) == (name, unit)


def test_columns_picked_by_name_case_and_unit_insensitive_or_by_index():
    header = "Time (s),Force (kN),Disp [mm],Temp_degC"
    rows = [[t, y, u, 20.0 + k] for k, (t, u, y) in enumerate(zip(T, U, Y, strict=True))]
    text = table(header=header, rows=rows)
    (r,) = read_csv(text, input="disp", output="FORCE")
    np.testing.assert_allclose(r.u, U, atol=1e-6)
    np.testing.assert_allclose(r.y, Y, atol=1e-6)
    assert dict(r.units) == {"time": "s", "input": "mm", "output": "kN"}
    assert r.extra_units["Temp"] == "degC"
    np.testing.assert_allclose(r.extra["Temp"], 20.0 + np.arange(N))
    (r2,) = read_csv(text, time=0, input=2, output="force [kN]")
    np.testing.assert_array_equal(r2.y, r.y)
    (r3,) = read_csv(text, input="Disp [mm]", output=1)
    np.testing.assert_array_equal(r3.u, r.u)


def test_time_in_milliseconds_is_converted_to_seconds():
    rows = [[1000 * t, u, y] for t, u, y in zip(T, U, Y, strict=True)]
    (r,) = read_csv(table(header="t [ms],u,y", rows=rows, fmt="{:.4f}"))
    assert r.fs == pytest.approx(100.0) and r.units["time"] == "s"
    assert any("time converted from ms to s" in c for c in r.cleaning)
    (r2,) = read_csv(table(header="t,u,y", rows=rows, fmt="{:.4f}"), time_unit="ms")
    np.testing.assert_allclose(r2.t, r.t)
    with pytest.raises(CSVError, match="time_unit='ms' was given but there is no time column"):
        read_csv(table(), time=False, time_unit="ms")


def test_named_input_and_output_columns_win_over_file_order():
    rows = [[t, y, 7.0, u] for t, u, y in zip(T, U, Y, strict=True)]
    (r,) = read_csv(table(header="time,y_pos,temperature,u_volt", rows=rows))
    np.testing.assert_allclose(r.u, U, atol=1e-6)
    np.testing.assert_allclose(r.y, Y, atol=1e-6)
    assert list(r.extra) == ["temperature"]


def test_scope_export_with_unit_row_and_blank_line():
    """PicoScope style: names, then units in brackets, then a blank line, then data."""
    body = table(header=None, rows=[[1000 * t, u, y] for t, u, y in zip(T, U, Y, strict=True)])
    text = "Time,Channel A,Channel B\n(ms),(V),(mV)\n\n" + body
    (r,) = read_csv(text)
    assert r.fs == pytest.approx(100.0)
    assert dict(r.units) == {"time": "s", "input": "V", "output": "mV"}
    assert any("read units from line 2" in c for c in r.cleaning)


def test_comment_lines_and_trailing_delimiter_are_skipped_and_noted():
    body = "".join(f"{t:.2f},{u:.6f},{y:.6f},\n" for t, u, y in zip(T, U, Y, strict=True))
    text = "# DAQ export\n# fs=100\nt_s,u_V,y_um,\n" + body
    (r,) = read_csv(text)
    np.testing.assert_allclose(r.y, Y, atol=1e-6)
    assert r.lines[0] == 4
    assert any("2 comment line(s)" in c for c in r.cleaning)
    assert any("empty last column" in c for c in r.cleaning)


def test_preamble_skipped_with_skiprows():
    text = "Instrument: XY-1\nRecord length: 40 points, 3 channels\n" + table()
    (r,) = read_csv(text)
    assert r.n_samples == N and r.lines[0] == 4
    assert any("skipped 2 preamble line(s) before line 3" in c for c in r.cleaning)
    (r,) = read_csv(text, skiprows=2)
    assert r.n_samples == N and any("skiprows=2" in c for c in r.cleaning)
    with pytest.raises(CSVError, match=r"line 3 has 3 field\(s\) but the header \(line 2\) "
                                       r"has 2.*skiprows="):
        read_csv(text, skiprows=1)


def test_encodings_utf8_bom_utf16_and_latin1():
    text = table(header="t [s],u [V],y [µm]")
    for data in (b"\xef\xbb\xbf" + text.encode(), text.encode("utf-16")):
        (r,) = read_csv(data)
        assert r.units["output"] == "µm"
        np.testing.assert_allclose(r.y, Y, atol=1e-6)
    (r,) = read_csv(text.encode("latin-1"))
    assert r.units["output"] == "µm"
    assert any(re.search(r"Latin-1: not valid UTF-8 at byte \d+ \(line 1\)", c)
               for c in r.cleaning)


def test_run_column_splits_into_recordings_in_order():
    rows = []
    for run in (3, 1):
        rows += [[run, t, u + run, y] for t, u, y in zip(T, U, Y, strict=True)]
    text = table(header="run,t_s,u_V,y_um", rows=rows, fmt="{:.12g}")
    recs = read_csv(text)
    assert [r.run for r in recs] == [3, 1]
    assert [r.name for r in recs] == ["recording run=3", "recording run=1"]
    np.testing.assert_allclose(recs[1].u, U + 1, atol=1e-5)
    assert recs[1].lines[0] == N + 2 and recs[1].columns["run"] == "run"
    with pytest.raises(CSVError, match=r"holds 2 recordings \(run column 'run': 3, 1\)"):
        read_recording(text)
    # the same file without splitting: time goes back at the run change
    with pytest.raises(CSVError, match=rf"line {N + 2} has t = 0 s after t = 0\.39 s"):
        read_csv(text, run=False)


def test_text_run_ids_and_explicit_run_column():
    rows = [[t, u, y] for t, u, y in zip(T, U, Y, strict=True)]
    body = "".join(f"{lab};{t:.2f};{u:.5f};{y:.5f}\n" for lab in ("up", "down")
                   for t, u, y in rows)
    recs = read_csv("case;t;u;y\n" + body, run="case")
    assert [r.run for r in recs] == ["up", "down"]
    assert all(r.n_samples == N for r in recs)


def test_bh_layout_without_time_uses_loop_as_run_and_k_as_sample_index():
    rows = []
    for loop, amp in enumerate((5.0, 10.0)):
        h = amp * np.cos(np.linspace(0, 2 * np.pi, 20))
        rows += [[loop, k, amp, hk, np.tanh(hk / 5)] for k, hk in enumerate(h)]
    recs = read_csv(table(header="loop,k,Hpk_Am,u_H_Am,y_B_T", rows=rows, fmt="{:g}"))
    assert [r.run for r in recs] == [0, 1]
    for r in recs:
        assert not r.has_time and r.n_samples == 20
        assert dict(r.units) == {"time": "sample", "input": "A/m", "output": "T"}
        np.testing.assert_array_equal(r.extra["k"], np.arange(20))
        assert any("'k' (column 1) is a sample index" in c for c in r.cleaning)


def test_text_extra_channel_is_kept_as_text():
    body = "".join(f"{t:.2f},{u:.5f},{y:.5f},{'ok' if k % 2 else 'sat'}\n"
                   for k, (t, u, y) in enumerate(zip(T, U, Y, strict=True)))
    (r,) = read_csv("t,u,y,flag\n" + body)
    assert r.extra["flag"][:3].tolist() == ["sat", "ok", "sat"]
    assert any("'flag' (column 3) is not numeric; kept as text" in c for c in r.cleaning)


def test_read_csvs_concatenates_files(tmp_path):
    paths = []
    for k in range(3):
        p = tmp_path / f"r{k}.csv"
        p.write_text(table())
        paths.append(p)
    recs = read_csvs(paths)
    assert [r.name for r in recs] == ["r0", "r1", "r2"]
    with pytest.raises(CSVError, match="no files"):
        read_csvs([])


# ------------------------------------------------------------------------------ NaN cleaning
def test_nan_rows_are_removed_and_reported_with_line_numbers():
    text = table()
    # data row k sits on line k + 2
    text = with_line(text, 10, "0.080000,nan,1.0")
    text = with_line(text, 11, "0.090000,,1.0")
    text = with_line(text, 30, "0.280000,1.0,inf")
    (r,) = read_csv(text, max_dropped=0.1)
    assert r.n_samples == N - 3
    assert "removed 3 row(s) with empty/NaN/inf input or output at line(s) 10, 11, 30" in (
        r.cleaning)
    assert 10 not in r.lines and 30 not in r.lines
    assert not r.is_uniform
    assert any("gaps in the time axis" in c for c in r.cleaning)
    (rr,) = read_csv(text, resample=True, max_dropped=0.1)
    assert rr.is_uniform and rr.n_samples == N
    np.testing.assert_allclose(rr.t, T, atol=1e-12)
    np.testing.assert_allclose(rr.u[10], U[10], atol=1e-6)  # untouched samples stay
    assert any("resampled by linear interpolation" in c for c in rr.cleaning)
    with pytest.raises(CSVError, match=r"line 10, column 'u_V' \(column 1\): 'nan' is not a "
                                       r"finite number.*nan='drop'"):
        read_csv(text, nan="error")


def test_too_many_nan_rows_is_an_error():
    text = table()
    for line in range(2, 12):
        text = with_line(text, line, f"{(line - 2) / 100:.6f},NaN,1")
    with pytest.raises(CSVError, match=r"10 of 40 rows \(25\.0 %\).*first at line 2.*"
                                       r"max_dropped"):
        read_csv(text)
    (r,) = read_csv(text, max_dropped=0.5)
    assert r.n_samples == 30


def test_nan_in_extra_channel_is_kept_and_noted():
    body = "".join(f"{t:.2f},{u:.5f},{y:.5f},{'' if k == 5 else k}\n"
                   for k, (t, u, y) in enumerate(zip(T, U, Y, strict=True)))
    (r,) = read_csv("t,u,y,temp\n" + body)
    assert r.n_samples == N and np.isnan(r.extra["temp"][5])
    assert any("'temp' has 1 empty/NaN/inf value(s) (kept)" in c for c in r.cleaning)


# ------------------------------------------------------------------------------ time axis
def test_uneven_time_is_an_error_that_suggests_resampling():
    t = T.copy()
    t[20:] += 0.005  # one 15 ms gap at line 22
    rows = list(zip(t, U, Y, strict=True))
    text = table(rows=rows)
    with pytest.raises(CSVError, match=r"uneven: spacing from 0\.01 s \(line \d+\) to 0\.015 s "
                                       r"\(line 22\).*resample=True") as ei:
        read_csv(text)
    assert ei.value.line == 22 and ei.value.column == "t_s"
    (r,) = read_csv(text, resample=True)
    assert r.is_uniform and r.dt == pytest.approx(0.01)
    np.testing.assert_allclose(r.u, np.interp(r.t, t, U), atol=1e-6)
    (k,) = read_csv(text, uneven="keep")
    np.testing.assert_allclose(k.t, t, atol=1e-9)
    assert any("kept as measured" in c for c in k.cleaning)
    (f,) = read_csv(text, resample=0.02)
    assert f.dt == pytest.approx(0.02) and f.n_samples == 20


def test_rounded_time_stamps_are_not_uneven():
    """1024 Hz printed with 6 decimals: spacings 0.000976/0.000977 are rounding, not jitter."""
    t = np.arange(N) / 1024
    (r,) = read_csv(table(rows=list(zip(t, U, Y, strict=True))))
    assert r.fs == pytest.approx(1024, rel=1e-4) and r.is_uniform


def test_duplicated_and_decreasing_time_stamps_name_the_line():
    text = with_line(table(), 12, f"{T[9]:.6f},1.0,2.0")  # t of line 11 again
    with pytest.raises(TimeOrderError, match=r"line 12 repeats t = 0\.09 s of line 11 \(duplicated "
                                       r"time stamp in column 't_s'"):
        read_csv(text)
    text = with_line(table(), 12, "0.05,1.0,2.0")
    with pytest.raises(TimeOrderError, match=r"line 12 has t = 0\.05 s after t = 0\.09 s at line 11"
                                       r".*decreasing"):
        read_csv(text)


def test_missing_time_stamps_name_the_lines():
    text = with_line(with_line(table(), 7, ",1.0,2.0"), 8, "NaN,1.0,2.0")
    with pytest.raises(CSVError, match=r"time stamp missing .* 't_s' \(column 0\) at line\(s\) "
                                       r"7, 8.*time=False"):
        read_csv(text)


def test_first_column_that_is_not_increasing_cannot_be_the_time():
    rows = [[y, u, t] for t, u, y in zip(T, U, Y, strict=True)]
    with pytest.raises(CSVError, match=r"column column 0 is not monotone increasing \(decreasing "
                                       r"at line \d+.*time=False"):
        read_csv(table(header=None, rows=rows))
    (r,) = read_csv(table(header=None, rows=rows), time=2, input=1, output=0)
    np.testing.assert_allclose(r.y, Y, atol=1e-6)


def test_unknown_time_unit_is_an_error():
    with pytest.raises(CSVError, match=r"unit 'V', which is not a time unit.*time_unit="):
        read_csv(table(header="t_V,u_V,y_um"), time=0)


# ------------------------------------------------------------------------------ error paths
def test_empty_inputs():
    with pytest.raises(CSVError, match=r"is empty \(0 bytes\)"):
        read_csv(b"")
    with pytest.raises(CSVError, match="empty: it holds only comment and blank lines"):
        read_csv("# nothing\n\n  \n")


def test_header_only():
    with pytest.raises(CSVError, match=r"only a header \(line 1: t_s, u_V, y_um\) and no data"):
        read_csv("t_s,u_V,y_um\n\n")


def test_binary_junk():
    with pytest.raises(CSVError, match=r"NUL byte at byte offset 14 \(line 2\).*binary"):
        read_csv(b"t_s,u_V,y_um\n1\x00\x01\x02,3\n")
    with pytest.raises(CSVError, match=r"control character '\\x03' on line 3"):
        read_csv(b"t,u,y\n1,2,3\n\x03\x04junk\n")


def test_non_numeric_cell_names_line_column_and_value():
    text = with_line(table(), 17, "0.150000,12.5V,1.0")
    with pytest.raises(CSVError, match=r"line 17, input column 'u_V' \(column 1\): '12\.5V' "
                                       r"is not a number") as ei:
        read_csv(text)
    assert (ei.value.line, ei.value.column, ei.value.column_index) == (17, "u_V", 1)
    text = with_line(table(), 5, "0.030000,1.0,2,5")
    with pytest.raises(CSVError, match="line 5 has 4 field"):
        read_csv(text)
    text = "t;u;y\n" + "".join(f"{t:.2f};{u:.3f};{y:.3f}\n" for t, u, y in zip(T, U, Y,
                                                                                strict=True))
    text = with_line(text, 3, "0.01;1,5;2.0")
    with pytest.raises(CSVError, match=r"line 3.*'1,5' is not a number; it looks like a "
                                       r"decimal comma: pass decimal=','"):
        read_csv(text)


def test_ragged_rows_name_the_line():
    text = with_line(table(), 9, "0.070000,1.0")
    with pytest.raises(CSVError, match=r"line 9 has 2 field\(s\) but the header \(line 1\) has 3"):
        read_csv(text)
    text = table().rstrip("\n") + "\n0.4,1.0"
    with pytest.raises(CSVError, match=rf"line {N + 2} has 2 field.*cut off"):
        read_csv(text)


def test_unknown_column_lists_available_columns():
    with pytest.raises(CSVError, match=r"no column named 'force' for output; available columns:"
                                       r" 0: 't_s', 1: 'u_V', 2: 'y_um'") as ei:
        read_csv(table(), output="force")
    assert ei.value.column == "force"
    with pytest.raises(CSVError, match=r"input=5 is not a column index; the file has 3 columns"):
        read_csv(table(), input=5)


def test_same_column_picked_twice():
    with pytest.raises(CSVError, match=r"input and output both refer to column 'u_V' "
                                       r"\(column 1\)"):
        read_csv(table(), input="u", output=1)


def test_duplicate_names_need_an_index():
    rows = [[t, u, y, y] for t, u, y in zip(T, U, Y, strict=True)]
    text = table(header="t,u,y,y", rows=rows)
    with pytest.raises(CSVError, match=r"matches several columns.*0-based index"):
        read_csv(text, output="y")
    (r,) = read_csv(text, output=3)
    assert list(r.extra) == ["y"]


def test_too_few_samples():
    with pytest.raises(CSVError, match=r"only 5 usable sample\(s\) \(lines 2\.\.6\), fewer than "
                                       r"the minimum of 10"):
        read_csv(table(rows=list(zip(T, U, Y, strict=True))[:5]))
    (r,) = read_csv(table(rows=list(zip(T, U, Y, strict=True))[:5]), min_samples=5)
    assert r.n_samples == 5


def test_constant_input_has_no_excitation():
    rows = [[t, 2.0, y] for t, y in zip(T, Y, strict=True)]
    with pytest.raises(CSVError, match=r"input column 'u_V' \(column 1\) is constant \(2 V\) "
                                       r"on all 40 samples: no excitation"):
        read_csv(table(rows=rows))


def test_single_column_file():
    with pytest.raises(CSVError, match=r"line 1 \('1\.0'\) has a single column"):
        read_csv("1.0\n2.0\n3.0\n")


def test_size_limits(tmp_path):
    p = tmp_path / "big.csv"
    p.write_text(table())
    size = p.stat().st_size
    with pytest.raises(CSVError, match=rf"is {size:,} bytes, more than max_bytes=1,000"):
        read_csv(p, max_bytes=1000)
    with pytest.raises(CSVError, match=r"more than max_rows=20 rows \(stopped at line 23\)"):
        read_csv(p, max_rows=20)
    with pytest.raises(CSVError, match="more than max_bytes=100"):
        read_csv(io.BytesIO(table().encode()), max_bytes=100)
    assert read_csv(p, max_rows=N)[0].n_samples == N


def test_missing_file_and_bad_options(tmp_path):
    with pytest.raises(CSVError, match=r"no such file; to parse CSV text pass a string"):
        read_csv(str(tmp_path / "nope.csv"))
    with pytest.raises(CSVError, match="delimiter=':' is not supported"):
        read_csv(table(), delimiter=":")
    with pytest.raises(CSVError, match="nan='zero' must be 'drop' or 'error'"):
        read_csv(table(), nan="zero")
    with pytest.raises(CSVError, match="cannot read a CSV from a int"):
        read_csv(3)


def test_header_forced_off_reports_the_header_cell():
    with pytest.raises(CSVError, match=r"line 1, time column column 0: 't_s' is not a number; if "
                                       r"that line holds column names, pass header=True"):
        read_csv(table(), header=False)


def test_errors_are_value_errors():
    assert issubclass(CSVError, ParameterError) and issubclass(CSVError, ValueError)


# ------------------------------------------------------------------------------ Recording
@pytest.fixture
def rec() -> Recording:
    t = np.arange(101) * 0.1  # 0..10 s
    return Recording(t, np.sin(t), np.cos(t), name="r", units={"input": "V", "output": "µm"},
                     extra={"temp": t * 2})


def test_window_is_half_open_or_closed(rec):
    train = rec.window(3.3, 7.0)
    test = rec.window(7.0, 9.0, closed="both")
    assert train.t[0] == pytest.approx(3.3) and train.t[-1] == pytest.approx(6.9)
    assert test.t[0] == pytest.approx(7.0) and test.t[-1] == pytest.approx(9.0)
    assert train.n_samples == 37 and test.n_samples == 21
    np.testing.assert_array_equal(train.extra["temp"], 2 * train.t)
    assert train.cleaning[-1] == "window t ∈ [3.3, 7) s: kept 37 of 101 samples"
    assert test.cleaning[-1].startswith("window t ∈ [7, 9] s")
    np.testing.assert_array_equal(rec.mask(3.3, 7.0), (rec.t >= 3.3) & (rec.t < 7.0))
    before, after = rec.split_at(5.0)
    assert before.n_samples + after.n_samples == rec.n_samples and after.t[0] == 5.0
    with pytest.raises(ParameterError, match=r"holds no sample; the recording spans \[0, 10\]"):
        rec.window(20, 30)
    with pytest.raises(ParameterError, match="empty window"):
        rec.window(5, 5)


def test_split_blocks_partition_the_samples(rec):
    blocks = rec.split_blocks(4)
    assert [b.n_samples for b in blocks] == [25, 25, 26, 25]
    np.testing.assert_array_equal(np.concatenate([b.u for b in blocks]), rec.u)
    assert blocks[2].cleaning[-1].startswith("block 3 of 4: samples 50..75")
    with pytest.raises(ParameterError, match=r"k = 51 blocks is not possible for 101 samples"):
        rec.split_blocks(51)


def test_resampled_interpolates_linearly_and_reports(rec):
    t = np.sort(np.concatenate([np.linspace(0, 1, 11), [0.05, 0.55]]))
    r = Recording(t, 3 * t + 1, t**2, name="uneven")
    assert not r.is_uniform
    g = r.resampled(0.1)
    np.testing.assert_allclose(g.t, np.linspace(0, 1, 11), atol=1e-12)
    np.testing.assert_allclose(g.u, 3 * g.t + 1)  # linear signals are reproduced exactly
    assert g.is_uniform and g.lines is None
    assert "onto 11 samples at dt = 0.1 s" in g.cleaning[-1]
    assert rec.resampled(0.05).extra["temp"][1] == pytest.approx(0.1)


def test_to_csv_round_trips_exactly(rec, tmp_path):
    w = rec.window(1.0, 8.0)
    p = w.to_csv(tmp_path / "out.csv")
    (back,) = read_csv(p)
    np.testing.assert_array_equal(back.t, w.t)
    np.testing.assert_array_equal(back.u, w.u)
    np.testing.assert_array_equal(back.y, w.y)
    np.testing.assert_array_equal(back.extra["temp"], w.extra["temp"])
    assert dict(back.units) == dict(w.units)
    assert "# cleaning: window t ∈ [1, 8) s" in p.read_text(encoding="utf-8")


def test_recording_pickles_and_deep_copies(rec):
    import copy
    import pickle

    w = rec.window(1.0, 2.0)
    for back in (pickle.loads(pickle.dumps(w)), copy.deepcopy(w)):
        np.testing.assert_array_equal(back.u, w.u)
        np.testing.assert_array_equal(back.extra["temp"], w.extra["temp"])
        assert dict(back.units) == dict(w.units) and back.cleaning == w.cleaning


def test_recording_validates_its_arrays():
    with pytest.raises(ParameterError, match="Recording.y has 2 samples but t has 3"):
        Recording([0, 1, 2], [0, 1, 2], [0, 1])
    with pytest.raises(ParameterError, match=r"Recording.u\[1\] = nan is not finite"):
        Recording([0, 1, 2], [0, np.nan, 2], [0, 1, 2])
    with pytest.raises(ParameterError, match=r"t must strictly increase, but t\[2\] = 1"):
        Recording([0, 1, 1], [0, 1, 2], [0, 1, 2])
    r = Recording([0, 1, 2], [0, 1, 2], [0, 1, 2])
    with pytest.raises(ValueError, match="read-only"):
        r.u[0] = 5.0


# ------------------------------------------------------------------------------ more layouts
def test_excel_sep_line_and_delimiter_only_rows():
    text = "sep=;\n" + table(sep=";", dec=",") + ";;\n;;\n"
    (r,) = read_csv(text)
    np.testing.assert_allclose(r.u, U, atol=1e-6)
    assert any("'sep=;' sets the delimiter" in c for c in r.cleaning)
    assert any(f"2 line(s) holding only delimiters (line(s) {N + 3}, {N + 4})" in c
               for c in r.cleaning)


def test_iso_datetime_time_column_becomes_seconds():
    body = "".join(f"2024-03-01 12:00:{10 + t:09.6f},{u:.6f},{y:.6f}\n"
                   for t, u, y in zip(T, U, Y, strict=True))
    (r,) = read_csv("timestamp,u,y\n" + body)
    np.testing.assert_allclose(r.t, T, atol=1e-9)
    assert any("holds date-times; converted to seconds since 2024-03-01 12:00:10" in c
               for c in r.cleaning)
    bad = with_line("timestamp,u,y\n" + body, 4, "yesterday,1,2")
    with pytest.raises(CSVError, match=r"line 2, time column 'timestamp'.*'2024-03-01 12:00:10"):
        read_csv(bad)


def test_whitespace_header_with_spaces_inside_names():
    text = "t [s]    u [V]    y [um]\n" + table(header=None, sep="    ")
    (r,) = read_csv(text)
    assert dict(r.units) == {"time": "s", "input": "V", "output": "µm"}


def test_a_column_called_n_with_a_unit_is_data_not_a_sample_index():
    rows = [[t, u, y, 1500 + 10 * k] for k, (t, u, y) in enumerate(zip(T, U, Y, strict=True))]
    (r,) = read_csv(table(header="t_s,u_V,y_um,n_rpm", rows=rows))
    assert r.has_time and r.extra_units["n"] == "rpm"
    rows = [[k, u, y] for k, (u, y) in enumerate(zip(U, Y, strict=True))]
    (r,) = read_csv(table(header="index,u,y", rows=rows, fmt="{:.8g}"))
    assert not r.has_time and list(r.extra) == ["index"]


def test_mixed_decimal_marks_are_reported():
    text = table(sep=";", dec=",")
    text = with_line(text, 6, "0,04;1.5;2,0")
    with pytest.raises(CSVError, match=r"line 6, input column 'u_V'.*'1\.5' is not a number; "
                                       r"the file uses decimal commas"):
        read_csv(text)


def test_recording_without_time_round_trips_through_csv(tmp_path):
    rows = [[0, k, 5.0, 5 * np.cos(k / 3), np.tanh(np.cos(k / 3))] for k in range(20)]
    (r,) = read_csv(table(header="loop,k,Hpk_Am,u_H_Am,y_B_T", rows=rows, fmt="{:.17g}"))
    p = r.to_csv(tmp_path / "bh.csv")
    header = [ln for ln in p.read_text(encoding="utf-8").splitlines() if ln[0] != "#"][0]
    assert header == "sample,u [A/m],y [T],k,Hpk [A/m]"
    (back,) = read_csv(p)
    assert not back.has_time
    np.testing.assert_array_equal(back.u, r.u)
    np.testing.assert_array_equal(back.extra["Hpk"], r.extra["Hpk"])


def test_trailing_delimiter_on_data_lines_only_keeps_the_header():
    body = "".join(f"{t:.2f},{u:.6f},{y:.6f},\n" for t, u, y in zip(T, U, Y, strict=True))
    (r,) = read_csv("t_s,u_V,y_um\n" + body)
    assert dict(r.columns) == {"time": "t_s", "input": "u_V", "output": "y_um"}
    assert any("empty last column" in c for c in r.cleaning)


def test_named_input_first_is_not_taken_as_time():
    rows = [[u, y, 20.0] for u, y in zip(U, Y, strict=True)]
    (r,) = read_csv(table(header="u,y,temp", rows=rows))
    assert not r.has_time and r.columns["input"] == "u" and list(r.extra) == ["temp"]


# ------------------------------------------------------------------------------ property test

HEADERS = {
    "suffix": ("t_{}", "u_V", "y_um"),
    "bracket": ("t [{}]", "u [V]", "y [um]"),
    "paren": ("Time ({})", "Input (V)", "Output (um)"),
    "slash": ("t/{}", "u/V", "y/um"),
}


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(10, 60),
    seed=st.integers(0, 2**31),
    sep=st.sampled_from([",", ";", "\t", "|", " "]),
    comma=st.booleans(),
    style=st.sampled_from([None, *HEADERS]),
    tunit=st.sampled_from(["s", "ms"]),
    eol=st.sampled_from(["\n", "\r\n"]),
    comments=st.integers(0, 2),
    encoding=st.sampled_from(["utf-8", "utf-8-sig", "utf-16", "latin-1"]),
)
def test_any_supported_layout_reads_back_the_values(
    n, seed, sep, comma, style, tunit, eol, comments, encoding
):
    """Write the same samples in a random supported layout; the reader recovers them."""
    rng = np.random.default_rng(seed)
    dt = 0.001 * (1 + seed % 7)
    t = np.arange(n) * dt
    u = np.round(rng.normal(size=n) * 10, 4)
    y = np.round(rng.normal(size=n), 4)
    dec = "," if comma and sep != "," else "."
    scale = 1000.0 if tunit == "ms" else 1.0
    lines = [f"# comment {k}" for k in range(comments)]
    if style is not None:
        if sep == " " and style in ("bracket", "paren"):
            style = "suffix"  # names with spaces need a non-space delimiter
        lines.append(sep.join(h.format(tunit) for h in HEADERS[style]))
    for a, b, c in zip(t * scale, u, y, strict=True):
        lines.append(sep.join(f"{v:.6f}".replace(".", dec) for v in (a, b, c)))
    data = eol.join(lines).encode(encoding) if encoding != "utf-8-sig" else (
        b"\xef\xbb\xbf" + eol.join(lines).encode())
    (r,) = read_csv(data, time_unit=None if style else tunit)
    np.testing.assert_allclose(r.t, t, atol=1e-9)
    np.testing.assert_array_equal(r.u, u)
    np.testing.assert_array_equal(r.y, y)
    assert r.has_time and r.fs == pytest.approx(1 / dt)
    if style is not None:
        assert (r.units["input"], r.units["output"]) == ("V", "µm")


def test_quoted_cells_read_like_plain_ones():
    body = "".join(f'"{t:.2f}","{u:.6f}","{y:.6f}"\n' for t, u, y in zip(T, U, Y, strict=True))
    (r,) = read_csv('"t [s]","Force, measured (kN)","y"\n' + body, input=1, output=2)
    assert r.units["input"] == "kN" and r.columns["input"] == "Force, measured (kN)"
    np.testing.assert_allclose(r.u, U, atol=1e-6)


def test_compensating_ragged_lines_are_still_found():
    """One line short and one long keep the total cell count: the per-line check finds it."""
    text = with_line(with_line(table(), 7, "0.05,1.0"), 9, "0.07,1.0,2.0,3.0")
    with pytest.raises(CSVError, match=r"line 7 has 2 field\(s\) but the header"):
        read_csv(text)


# ----------------------------------------------------------------- content, never a path
def test_text_readers_never_open_a_file(tmp_path):
    """A body that is the name of a readable numeric file is read as content, not opened."""
    secret = tmp_path / "secret.csv"
    secret.write_text(table())
    from core.csvio import inspect_csv_text, read_csv_text

    for body in (str(secret), str(secret).encode(), str(tmp_path / "missing.csv")):
        with pytest.raises(CSVError) as err:
            read_csv_text(body)
        assert "no such file" not in str(err.value)
        assert "single column" in str(err.value)
        with pytest.raises(CSVError):
            inspect_csv_text(body)
    (r,) = read_csv(secret)  # a Path is still a file
    assert r.n_samples == len(T)


def test_text_reader_decodes_bytes_like_a_file():
    from core.csvio import read_csv_text

    data = table().encode("utf-16")  # with BOM, as Windows tools write it
    (r,) = read_csv_text(data)
    (ref,) = read_csv(table())
    np.testing.assert_array_equal(r.u, ref.u)
    np.testing.assert_allclose(r.u, U, atol=1e-6)


@pytest.mark.parametrize(
    ("body", "match"),
    [
        ("a,b\n\"" + "x" * 200_000 + "\",1\n1,2\n", r"line 2 is 200,004 characters long"),
        ("1,2," * 1_200_000, r"line 1 is 4,800,000 characters"),
        ('t,u,y\n"0,1,2\n0.1,2,3\n', r"line 2 has an unclosed quote"),
    ],
)
def test_hostile_layouts_are_csv_errors(body, match):
    from core.csvio import inspect_csv_text

    with pytest.raises(CSVError, match=match):
        inspect_csv_text(body)
