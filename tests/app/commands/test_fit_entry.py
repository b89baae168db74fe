"""One fitting entry point: ``hyst fit``, the explorer and the batch worker fit alike.

The reference is what the ``hyst fit`` command writes (an independent run through its own
parser, reader and file output); the batch worker is run in threads to show that workers no
longer share stdout / stderr; the batch sources are checked for the old in-process command
run (argv parsing, redirected streams).
"""

from __future__ import annotations

import json
import re
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from app.batch import DiagnoseOptions, FitOptions
from app.batch.single import run_recording
from app.cli import main
from app.routers.schemas import fit_report_json
from app.services.analysis.fitting import fit_recording, fit_result
from app.services.analysis.recordings import recording_from_csv
from core.csvio import read_csv
from core.fitting import TimeWindow, fit_recordings
from tests.app.recordings import assert_same_document, write_recording

APP = Path(__file__).resolve().parents[3] / "app"
_write = write_recording
_assert_same = assert_same_document


def _cli_fit(src: Path, out: Path, *extra: str) -> dict:
    assert main(["fit", str(src), "-o", str(out), "-q", *extra]) == 0
    return json.loads(out.read_text(encoding="utf-8"))


def test_cli_explorer_and_batch_fit_the_same_parameter_set(tmp_path):
    src = _write(tmp_path / "alpha.csv", 60.0, 1)
    ref = _cli_fit(src, tmp_path / "cli.json", "--model", "pi", "-n", "6", "--train", "0:1.6")
    # the entry point itself, with the provenance the command gives it
    out = fit_recordings(read_csv(src), "pi", n_operators=6,
                         train=TimeWindow(0.0, 1.6, "0:1.6"),
                         files=["alpha.csv"], source="hyst fit alpha.csv")
    _assert_same(out.parameter_set.to_dict(), ref)
    assert out.memory_note and "wipe-out" in out.memory_note  # the PI default: exclude
    # the batch worker: bytes in, the same document out
    got = run_recording("fit", "alpha.csv", src.read_bytes(),
                        FitOptions(model="pi", n_operators=6, train="0:1.6"))
    assert got.ok, got.error
    _assert_same(json.loads(got.parameter_set), ref)
    assert got.samples == 4000 and "read alpha" in got.messages
    # the explorer (web page, REST, viser) fits with the command line's defaults: hyst fit
    # -n 6 (the last 20 % held out, the pre-wipe-out rows left out), no --initial-memory keep
    ref_cli = _cli_fit(src, tmp_path / "cli.json", "--model", "pi", "-n", "6")
    rec = recording_from_csv(src.read_bytes(), name="alpha.csv")
    out = fit_recording(rec, 6)
    report = fit_report_json(fit_result(out, rec))  # what the page shows
    _assert_same({"model": out.model.to_dict()}, {"model": ref_cli["model"]})
    rep = ref_cli["provenance"]["fit"]["report"]
    assert "wipe-out" in report["extra"]["initial_memory"]["summary"]
    assert report["train"]["rmse"] == pytest.approx(rep["train"]["rmse"], rel=1e-12)
    assert report["test"]["rmse_pct"] == pytest.approx(rep["test"]["rmse_pct"], rel=1e-12)


def test_other_fit_kinds_and_their_initial_memory(tmp_path):
    src = _write(tmp_path / "beta.csv", 50.0, 2)
    ref = _cli_fit(src, tmp_path / "mpi.json", "--model", "mpi", "-n", "5")
    got = run_recording("fit", "beta.csv", src.read_bytes(), FitOptions(model="mpi",
                                                                        n_operators=5))
    _assert_same(json.loads(got.parameter_set), ref)
    out = fit_recording(recording_from_csv(src.read_bytes(), name="beta.csv"), 5, "mpi")
    _assert_same({"model": out.model.to_dict()}, {"model": ref["model"]})
    # a kind that always starts relaxed says so instead of ignoring the option
    code = main(["fit", str(src), "--model", "mpi", "-n", "5", "--initial-memory", "exclude",
                 "-o", str(tmp_path / "x.json"), "-q"])
    assert code == 2 and not (tmp_path / "x.json").exists()


def test_thread_workers_keep_their_own_outputs(tmp_path):
    """Several recordings run concurrently in threads of one process (a ``processes=False``
    cluster): each outcome is that of its own recording, as when run one at a time."""
    amps = {"r0": 63.0, "r1": 45.0, "r2": 55.0, "r3": 35.0}
    files = {n: _write(tmp_path / f"{n}.csv", a, k) for k, (n, a) in enumerate(amps.items())}
    lagged = _write(tmp_path / "lagged.csv", 63.0, 7, lag=1e-3)
    fit_opts = FitOptions(n_operators=5)
    diag_opts = DiagnoseOptions(operators=10, effects="lag")
    serial = {n: run_recording("fit", p.name, p.read_bytes(), fit_opts)
              for n, p in files.items()}
    serial["lagged"] = run_recording("diagnose", lagged.name, lagged.read_bytes(), diag_opts)
    jobs = [("fit", p, fit_opts) for p in files.values()] * 2 + [("diagnose", lagged, diag_opts)]
    with ThreadPoolExecutor(max_workers=len(jobs)) as pool:
        futs = [pool.submit(run_recording, kind, p.name, p.read_bytes(), opts)
                for kind, p, opts in jobs]
        outcomes = [f.result() for f in futs]
    for (kind, p, _), got in zip(jobs, outcomes, strict=True):
        assert got.ok, got.error
        doc = json.loads(got.parameter_set)
        name = p.stem
        others = set(amps) - {name}
        assert not any(re.search(rf"\b{o}\b", got.messages) for o in others), got.messages
        if kind == "fit":
            assert doc["provenance"]["fit"]["recordings"] == [name]
            assert got.diagnosis == ""
            _assert_same(doc, json.loads(serial[name].parameter_set))
        else:
            diag = json.loads(got.diagnosis)  # exactly one JSON object, nothing else in it
            assert [r["name"] for r in diag["recordings"]] == ["lagged"]
            assert doc["provenance"]["source"] == "hyst diagnose lagged.csv"
            _assert_same(doc, json.loads(serial["lagged"].parameter_set))
            ref = json.loads(serial["lagged"].diagnosis)
            assert diag["final"] == ref["final"] and diag["effects"] == ref["effects"]


def test_batch_runs_no_command_line_and_redirects_nothing():
    """The worker calls functions; the old in-process ``hyst`` run (an argument list parsed
    by the command's parser, stdout / stderr redirected into buffers) must not come back."""
    forbidden = re.compile(r"redirect_std(out|err)|sys\.std(out|err)\s*=|parse_args|"
                           r"command_args|ArgumentParser|\bargv\b|\.run\(args")
    for path in sorted((APP / "batch").glob("*.py")):
        text = path.read_text(encoding="utf-8")
        hits = [m.group(0) for m in forbidden.finditer(text)]
        assert not hits, f"{path.name}: {hits}"
    # and no caller sniffs an estimator's (or the diagnosis') signature
    for path in [APP / "services" / "analysis" / "fitting.py",
                 APP / "services" / "analysis" / "diagnosis.py",
                 APP / "commands" / "fit.py", *(APP / "batch").glob("*.py")]:
        assert "inspect.signature" not in path.read_text(encoding="utf-8"), path.name
