"""``hyst batch`` on Dask: equality with single-file runs, failures, resume, globs, outputs.

One threaded LocalCluster on TCP serves most tests through its scheduler address (the
``--scheduler`` path); one test lets ``hyst batch fit`` start its own process cluster.
"""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import median_abs_deviation

from app.batch import DiagnoseOptions, FitOptions, RecordingResult, run_batch
from app.batch.files import expand, output_names
from app.batch.report import write_report
from app.batch.runner import LOCAL_CLUSTER_QUIET
from app.batch.summary import robust_outliers
from app.cli import main
from app.services.runs.inputs import CommandError
from tests.app.recordings import assert_same_document, read_json, write_recording

_write = write_recording


@pytest.fixture(scope="module")
def recordings(tmp_path_factory) -> Path:
    """``data/`` with four good recordings (two named ``rec.csv`` in different folders)
    and one broken file."""
    d = tmp_path_factory.mktemp("data")
    _write(d / "alpha.csv", 63.0, 1)
    _write(d / "beta.csv", 50.0, 2)
    _write(d / "a" / "rec.csv", 60.0, 3)
    _write(d / "b" / "rec.csv", 40.0, 4)
    (d / "broken.csv").write_text("t_s,u_V,y_um\n0,1,abc\n", encoding="utf-8")
    return d


