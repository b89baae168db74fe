"""A session row as main 3119b8e's code wrote it (its text columns, byte for byte) loads:
its config with the model document, the typed model built from it, its fit as a typed
outcome; over REST and in the services."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

from fastapi.testclient import TestClient

from app.server import create_app
from app.services.explore import controls as C
from app.services.explore.config import Config, SignalSpec
from app.services.session import actions
from app.services.session.sessions import SessionRegistry
from app.services.settings import Settings
from app.services.storage.store import SessionStore
from core.base import Model

# Written by SessionStore.save of main 3119b8e (2026-12-05), a session with a Bouc-Wen model
# whose optional input0 is spelled out at its default, a moved signal and mismatch, and a
# 4-operator PI fit of a 400-sample recording (the columns config, fitted, fit_report).
_MAIN_CONFIG = (
    '{"model": {"type": "bouc-wen", "k": 1.0, "weights": [1.0], "saturation": [1.0], "rev'
    'ersal_slope": [0.5], "exponent": [1.0], "input0": 0.0}, "signal": {"kind": "sine", "'
    'amplitude": 2.5, "frequency": 1.0, "offset": 0.0, "duration": 2.0, "samples": 500}, '
    '"mismatch": 0.1, "use_recording": false}'
)
_MAIN_FITTED = (
    '{"type": "chain", "stages": [{"type": "pi", "p0": 0.7875610304275329, "thresholds": '
    '[0.574152957848414, 1.148305915696828, 1.722458873545242, 2.296611831393656], "weigh'
    'ts": [0.7546163926876338, 0.5222613531711069, 0.33102047257113004, 0.163566013838278'
    '9]}, {"type": "offset", "offset": -0.0072413804698796495}]}'
)
_MAIN_FIT_REPORT = (
    '{"parameter_set": {"format": "hysteresis-explorer/parameter-set", "version": 1, "mod'
    'el": {"type": "chain", "stages": [{"type": "pi", "p0": 0.7875610304275329, "threshol'
    'ds": [0.574152957848414, 1.148305915696828, 1.722458873545242, 2.296611831393656], "'
    'weights": [0.7546163926876338, 0.5222613531711069, 0.33102047257113004, 0.1635660138'
    '382789]}, {"type": "offset", "offset": -0.0072413804698796495}]}, "units": {"input":'
    ' "V", "output": "um", "time": "s"}, "provenance": {"created": "2026-12-05T23:43:06+0'
    '0:00", "tool": "hysteresis-explorer 0.1.0", "source": "fit old", "fit": {"model": "p'
    'i", "files": ["old"], "recordings": ["old"], "columns": {"time": "", "input": "", "o'
    'utput": ""}, "train": null, "test": null, "n_operators": 4, "report": {"model_type":'
    ' "pi", "n_parameters": 6, "train": {"n_samples": 320, "rmse": 0.02277871701694192, "'
    'max_abs": 0.07860700215192562, "output_range": 9.081026255804474, "rmse_pct": 0.2508'
    '3857677850074, "inverse_input_rmse": 0.022444036549750378, "input_range": 5.10358184'
    '7541458, "inverse_input_rmse_pct": 0.4397702872260649}, "test": {"n_samples": 80, "r'
    'mse": 0.022652633672397372, "max_abs": 0.062409525771492724, "output_range": 5.10769'
    '6044940488, "rmse_pct": 0.4435000335393159, "inverse_input_rmse": 0.0127300824274070'
    '82, "input_range": 2.4441433731985964, "inverse_input_rmse_pct": 0.5208402488577216}'
    ', "compensation_max_abs": 3.1086244689504383e-15, "compensation_rmse": 8.90655523635'
    '1438e-16, "invertible": true, "min_slope": 0.7875610304275329, "condition_number": 1'
    '351.8438420019174, "solver": "gram-cholesky-nnls", "extra": {"n_operators": 4, "min_'
    'slope": 0.0017793437093948177, "offset": -0.0072413804698796495, "initial_memory": {'
    '"rule": "exclude", "excluded_train_rows": 0, "wipeout_index": [232], "summary": "ini'
    'tial memory: kept the 232 training rows before the wipe-out time (leaving them out w'
    'ould keep only 88 of 320); they assume the relaxed state"}, "orientation": "loops ru'
    'n counter-clockwise in the (input, output) plane (the output lags: piezo-like loops;'
    ' signed loop area 8.5% of the travel x output range); fitted with play operators, no'
    'n-negative weights", "constraint": "nonnegative", "noise_floor": 0.00419773730747779'
    '3, "rmse_over_noise_floor": 5.39639143975119}, "warnings": ["the held-out RMSE 0.022'
    '65 (0.444 % of range) is 5 times the white-noise floor 0.0042: this model misses str'
    'ucture in the data. Largest residuals: at inputs -0.5418 to -0.05293 (RMS 0.0391), o'
    'n the rising input branch, further from the reversal (RMS 0.0227), and in t = 0.328 '
    'to 0.335 s of old (RMS 0.0453). Another fit kind (--model auto chooses one the way t'
    'he diagnosis does) or hyst diagnose may explain it."]}, "warnings": ["the held-out R'
    'MSE 0.02265 (0.444 % of range) is 5 times the white-noise floor 0.0042: this model m'
    'isses structure in the data. Largest residuals: at inputs -0.5418 to -0.05293 (RMS 0'
    '.0391), on the rising input branch, further from the reversal (RMS 0.0227), and in t'
    ' = 0.328 to 0.335 s of old (RMS 0.0453). Another fit kind (--model auto chooses one '
    'the way the diagnosis does) or hyst diagnose may explain it."]}, "notes": null}}}'
)
CODE = "mhxy-3k9b-8eqr-stuv"


def _main_row(db: Path) -> None:
    SessionStore(db).close()  # the schema
    with sqlite3.connect(db) as raw:
        raw.execute(
            "INSERT INTO sessions (code, created, last_used, teacher, version, config, fitted,"
            " fit_report, diagnosis, size, owner) VALUES (?,?,?,?,?,?,?,?,?,?,?)",
            (CODE, 1.0, 2.0, 0, 7, _MAIN_CONFIG, _MAIN_FITTED, _MAIN_FIT_REPORT, None,
             len(_MAIN_CONFIG) + len(_MAIN_FITTED) + len(_MAIN_FIT_REPORT), ""))
    raw.close()


def test_a_session_stored_by_main_loads(tmp_path: Path) -> None:
    db = tmp_path / "sessions.sqlite3"
    _main_row(db)
    s = SessionRegistry(store=SessionStore(db)).get(CODE)
    assert s.version == 7
    cfg = s.config
    assert cfg.to_dict() == json.loads(_MAIN_CONFIG)
    assert cfg.signal == SignalSpec(amplitude=2.5, samples=500) and cfg.mismatch == 0.1
    # the document keeps the slider the user spelled out, the session the typed model
    assert "input0" in [sl.path for g in C.model_controls(cfg.model).groups
                        for sl in g.sliders]
    assert isinstance(s.model, Model) and s.model.type_name == "bouc-wen"
    # the fit, typed
    fit = s.fit
    assert fit is not None and fit.kind == "pi" and s.fitted is not None
    assert s.fitted.to_dict() == json.loads(_MAIN_FITTED)
    assert fit.parameter_set.provenance.fit["n_operators"] == 4
    assert "wipe-out" in fit.memory_note and len(fit.warnings) == 1
    # the typed model the checks build is the same one; the export reads it
    settings = Settings(viser_port=None)
    assert actions.session_model(s, settings).to_dict() == s.model.to_dict()
    name, data = actions.export(s, "json")
    assert name.endswith(".json") and json.loads(data)["model"] == s.model.to_dict()
    # stored again by this code: the same config text, the same fit
    s.save()
    with sqlite3.connect(db) as raw:
        config_text, = raw.execute("SELECT config FROM sessions WHERE code=?",
                                   (CODE,)).fetchone()
    raw.close()
    assert config_text == _MAIN_CONFIG
    back = SessionStore(db).load(CODE)
    assert back is not None and back.fit is not None
    assert back.fit.parameter_set.to_dict() == fit.parameter_set.to_dict()


def test_a_session_stored_by_main_over_rest(tmp_path: Path) -> None:
    _main_row(tmp_path / "sessions.sqlite3")
    with TestClient(create_app(Settings(viser_port=None, state_dir=str(tmp_path)))) as c:
        r = c.get(f"/api/sessions/{CODE}")
        assert r.status_code == 200, r.text
        body = r.json()
        assert body["config"] == json.loads(_MAIN_CONFIG)
        assert body["fitted"] == json.loads(_MAIN_FITTED)
        fig = c.get(f"/api/sessions/{CODE}/figures?name=loop")
        assert fig.status_code == 200, fig.text
        assert fig.json()["model_type"] == "bouc-wen"
        assert Config().model != body["config"]["model"]
