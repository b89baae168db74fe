"""Every stored part is JSON or ``.npz`` and nothing stored is executed; a damaged part
resets its session with a clear 410, once."""

from __future__ import annotations

import io
import json
import logging
import pickle
import sqlite3
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.explore.config import Config
from app.services.explore.simulation import diagnosed_model
from app.services.session import actions
from app.services.session.sessions import SessionRegistry, new_code
from app.services.settings import Settings
from app.services.storage.store import DamagedSessionError, SessionState, SessionStore
from app.services.storage.store_parts import OLD_DIAGNOSIS_NOTE
from core.base import Chain, model_from_dict
from core.recordings import Recording
from core.stages import Creep
from tests.app.recordings import small_diagnosis, small_fit


def _extended() -> Chain:
    return Chain.of(model_from_dict(Config().model), Creep([0.01, 0.1], [0.05, 0.05]))


def _old_diagnosis(db: Path, code: str, report: dict[str, Any] | str,
                   diagnosed: dict[str, Any] | None) -> None:
    """Give the stored session ``code`` a diagnosis in the form the explorer stored before
    2026-12-05 (store.py and store_parts.py of 483c7f3^): the report, ``dump_json``'s text,
    in the row's ``diagnosis`` column, and the blob ``{"diagnosed": model document or
    null}`` as JSON bytes."""
    text = report if isinstance(report, str) else json.dumps(report, allow_nan=False)
    blob = json.dumps({"diagnosed": diagnosed}, allow_nan=False).encode()
    with sqlite3.connect(db) as raw:
        raw.execute("UPDATE sessions SET diagnosis=?, size=size+? WHERE code=?",
                    (text, len(text) + len(blob), code))
        raw.execute("INSERT INTO blobs (code, kind, data) VALUES (?, 'diagnosis', ?)",
                    (code, blob))
    raw.close()


def _stored(db: Path) -> str:
    """A session with every part (config, recording, fit, diagnosis) in the file ``db``, its
    diagnosis in the form stored before 2026-12-05 (the report and the diagnosed model)."""
    t = np.arange(300) * 1e-3
    u = np.sin(2 * np.pi * 4 * t)
    store = SessionStore(db)
    code = new_code()
    store.save(SessionState(
        code=code, config=Config(), recording=Recording(t, u, 0.5 * u, name="r"),
        fit=small_fit()))
    store.close()
    _old_diagnosis(db, code, {"findings": ["creep"]}, _extended().to_dict())
    return code


def _tamper(db: Path, sql: str, value: Any) -> None:
    with sqlite3.connect(db) as raw:
        assert raw.execute(sql, (value,)).rowcount == 1
    raw.close()


class _Payload:
    """Unpickling this creates ``path`` (what a crafted blob could do)."""

    def __init__(self, path: Path) -> None:
        self.path = str(path)

    def __reduce__(self) -> tuple[Any, ...]:
        return (open, (self.path, "w"))


def _npz_without_meta() -> bytes:
    buf = io.BytesIO()
    np.savez(buf, t=np.zeros(3))
    return buf.getvalue()


SET_CONFIG = "UPDATE sessions SET config=?"
SET_FITTED = "UPDATE sessions SET fitted=?"
SET_FIT_REPORT = "UPDATE sessions SET fit_report=?"
SET_RECORDING = "UPDATE blobs SET data=? WHERE kind='recording'"
SET_DIAGNOSIS = "UPDATE blobs SET data=? WHERE kind='diagnosis'"

