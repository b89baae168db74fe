"""An upload that keeps every run of a file, each its own loop (``run="each"``): the fit
reads the same recordings ``hyst fit FILE`` reads (the core's reader of the file), on sample
numbers where the file has no time column, and gives the same held-out error."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from app.services.analysis.fitting import fit_recording, fitted_output
from app.services.analysis.loops import file_recordings, split_runs
from app.services.analysis.recordings import read_upload
from core.csvio import read_csv

BH = Path(__file__).resolve().parents[4] / "examples" / "data" / "bh_loops" / "MnZn_HP_ferrite.csv"


def test_each_run_is_the_file_s_run_as_the_command_line_reads_it() -> None:
    up = read_upload(BH.read_bytes(), run="each", name=BH.name)
    assert up.runs == ("0", "1", "2", "3")
    assert up.recording.n_samples == 516
    assert any("each its own loop" in n for n in up.recording.cleaning)
    want = read_csv(BH)  # what hyst fit reads: one recording per loop, no time axis
    got = file_recordings(up.recording)
    assert [r.name for r in got] == [r.name for r in want]
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g.u, w.u)
        np.testing.assert_array_equal(g.y, w.y)
        np.testing.assert_array_equal(g.t, np.arange(w.n_samples))
        assert not g.has_time and not w.has_time


def test_one_run_or_all_rows_stay_one_recording() -> None:
    first = read_upload(BH.read_bytes(), run="0", name=BH.name).recording
    assert len(split_runs(first)) == 1 and first.n_samples == 129
    default = read_upload(BH.read_bytes(), name=BH.name)  # every loop, as hyst fit reads it
    assert default.kept == "each" and len(split_runs(default.recording)) == 4
    every = read_upload(BH.read_bytes(), run="all", name=BH.name)
    assert len(split_runs(every.recording)) == 1 and every.recording.n_samples == 516
    assert every.runs == ("0", "1", "2", "3")  # the page keeps offering the runs


def test_the_fit_of_every_loop_is_hyst_fit_s() -> None:
    from core.fitting import fit_recordings

    rec = read_upload(BH.read_bytes(), run="each", name=BH.name).recording
    web = fit_recording(rec, None, "auto")
    cli = fit_recordings(read_csv(BH), "auto")
    assert web.kind == cli.kind
    assert web.report.test.rmse_pct == pytest.approx(cli.report.test.rmse_pct, rel=1e-9)
    # the overlay starts each loop as the fit did: its held-out rows give the same error
    y = fitted_output(web, rec)
    runs = file_recordings(rec)
    ends = np.cumsum([r.n_samples for r in runs])
    held = np.concatenate([np.arange(e - r.n_samples + int(np.ceil(0.8 * r.n_samples)), e)
                           for e, r in zip(ends, runs, strict=True)])
    rmse = float(np.sqrt(np.mean((rec.y[held] - y[held]) ** 2)))
    assert rmse == pytest.approx(cli.report.test.rmse, rel=0.02)


def test_runs_that_each_start_their_own_clock_are_kept_and_given_back() -> None:
    """A file whose runs each restart their time at 0 (two sweeps logged one after the
    other): every run is kept, laid one after the other, and given back at its own times
    and with its own ids, as the command line's reader gives them."""
    from core.csvio import read_csv_text

    rows = ["run,t,u,y"]
    for run, f in (("A", 2.0), ("B", 5.0)):
        for k in range(300):
            t = k * 1e-3
            u = np.sin(2 * np.pi * f * t)
            rows.append(f"{run},{t:.6g},{u:.8g},{0.5 * u + 0.1 * np.sign(u):.8g}")
    text = "\n".join(rows) + "\n"
    up = read_upload(text, name="sweeps.csv")
    assert up.kept == "each" and up.runs == ("A", "B")
    rec = up.recording
    assert rec.n_samples == 600 and np.all(np.diff(rec.t) > 0)
    want = read_csv_text(text, name="sweeps.csv")
    got = split_runs(rec)
    assert [r.run for r in got] == [r.run for r in want] == ["A", "B"]
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g.t, w.t)
        np.testing.assert_array_equal(g.u, w.u)
        np.testing.assert_array_equal(g.y, w.y)


def test_the_explorer_diagnoses_every_loop_as_hyst_diagnose_reads_the_file() -> None:
    """The explorer's diagnosis of a file's loops takes each loop as its own recording on
    its sample numbers, as ``hyst diagnose FILE`` does (before: the loops end to end, as one
    recording with invented times)."""
    from app.services.analysis.diagnosis import run_diagnosis
    from core.diagnosis import as_records

    rec = read_upload(BH.read_bytes(), name=BH.name).recording
    got = run_diagnosis(rec, None).result.records
    want = as_records([BH])
    assert [r.name for r in got] == [r.name for r in want]
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g.u, w.u)
        assert not g.has_time and not w.has_time


def test_a_recording_made_in_code_keeps_its_time() -> None:
    """Only a file without a time column is put on sample numbers; a recording made in
    code (no column map) keeps its time axis for the fit and the diagnosis."""
    from core.recordings import Recording

    t = np.arange(200) * 2e-3
    rec = Recording(t, np.sin(t), np.sin(t), name="made")
    (got,) = file_recordings(rec)
    assert got.has_time and np.array_equal(got.t, t)
    up = read_upload(BH.read_bytes(), run="0", name=BH.name).recording
    (loop,) = file_recordings(up)
    assert not loop.has_time and np.array_equal(loop.t, np.arange(129))