@pytest.fixture(scope="module")
def scheduler():
    """Address of a small threaded TCP cluster (one worker, one thread)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      **LOCAL_CLUSTER_QUIET) as cluster:
        yield cluster.scheduler_address


def _assert_same_document(batch: Path, single: Path) -> None:
    assert_same_document(read_json(batch), read_json(single))


def _rows(path: Path) -> dict[str, dict[str, str]]:
    with path.open(encoding="utf-8") as fh:
        return {r["name"]: r for r in csv.DictReader(fh)}


def test_fit_batch_equals_single_fits_and_records_failures(recordings, scheduler, tmp_path,
                                                           capsys):
    out = tmp_path / "out"
    files = [str(recordings / "*.csv"), str(recordings / "*" / "rec.csv"),
             str(recordings / "missing.csv")]
    res = run_batch(files, out, FitOptions(n_operators=6), scheduler=scheduler)
    err = capsys.readouterr().err
    by = {r.name: r for r in res.recordings}
    assert set(by) == {"alpha", "beta", "broken", "a__rec", "b__rec", "missing"}
    assert {r.name for r in res.failed} == {"broken", "missing"}
    assert "file not found" in by["missing"].error
    # the user-facing message of the single command, with the file's own name
    single_err = tmp_path / "single-err.json"
    assert main(["fit", str(recordings / "broken.csv"), "-o", str(single_err), "-q"]) == 2
    msg = capsys.readouterr().err
    assert by["broken"].error and by["broken"].error in msg.replace(str(recordings) + "/", "")
    assert "hyst-batch-" not in by["broken"].error  # no worker temp path leaks
    # every good recording: exactly what `hyst fit` writes (to 1e-9)
    rows = _rows(res.summary_csv)
    for name, src in (("alpha", "alpha.csv"), ("beta", "beta.csv"), ("a__rec", "a/rec.csv"),
                      ("b__rec", "b/rec.csv")):
        single = tmp_path / f"single-{name}.json"
        assert main(["fit", str(recordings / src), "-n", "6", "-o", str(single), "-q"]) == 0
        _assert_same_document(out / f"{name}.json", single)
        report = json.loads(single.read_text())["provenance"]["fit"]["report"]
        assert float(rows[name]["heldout_rmse_pct"]) == pytest.approx(
            report["test"]["rmse_pct"], rel=1e-12)
        assert float(rows[name]["train_rmse"]) == pytest.approx(report["train"]["rmse"],
                                                                rel=1e-12)
        assert int(rows[name]["samples"]) == 4000 and rows[name]["n"] == "6"
        assert rows[name]["status"] == "ok" and rows[name]["error"] == ""
    assert rows["broken"]["status"] == "failed" and rows["broken"]["error"]
    # progress on stderr: done / failed / remaining and a rate
    assert re.search(r"\d+ done, \d+ failed, 0 remaining, [\d.]+/s", err)
    html = res.report_html.read_text(encoding="utf-8")
    assert "Plotly.newPlot" in html and "cdn.plot.ly" not in html
    assert not re.search(r"<script[^>]+src=", html)
    assert "id='rec-a__rec'" in html and "href='a__rec.json'" in html
    assert "file not found" in html


def test_resume_skips_same_content_and_options_only(recordings, scheduler, tmp_path):
    out = tmp_path / "out"
    src = tmp_path / "in"
    for k, name in enumerate(("one", "two", "three")):
        _write(src / f"{name}.csv", 60.0 - 5 * k, 10 + k)
    opts = FitOptions(n_operators=5)
    first = run_batch([str(src)], out, opts, scheduler=scheduler, quiet=True)
    assert not first.resumed and len(first.succeeded) == 3
    again = run_batch([str(src / "*.csv")], out, opts, scheduler=scheduler, quiet=True)
    assert {r.name for r in again.resumed} == {"one", "two", "three"}
    assert [r.heldout_rmse for r in again.recordings] == [r.heldout_rmse for r in
                                                         first.recordings]
    # changed content -> that recording reruns; the others are still skipped
    _write(src / "two.csv", 30.0, 99)
    third = run_batch([str(src)], out, opts, scheduler=scheduler, quiet=True)
    assert {r.name for r in third.resumed} == {"one", "three"}
    assert third.recordings[2].heldout_rmse != first.recordings[2].heldout_rmse  # "two"
    # a deleted output -> rerun; other options -> everything reruns
    (out / "one.json").unlink()
    fourth = run_batch([str(src)], out, opts, scheduler=scheduler, quiet=True)
    assert {r.name for r in fourth.resumed} == {"two", "three"}
    fifth = run_batch([str(src)], out, FitOptions(n_operators=4), scheduler=scheduler,
                      quiet=True)
    assert not fifth.resumed and {r.n_operators for r in fifth.recordings} == {4}


def test_diagnose_batch_equals_single_diagnose(tmp_path, scheduler, capsys):
    src = _write(tmp_path / "lagged.csv", 63.0, 7, lag=1e-3)
    out = tmp_path / "out"
    opts = DiagnoseOptions(operators=10, effects="lag")
    res = run_batch([str(src)], out, opts, scheduler=scheduler, quiet=True)
    single = tmp_path / "single.json"
    assert main(["diagnose", str(src), "--operators", "10", "--effects", "lag",
                 "--json", "--save-model", str(single)]) == 0
    doc = json.loads(capsys.readouterr().out)
    _assert_same_document(out / "lagged.json", single)
    (r,) = res.recordings
    assert r.effects == tuple(doc["final"]["effects"]) and r.effects[:1] == ("lag",)
    assert r.heldout_rmse_pct == pytest.approx(doc["final"]["heldout_rmse_pct"], rel=1e-9)
    assert r.parameters["lag.tau_s"] == pytest.approx(1e-3, rel=0.2)
    stored = json.loads((out / "diagnosis" / "lagged.json").read_text())
    assert stored["effects"][0]["parameters"] == doc["effects"][0]["parameters"]
    row = _rows(res.summary_csv)["lagged"]
    assert row["effects"] == ";".join(doc["final"]["effects"]) and row["train_rmse"] == ""
    html = res.report_html.read_text(encoding="utf-8")
    assert "Effects across the fleet" in html and "<td>lag</td>" in html


def test_cli_starts_a_process_cluster(recordings, tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["batch", "fit", str(recordings / "alpha.csv"), str(recordings / "beta.csv"),
                 "-o", str(out), "-n", "6", "--workers", "1", "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    doc = json.loads(captured.out)
    assert [r["status"] for r in doc["recordings"]] == ["ok", "ok"]
    single = tmp_path / "single.json"
    assert main(["fit", str(recordings / "beta.csv"), "-n", "6", "-o", str(single), "-q"]) == 0
    _assert_same_document(out / "beta.json", single)
    # a failed recording makes the exit code 1, bad options 2 before any work
    assert main(["batch", "fit", str(recordings / "broken.csv"), "-o", str(out), "-q",
                 "--scheduler", "tcp://127.0.0.1:1", "--train", "x"]) == 2
    assert "--train" in capsys.readouterr().err


def test_bad_options_and_nothing_to_run_fail_before_work(tmp_path):
    with pytest.raises(CommandError, match="--test"):
        run_batch(["x.csv"], tmp_path, FitOptions(test="5"))
    with pytest.raises(CommandError, match="nothing matches"):
        run_batch([str(tmp_path / "*.csv")], tmp_path / "o", FitOptions())


def test_output_names_disambiguate_stems_and_expand_globs(tmp_path):
    for p in ("x/run.csv", "y/run.csv", "z/deep/run.csv", "summary.csv", "solo.csv"):
        (tmp_path / p).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / p).write_text("t,u,y\n", encoding="utf-8")
    files, unmatched = expand([str(tmp_path / "**" / "*.csv"), str(tmp_path / "solo.csv"),
                               str(tmp_path / "none*.csv")])
    assert unmatched == [str(tmp_path / "none*.csv")]
    assert len(files) == 5  # solo.csv once although named twice
    names = dict(zip((f.relative_to(tmp_path).as_posix() for f in files),
                     output_names(files), strict=True))
    assert names == {"x/run.csv": "x__run", "y/run.csv": "y__run", "z/deep/run.csv": "deep__run",
                     "summary.csv": "summary_1", "solo.csv": "solo"}


def test_outliers_follow_median_mad_and_report_escapes(tmp_path):
    vals = [1.0, 1.1, 0.9, 1.05, 0.95, 1.02, 6.0]
    rows = [RecordingResult(f"r{i}.csv", f"r{i}", "ok", model="pi", heldout_rmse_pct=v,
                            parameters={"pi.p0": 0.5 + 0.01 * i}) for i, v in enumerate(vals)]
    rows.append(RecordingResult("<b>x</b>.csv", "<script>alert(1)</script>", "failed",
                                error="bad <img src=x onerror=alert(1)>"))
    from app.batch.summary import fleet_metrics

    out = robust_outliers(fleet_metrics(rows))
    mad = median_abs_deviation(vals)  # scipy: an independent median/MAD
    z = 0.6745 * (np.array(vals) - np.median(vals)) / mad
    assert [(o.name, o.metric) for o in out] == [
        (f"r{i}", "held-out RMSE (% of range)") for i in np.flatnonzero(np.abs(z) > 3.5)]
    assert out[0].name == "r6" and math.isclose(out[0].z, z[6])
    page = write_report(tmp_path / "r.html", "fit", rows, FitOptions()).read_text()
    assert "<script>alert" not in page and "<img src=x" not in page
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert "href='#rec-r6'" in page
    assert '"displaylogo": false' in page and '"showSendToCloud": false' in page  # stays local


def test_diagnosis_benchmark_executor_runs_on_a_scheduler(scheduler):
    from concurrent.futures import as_completed

    from benchmarks.diagnosis.dask_runner import executor

    with executor(1, scheduler) as ex:
        futs = [ex.submit(pow, k, 2) for k in range(5)]
        assert sorted(f.result() for f in as_completed(futs)) == [0, 1, 4, 9, 16]


def test_batch_builds_each_recordings_fmu_and_links_it(recordings, scheduler, tmp_path,
                                                        capsys):
    """``--fmu 2``: every good recording's compensator FMU in DIR/fmu/, linked from the
    report; the FMU is the one ``hyst export --format fmu --inverse`` builds from its JSON."""
    import shutil

    fmpy = pytest.importorskip("fmpy")
    from fmpy.validation import validate_fmu

    if shutil.which("gcc") is None:
        pytest.skip("gcc not installed")
    out = tmp_path / "out"
    code = main(["batch", "fit", str(recordings / "alpha.csv"), str(recordings / "broken.csv"),
                 "-n", "6", "--fmu", "2", "-o", str(out), "--scheduler", scheduler, "-q"])
    assert code == 1  # broken.csv fails, alpha does not
    capsys.readouterr()
    fmu = out / "fmu" / "alpha-compensator.fmu"
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    assert md.fmiVersion == "2.0" and "alpha.csv" in md.description
    assert "href='fmu/alpha-compensator.fmu'" in (out / "report.html").read_text()
    assert not list((out / "fmu").glob("broken*"))
    with pytest.raises(SystemExit):
        main(["batch", "fit", str(recordings / "alpha.csv"), "--fmu", "x", "-o", str(out)])
    assert main(["batch", "fit", str(recordings / "alpha.csv"), "--fmu", "4", "-o",
                 str(out), "--scheduler", scheduler, "-q"]) == 2
    assert "--fmu 4: unknown FMI version; use --fmu 3 or --fmu 2" in capsys.readouterr().err
