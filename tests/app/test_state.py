"""Explorer services (no web imports): sessions, registry, compute, CSV, exports, figures."""

from __future__ import annotations

import json
import sys
import threading

import numpy as np
import plotly.graph_objects as go
import pytest

from app.services import config as S
from app.services import exports as E
from app.services import figures as F
from app.services import fitting as FT
from app.services import recordings as D
from app.services import sessions as SS
from app.services import simulation as C
from core.csvio import CSVError
from core.exceptions import ParameterError
from core.pi import PIModel
from core.signals import SIGNALS


def test_service_modules_have_no_web_imports() -> None:
    import subprocess

    code = ("import sys, app.services.sessions, app.services.simulation, "
            "app.services.recordings, app.services.fitting, app.services.diagnosis, "
            "app.services.exports; "
            "print([m for m in ('viser', 'fastapi', 'plotly') if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_default_config_is_paper001_example1() -> None:
    res = C.compute(S.Config())
    m = PIModel.from_dict(S.EXAMPLE1)
    np.testing.assert_allclose(res.u, 4 * np.sin(2 * np.pi * res.t), atol=1e-12)
    np.testing.assert_allclose(res.y, m(res.u))
    k = res.contrib_idx
    np.testing.assert_allclose(res.contributions.sum(axis=1) + m.p0 * res.u[k], res.y[k],
                               atol=1e-12)
    np.testing.assert_allclose(res.y_comp, res.u, atol=1e-9)  # P(P^-1(u)) = u


def test_perturb_changes_the_plant_only_when_asked() -> None:
    m = PIModel.from_dict(S.EXAMPLE1)
    assert C.perturb(m, 0.0) is m
    p = C.perturb(m, 0.2)
    np.testing.assert_allclose(p.thresholds, 1.2 * m.thresholds)
    np.testing.assert_allclose(p.weights, 0.8 * m.weights)


def test_registry_codes_lru_and_broadcast() -> None:
    reg = SS.SessionRegistry(max_sessions=3)
    a = reg.create()
    assert len(a.code.replace("-", "")) == 16 and reg.get(a.code.upper()) is a
    b = reg.create()
    with pytest.raises(KeyError):  # codes are made by the server only (issue 10)
        reg.get_or_create("Class-1")
    reg.get(a.code)  # a is now the most recent
    reg.create()
    reg.create()  # b leaves memory, not the store
    assert b.code not in [s.code for s in reg.all()]
    assert reg.get(b.code).code == b.code and len(reg) == 4
    with pytest.raises(KeyError):
        reg.get("x")
    model = {**S.EXAMPLE1, "p0": 1.0}
    assert reg.push_model(model) == 4
    assert all(s.config.model["p0"] == 1.0 for s in reg.all())


def test_session_listeners_and_versions() -> None:
    s = SS.Session(code="abc")
    seen: list[int] = []
    cb = lambda sess, cfg, v: seen.append(v)  # noqa: E731
    s.add_listener(cb)
    s.set_config(S.Config(mismatch=0.1))
    s.update(lambda c: S.Config(mismatch=0.2))
    s.touch()
    s.remove_listener(cb)
    s.set_config(S.Config())
    assert seen == [1, 2, 3] and s.version == 4


def test_concurrent_updates_are_not_lost() -> None:
    s = SS.Session(code="abc")

    def bump() -> None:
        for _ in range(200):
            s.update(lambda c: S.Config(mismatch=c.mismatch + 0.001))

    threads = [threading.Thread(target=bump) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert s.version == 800 and s.config.mismatch == pytest.approx(0.8)


def test_signal_validation_messages() -> None:
    with pytest.raises(ParameterError, match="samples"):
        S.SignalSpec(samples=10**7).validate(1000)
    with pytest.raises(ParameterError, match="kind"):
        S.SignalSpec(kind="nope").validate(1000)
    with pytest.raises(ParameterError, match="operators"):
        C.build_model({"type": "pi", "p0": 1, "thresholds": [1, 2, 3], "weights": [1, 1, 1]}, 2)


def test_every_signal_kind_builds() -> None:
    for kind in SIGNALS:
        t, u = C.make_signal(S.SignalSpec(kind=kind, samples=500))
        assert t.shape == u.shape and np.isfinite(u).all()


def test_csv_recordings_come_from_core_csvio() -> None:
    rows = "".join(f"{k},{(-1) ** (k // 4) * k},{k / 2}\n" for k in range(12))
    two = "".join(f"{(-1) ** (k // 4) * k},{k / 2}\n" for k in range(12))
    rec = D.recording_from_csv("a,b\n" + two, dt=0.5)
    np.testing.assert_allclose(rec.t, 0.5 * np.arange(12))  # no time column: t = k dt
    assert rec.n_samples == 12 and rec.units["time"] == "s"
    prev = D.csv_preview("t,u,y\n" + rows, 100, rows=2)
    assert prev["columns"] == ["t", "u", "y"] and prev["n_rows"] == 12 and len(prev["rows"]) == 2
    with pytest.raises(CSVError) as e:
        D.recording_from_csv("t,u,y\n" + rows + "12,x,1\n")
    assert e.value.line == 14 and e.value.column_index == 1
    with pytest.raises(CSVError, match="zz"):
        D.recording_from_csv("t,u,y\n" + rows, u_col="zz")


def test_exports_use_the_core_parameter_set() -> None:
    from core.paramset import FORMAT

    m = PIModel.from_dict(S.EXAMPLE1)
    name, payload = E.export_bytes(m, "json", "abc")
    doc = json.loads(payload)
    assert name == "hysteresis-pi-abc.json" and doc["format"] == FORMAT
    assert E.parameter_set_model(doc).to_dict() == m.to_dict()
    assert E.parameter_set_model(S.EXAMPLE1).to_dict() == m.to_dict()  # a bare model
    name, c = E.export_bytes(m, "c")
    assert b"hyst_inv_step" in c and b"hyst_fwd_step" in c
    with pytest.raises(ParameterError, match="format"):
        E.export_bytes(m, "xls")


def test_chunked_contributions_match_the_full_matrix() -> None:
    m = PIModel(0.5, [0.3, 0.8, 1.9], [0.4, 0.3, 0.2], [0.1, -0.2, 0.3])
    t = np.linspace(0, 5, 47_001)
    u = 3 * np.sin(2 * np.pi * 3 * t) * np.exp(-0.3 * t)
    idx, c = C.operator_contributions(m, u)
    np.testing.assert_allclose(c, (m.operator_outputs(u) * m.weights)[idx], atol=1e-12)


def test_decimate_keeps_reversals() -> None:
    t = np.linspace(0, 1, 20_000)
    u = np.sin(2 * np.pi * 7 * t)
    idx = F.decimate_index(u, 500)
    assert idx[0] == 0 and idx[-1] == u.size - 1 and idx.size < 700
    turns = np.flatnonzero(np.diff(np.sign(np.diff(u))) != 0) + 1
    assert set(turns) <= set(idx)


def test_typed_arrays_round_trip_and_figures_validate() -> None:
    res = C.compute(S.Config(signal=S.SignalSpec(samples=3000)))
    for name in F.FIGURES:
        fig = F.build(name, res)
        go.Figure(fig.to_dict())
    loop = F.loop_figure(res).to_dict()["data"][0]
    np.testing.assert_allclose(F.values(loop["x"]), res.u[F.decimate_index(res.u)], rtol=1e-6)
    ops = F.operators_figure(res).to_dict()
    assert len(ops["data"]) == 6 + 2  # p0 u, six operators, the sum
    with pytest.raises(KeyError):
        F.build("nope", res)


def test_session_services_store_fit_export_and_clear() -> None:
    from core.recordings import Recording

    s = SS.Session(code="abc")
    t = np.arange(600) * 1e-3
    u = 3 * np.sin(2 * np.pi * 3 * t)
    rec = Recording(t, u, PIModel.from_dict(S.EXAMPLE1)(u))
    D.store_recording(s, rec)
    model, report = FT.fit_session(s, 6)
    assert s.fitted == s.config.model == model.to_dict() and report["nrmse_percent"] < 2
    _, payload = E.export_session(s, "json")
    assert json.loads(payload)["provenance"]["fit"]["kind"] == "pi"  # the fit travels along
    D.store_recording(s, rec)
    assert s.fitted is s.fit_report is s.diagnosis is s.diagnosis_result is None