DAMAGE = {
    "config-garbage": ("config", SET_CONFIG, "{not json"),
    "config-no-object": ("config", SET_CONFIG, "[1, 2]"),
    "config-bad-model": ("config", SET_CONFIG, '{"model": {"type": "nope"}, "signal": {},'
                                               ' "mismatch": 0, "use_recording": false}'),
    "recording-garbage": ("recording", SET_RECORDING, b"\x00\xff garbage"),
    "recording-no-meta": ("recording", SET_RECORDING, _npz_without_meta()),
    "fit-garbage": ("fit", SET_FITTED, "\x00\x01"),
    "fit-bad-model": ("fit", SET_FITTED, '{"type": "pi", "r": "many"}'),
    "fit-bad-parameter-set": ("fit", SET_FIT_REPORT, '{"parameter_set": {"format": "x"}}'),
    "fit-no-report": ("fit", SET_FIT_REPORT, '{"rmse": 0.1}'),
    "diagnosis-garbage": ("diagnosis", SET_DIAGNOSIS, b"\x80\x04garbage"),
    "diagnosis-neither-form": ("diagnosis", SET_DIAGNOSIS, b'{"model": {"type": "pi"}}'),
    # the stored result (compressed JSON): cut short, not a result, a damaged result
    "diagnosis-result-cut": ("diagnosis", SET_DIAGNOSIS, zlib.compress(b'{"result": 1}')[:-3]),
    "diagnosis-not-a-result": ("diagnosis", SET_DIAGNOSIS, zlib.compress(b'{"report": {}}')),
    "diagnosis-bad-result": ("diagnosis", SET_DIAGNOSIS, zlib.compress(
        b'{"result": {"format": "hysteresis-explorer/diagnosis-result", "version": 1, '
        b'"result": {"$type": "DiagnosisResult", "fields": {"split": 3}}}}')),
}


@pytest.mark.parametrize("name", list(DAMAGE))
def test_a_damaged_part_answers_410_once_and_resets_the_session(
        tmp_path: Path, caplog: pytest.LogCaptureFixture, name: str) -> None:
    part, sql, value = DAMAGE[name]
    db = tmp_path / "sessions.sqlite3"
    code = _stored(db)
    _tamper(db, sql, value)
    with TestClient(create_app(Settings(viser_port=None, state_dir=str(tmp_path)))) as c:
        with caplog.at_level(logging.WARNING):
            r = c.get(f"/api/sessions/{code}")
        assert r.status_code == 410, r.text
        detail = r.json()["detail"]
        assert detail.startswith("this session's state was damaged and has been reset")
        assert f"(damaged: {part})" in detail
        assert "damaged and has been reset" in caplog.text and part in caplog.text
        assert code not in caplog.text and code.replace("-", "") not in caplog.text
        again = c.get(f"/api/sessions/{code}")  # the next request works: a fresh state
        assert again.status_code == 200
        assert again.json()["recording"] is None and again.json()["fitted"] is None
        assert c.patch(f"/api/sessions/{code}/config", json={"mismatch": 0.1}).status_code \
            == 200
    assert SessionStore(db).load(code) is not None  # the reset is stored too


def test_a_fit_stored_in_the_old_form_loads_as_a_typed_outcome(tmp_path: Path) -> None:
    """Sessions stored before the typed state (2026-12-05) hold their fit as the fitted
    model's document beside the explorer's report (FitReport.to_dict() plus the kind, n
    and the errors on the whole recording); they load as the same FitOutcome."""
    import json

    from app.routers.schemas import fit_report_json
    from app.services.analysis.fitting import fit_result

    t = np.arange(400) * 1e-3
    u = 3 * np.sin(2 * np.pi * 3 * t) * np.exp(-t)
    rec = Recording(t, u, model_from_dict(Config().model)(u), name="old")
    fit = small_fit()
    db = tmp_path / "sessions.sqlite3"
    code = _stored(db)
    old_report = fit_report_json(fit_result(fit, rec))  # as the fit job stored it then
    with sqlite3.connect(db) as raw:
        raw.execute("UPDATE sessions SET fitted=?, fit_report=? WHERE code=?",
                    (json.dumps(fit.model.to_dict()), json.dumps(old_report), code))
    raw.close()
    again = SessionRegistry(store=SessionStore(db)).get(code)
    got = again.fit
    assert got is not None and again.fitted is not None
    assert again.fitted.to_dict() == fit.model.to_dict() and got.kind == "pi"
    assert got.report == fit.report and got.warnings == fit.warnings
    assert got.memory_note == fit.memory_note and "wipe-out" in got.memory_note
    assert got.parameter_set.provenance.fit["n_operators"] == 4
    # and it is stored again in the new form, the same outcome
    again.save()
    back = SessionStore(db).load(code)
    assert back is not None and back.fit is not None
    assert back.fit.parameter_set.to_dict() == got.parameter_set.to_dict()


