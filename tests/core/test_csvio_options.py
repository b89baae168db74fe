"""Reading options as one object: :class:`core.csvio.CsvOptions`, and every reader's
``(source, options, **changes)``."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from core.csvio import (
    MIN_SAMPLES,
    CSVError,
    CsvOptions,
    inspect_csv_text,
    read_csv,
    read_csv_text,
    read_csvs,
    read_input,
    read_input_text,
    read_recording,
)
from core.datasets import dataset_info
from core.diagnosis import as_records

# a decimal-comma file whose columns are not named like roles: only the options read it right
TEXT = "zeit [ms];strom [A];weg [mm];force [N]\n" + "".join(
    f"{k};{(-1) ** (k // 4) * k / 10:.1f};{k / 20:.2f};{k % 3}\n".replace(".", ",")
    for k in range(24))
OPTS = CsvOptions(time="zeit", input="weg", output="strom", decimal=",")


def test_options_object_and_keywords_read_the_same() -> None:
    (a,) = read_csv(TEXT, OPTS)
    (b,) = read_csv(TEXT, time="zeit", input="weg", output="strom", decimal=",")
    assert dict(a.columns) == dict(b.columns) == {
        "time": "zeit [ms]", "input": "weg [mm]", "output": "strom [A]"}
    for x, y in ((a.t, b.t), (a.u, b.u), (a.y, b.y)):
        np.testing.assert_array_equal(x, y)
    # the printed values, converted by hand: ms -> s, decimal commas
    np.testing.assert_allclose(a.t[:3], [0.0, 0.001, 0.002])
    np.testing.assert_allclose(a.u[:3], [0.0, 0.05, 0.1])
    assert a.cleaning == b.cleaning and a.units["time"] == "s"


def test_keywords_replace_fields_of_the_options() -> None:
    (r,) = read_csv(TEXT, OPTS, input="force", output="weg", name="swapped")
    assert r.columns["input"] == "force [N]" and r.columns["output"] == "weg [mm]"
    assert r.name == "swapped"
    assert OPTS.input == "weg"  # frozen: the caller's options are untouched
    with pytest.raises(dataclasses.FrozenInstanceError):
        OPTS.time = "t"  # type: ignore[misc]


def test_every_reader_takes_the_options() -> None:
    lay = inspect_csv_text(TEXT, OPTS)
    assert lay.decimal == "," and lay.delimiter == ";"
    (r,) = read_csv_text(TEXT, OPTS, name="upload.csv")
    assert r.name == "upload.csv" and r.columns["input"] == "weg [mm]"
    assert read_recording(TEXT, OPTS).columns == r.columns
    assert [x.name for x in read_csvs([TEXT, TEXT], OPTS, name="two")] == ["two", "two"]
    sig = read_input(TEXT, CsvOptions(time="zeit", input="weg", decimal=","))
    np.testing.assert_array_equal(sig.u, r.u)
    assert read_input_text(TEXT, time="zeit", input="weg", decimal=",").columns == sig.columns


def test_read_csv_text_keeps_a_name_given_in_the_options() -> None:
    (r,) = read_csv_text(TEXT, dataclasses.replace(OPTS, name="from options"))
    assert r.name == "from options"
    (r,) = read_csv_text(TEXT, OPTS)
    assert r.name == "recording"  # content has no file stem


def test_bad_options_are_refused_by_name() -> None:
    with pytest.raises(CSVError, match="nan='skip' must be 'drop' or 'error'"):
        CsvOptions(nan="skip")  # type: ignore[arg-type]
    with pytest.raises(CSVError, match="uneven='fix' must be"):
        read_csv(TEXT, OPTS, uneven="fix")
    with pytest.raises(CSVError, match="max_dropped=2 must be a fraction"):
        read_csv(TEXT, max_dropped=2)
    with pytest.raises(TypeError, match="colums: not a CSV reading option"):
        read_csv(TEXT, colums=3)
    with pytest.raises(TypeError, match="options must be a CsvOptions, not dict"):
        read_csv(TEXT, {"time": "zeit"})  # type: ignore[arg-type]


def test_read_input_refuses_the_options_of_recordings() -> None:
    for extra, said in ((dict(output="strom"), "output='strom'"),
                        (dict(run="force"), "run='force'"), (dict(resample=True), "resample=True"),
                        (dict(citation="lab"), "citation='lab'")):
        with pytest.raises(CSVError, match=said + ".*read_input\\(\\) reads a signal"):
            read_input(TEXT, OPTS, **extra)
    # the same options serve both readers when they hold nothing of recordings only
    sig = read_input(TEXT, dataclasses.replace(OPTS, output=None, run=False))
    assert sig.columns["input"] == "weg [mm]"


def test_min_samples_default_depends_on_the_reader() -> None:
    short = "t,u,y\n" + "".join(f"{k},{k % 3},{k}\n" for k in range(MIN_SAMPLES - 1))
    with pytest.raises(CSVError, match=f"fewer than the minimum of {MIN_SAMPLES}"):
        read_csv(short)
    assert read_input(short, CsvOptions(input="u")).n_samples == MIN_SAMPLES - 1
    (r,) = read_csv(short, min_samples=MIN_SAMPLES - 1)
    assert r.n_samples == MIN_SAMPLES - 1


def test_callers_pass_one_object(tmp_path) -> None:
    assert isinstance(dataset_info("piezo-150V-1Hz").read_options, CsvOptions)
    path = tmp_path / "rec.csv"
    path.write_text(TEXT)
    (a,) = as_records(path, OPTS)
    (b,) = as_records(path, time="zeit", input="weg", output="strom", decimal=",")
    (c,) = read_csv(path, OPTS)
    for r in (a, b):
        np.testing.assert_array_equal(r.u, c.u)
        np.testing.assert_array_equal(r.y, c.y)
