"""The service layer: one typed session state, views computed on demand, pure figures."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from app.services.explore import figures as F
from app.services.explore.config import Config, SignalSpec
from app.services.explore.simulation import compute
from app.services.jobs import tasks
from app.services.session import actions
from app.services.session.sessions import Session, SessionRegistry
from app.services.settings import Settings
from app.services.storage.store import SessionState, SessionStore
from core.base import Model
from core.closed_loop import HammersteinLoop
from core.pi import PIModel
from core.presets import get_preset
from core.recordings import Recording
from tests.app.job_work import run_here
from tests.app.recordings import small_diagnosis

ROOT = Path(__file__).resolve().parents[3]


def test_a_session_holds_one_frozen_state_replaced_by_each_transition(tmp_path: Path) -> None:
    reg = SessionRegistry(store=SessionStore(tmp_path / "s.sqlite3"))
    s = reg.create()
    before = s.state
    assert isinstance(before, SessionState) and isinstance(before.config, Config)
    with pytest.raises(dataclasses.FrozenInstanceError):
        before.version = 9  # type: ignore[misc]
    t = np.arange(400) * 1e-3
    u = 3 * np.sin(2 * np.pi * 3 * t)
    s.set_recording(Recording(t, u, PIModel.from_dict(before.config.model)(u)))
    run_here(tasks.fit_task(s, 4, "pi", apply=True))  # the GUI's and REST's fit job
    after = s.state
    assert before.recording is None and before.fit is None and before.version == 0
    # the recording is on disk (the store's cache), not held by the state
    assert after.recording is None and after.recording_stored and s.recording is not None
    assert after.fit is not None and after.config.model == after.fit.model.to_dict()
    # the store keeps the same typed state: a restarted server reads it back as it was
    reg.store.close()
    again = SessionStore(tmp_path / "s.sqlite3").load(s.code)
    assert isinstance(again.config, Config) and again.config.to_dict() == after.config.to_dict()
    assert again.version == after.version and again.fit is not None
    assert again.fit.parameter_set.to_dict() == after.fit.parameter_set.to_dict()
    assert again.fit.report == after.fit.report and again.fit.kind == "pi"


def test_every_change_marks_the_session_used_in_the_store() -> None:
    """The store's eviction protection and the teacher's push go by the last use: a
    session changed through a GUI view (never looked up by code) must count as used."""
    store = SessionStore(":memory:")
    s = SessionRegistry(store=store).create()
    time.sleep(0.01)
    later = time.time()
    assert s.code not in store.codes(since=later)
    s.set_config(Config(mismatch=0.1))
    assert s.code in store.codes(since=later)
    time.sleep(0.01)
    later = time.time()
    s.set_diagnosis(small_diagnosis()[1])
    assert s.code in store.codes(since=later)


def test_only_the_requested_views_are_computed() -> None:
    cfg = Config(signal=SignalSpec(samples=1500))
    res = compute(cfg, views=("loop",))
    assert res.views == {"loop"} and res.loading is not None
    assert res.v is res.y_comp is res.digitized is res.contributions is res.closed_loop is None
    full = compute(cfg)
    assert full.v is not None and full.digitized is not None
    assert full.contributions is not None and full.closed_loop is not None
    # a figure of a view that was not computed says so instead of computing it
    fig = F.build("inverse", res).to_dict()
    assert fig["data"] == [] and "not computed" in fig["layout"]["annotations"][0]["text"]


def test_figures_are_pure_functions_of_the_result(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every figure builds from a result with simulation, inversion and the loading curve
    of every model switched off (a figure that still ran a model would raise)."""
    settings = Settings()
    for model in (PIModel.from_dict(Config().model), get_preset("paper001-example4")):
        res = compute(Config(model=model.to_dict(), signal=SignalSpec(samples=1200)),
                      max_operators=settings.max_operators)

        def boom(*a: object, **k: object) -> None:
            raise AssertionError("a figure ran the model")

        with monkeypatch.context() as m:
            for cls in {Model, *type(res.model).__mro__, PIModel, HammersteinLoop}:
                for name in ("simulate", "inverse", "loading_curve", "_run", "__call__"):
                    if name in vars(cls):
                        m.setattr(cls, name, boom)
            for name in F.FIGURES:
                F.build(name, res).to_json()


def test_operators_view_groups_many_operators_into_outline_free_bands() -> None:
    r = np.linspace(0.1, 3.6, 25)
    model = {"type": "pi", "p0": 0.72, "thresholds": r.tolist(),
             "weights": (0.6 * np.exp(-r)).tolist()}
    res = compute(Config(model=model, signal=SignalSpec(samples=4000)), views=("operators",))
    fig = F.operators_figure(res).to_dict()
    bands = [t for t in fig["data"] if t.get("stackgroup")]
    assert len(bands) == 1 + F.MAX_BANDS  # p0 u and the operator bands
    assert all(t["mode"] == "none" for t in bands)  # fills only: one path per band
    assert f"25 operators in {F.MAX_BANDS} bands" in fig["layout"]["legend"]["title"]["text"]
    total = next(F.values(t["y"]) for t in fig["data"] if t["name"] == "y (sum)")
    np.testing.assert_allclose(np.sum([F.values(t["y"]) for t in bands], axis=0), total,
                               atol=1e-5 * np.ptp(total))


def test_refused_config_changes_store_nothing() -> None:
    s = Session("abc")
    bad = {**Config().model, "thresholds": [0.9, 0.45, 1.35, 1.8, 2.25, 2.7]}
    with pytest.raises(ValueError, match="thresholds"):
        actions.change_config(s, lambda c: c.with_model(bad), Settings())
    assert s.version == 0 and s.config.model == Config().model


def test_the_web_layer_does_not_import_the_command_line() -> None:
    code = ("import sys, app.server, app.gui.explorer, app.routers.jobs, "
            "app.services.session.actions;"
            "print([m for m in sys.modules if m.startswith('app.commands')])")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, check=True, timeout=120).stdout
    assert out.strip() == "[]"