def test_a_legacy_pickled_diagnosis_is_never_unpickled(tmp_path: Path) -> None:
    canary, marker = tmp_path / "canary", tmp_path / "executed"
    pickle.loads(pickle.dumps(_Payload(canary)))  # the payload is live: it makes a file
    assert canary.exists()
    db = tmp_path / "sessions.sqlite3"
    code = _stored(db)
    _tamper(db, SET_DIAGNOSIS, pickle.dumps(_Payload(marker)))
    reg = SessionRegistry(store=SessionStore(db))
    with pytest.raises(DamagedSessionError, match=r"damaged: diagnosis"):
        reg.get(code)
    assert not marker.exists()
    assert reg.get(code).diagnosis is None and not marker.exists()


def test_no_stored_part_is_a_pickle(tmp_path: Path, diagnosed) -> None:
    rec, result = diagnosed
    db = tmp_path / "sessions.sqlite3"
    store = SessionStore(db)
    store.save(SessionState(code=new_code(), config=Config(), recording=rec,
                            fit=small_fit(), diagnosis_result=result))
    store.close()
    with sqlite3.connect(db) as raw:
        blobs = dict(raw.execute("SELECT kind, data FROM blobs"))
    raw.close()
    assert zlib.decompress(blobs["diagnosis"]).startswith(b'{"result": ')  # JSON
    assert blobs["recording"].startswith(b"PK")  # .npz (a zip of .npy arrays)
    with np.load(io.BytesIO(blobs["recording"]), allow_pickle=False) as z:
        assert all(z[k].dtype != object for k in z.files)


@pytest.fixture(scope="module")
def diagnosed() -> tuple[Recording, Any]:
    return small_diagnosis()


def test_a_diagnosis_survives_a_restart_as_its_result(tmp_path: Path, diagnosed) -> None:
    """The stored diagnosis is the core's result: after a restart the session has the same
    result (the same document), report, diagnosed model, figure and HTML report."""
    rec, result = diagnosed
    db = tmp_path / "sessions.sqlite3"
    reg = SessionRegistry(store=SessionStore(db))
    s = reg.create()
    s.set_recording(rec)
    s.set_diagnosis(result)
    report, figure = s.diagnosis, actions.diagnosis_figure(s)
    assert diagnosed_model(s) is result.model and report is not None and figure is not None
    reg.store.close()
    again = SessionRegistry(store=SessionStore(db)).get(s.code)  # a restarted server
    back = again.diagnosis_result
    assert back is not None and back is not result
    assert back.to_json() == result.to_json()
    assert again.diagnosis is not None and again.has_diagnosis
    assert again.diagnosis.summary == report.summary
    assert "Found" in " ".join(report.summary.findings)
    got = diagnosed_model(again)
    assert got is not None and got.to_dict() == result.model.to_dict()
    fig = actions.diagnosis_figure(again)
    assert fig is not None and json.dumps(fig.to_dict()) == json.dumps(figure.to_dict())
    html = actions.diagnosis_report(again)
    assert html is not None and html.startswith("<!DOCTYPE html>")
    with sqlite3.connect(db) as raw:
        (blob,), (column,) = (raw.execute("SELECT data FROM blobs WHERE kind='diagnosis'")
                              .fetchone(), raw.execute("SELECT diagnosis FROM sessions")
                              .fetchone())
    raw.close()
    assert column is None and zlib.decompress(blob).startswith(b'{"result": {"format"')


def _old_form(tmp_path: Path, diagnosed) -> tuple[Path, str, dict[str, Any], Any]:
    """A session stored as the explorer stored it before 2026-12-05: config, the
    diagnosis's recording and a fit in their forms, the diagnosis as the report the
    diagnosis job returned then (``{"engine", "findings", "baseline_rmse_pct",
    "final_rmse_pct", "effects", "document": DiagnosisResult.to_dict()}``, the bytes the REST
    API still answers) beside the diagnosed model's document."""
    from app.routers.schemas import diagnosis_json
    from app.services.analysis.diagnosis import session_diagnosis

    rec, result = diagnosed
    db = tmp_path / "sessions.sqlite3"
    store = SessionStore(db)
    code = new_code()
    fit = small_fit()
    store.save(SessionState(code=code, config=Config(), recording=rec, fit=fit))
    store.close()
    report = diagnosis_json(session_diagnosis(result, rec.units))
    assert report["findings"] and report["document"]["effects"]
    _old_diagnosis(db, code, report, result.model.to_dict())
    return db, code, report, fit


def test_a_diagnosis_stored_in_the_old_form_is_dropped_with_a_note(tmp_path: Path,
                                                                  diagnosed) -> None:
    """A real session of before 2026-12-05 (its report in the row, the diagnosed model's
    document in the blob): no result can be rebuilt from a report of derived numbers, so
    the diagnosis is dropped, not kept as a dict; the session keeps its recording, fit and
    config, and the figure, the report and the viser button say why in words."""
    db, code, report, fit = _old_form(tmp_path, diagnosed)
    with sqlite3.connect(db) as raw:  # written in the old form, as the old code wrote it
        (blob,), (column,) = (raw.execute("SELECT data FROM blobs WHERE kind='diagnosis'")
                              .fetchone(), raw.execute("SELECT diagnosis FROM sessions")
                              .fetchone())
    raw.close()
    assert json.loads(column) == report and column.startswith('{"engine": "core.diagnosis"')
    assert blob.startswith(b'{"diagnosed": {"type": "chain"')
    again = SessionRegistry(store=SessionStore(db)).get(code)  # a server of this version
    assert again.diagnosis_result is None and again.diagnosis is None
    assert not again.has_diagnosis and diagnosed_model(again) is None
    assert again.recording is not None and again.recording.n_samples == 1500
    assert again.fit is not None and again.fit.parameter_set.to_dict()["model"] \
        == fit.parameter_set.to_dict()["model"]
    assert again.config.to_dict() == Config().to_dict()
    assert again.diagnosis_note == OLD_DIAGNOSIS_NOTE
    why = actions.no_report(again)
    assert "stored by an older version" in why and "dropped" in why
    assert why.endswith("run the diagnosis again")
    assert actions.diagnosis_report(again) is None and actions.diagnosis_figure(again) is None
    again.touch()  # the next stored change leaves nothing of the old form behind
    with sqlite3.connect(db) as raw:
        left = raw.execute("SELECT COUNT(*) FROM blobs WHERE kind='diagnosis'").fetchone()
        (column,) = raw.execute("SELECT diagnosis FROM sessions").fetchone()
    raw.close()
    assert left == (0,) and column is None
    back = SessionStore(db).load(code)
    assert back is not None and back.diagnosis_note is None and back.recording_stored
    s2 = SessionRegistry(store=SessionStore(tmp_path / "b.sqlite3")).create()
    assert actions.no_report(s2) == "run the diagnosis first" and not s2.has_diagnosis


def test_an_old_form_diagnosis_answers_in_words_over_rest(tmp_path: Path, diagnosed) -> None:
    """Through the REST API: the session loads (200, no diagnosis), the report asks for the
    diagnosis again in the note's words, and a new diagnosis clears the note."""
    db, code, _, _ = _old_form(tmp_path, diagnosed)
    with TestClient(create_app(Settings(viser_port=None, state_dir=str(tmp_path)))) as c:
        r = c.get(f"/api/sessions/{code}")
        assert r.status_code == 200 and r.json()["has_diagnosis"] is False
        assert r.json()["recording"] == {"name": "creep", "samples": 1500}
        for path in ("diagnosis/report.html", "diagnosis/figure"):
            r = c.get(f"/api/sessions/{code}/{path}")
            assert r.status_code == 409 and OLD_DIAGNOSIS_NOTE in r.json()["detail"]


@pytest.mark.parametrize("report, model", [
    ('"just a string"', _extended().to_dict()),  # a report that is no object
    ('{"findings": ["creep"]}', {"type": "nope"}),  # a model that no longer builds
    ('{"findings": ["creep"]}', None),  # no effect added: no model
])
def test_any_old_form_diagnosis_is_dropped_not_the_session(tmp_path: Path, report: str,
                                                           model: Any) -> None:
    """Whatever an old-form diagnosis holds, it is dropped and the rest of the session kept
    (it is never read, so it cannot reset the session)."""
    db = tmp_path / "sessions.sqlite3"
    store = SessionStore(db)
    code = new_code()
    t = np.arange(300) * 1e-3
    store.save(SessionState(code=code, config=Config(),
                            recording=Recording(t, np.sin(t), np.cos(t), name="r")))
    store.close()
    _old_diagnosis(db, code, report, model)
    back = SessionStore(db).load(code)
    assert back is not None and back.recording_stored and back.diagnosis_result is None
    assert back.diagnosis_note == OLD_DIAGNOSIS_NOTE
