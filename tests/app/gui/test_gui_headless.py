"""The viser GUI without a browser: handles driven on the server (callbacks fire inline)."""

from __future__ import annotations

import html
import importlib.util
import io
import json
import shutil
import threading
import time
import zipfile
from collections.abc import Iterator
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from app.gui.controller import SessionView
from app.gui.render import LatestWinsWorker
from app.gui.text import diagnosis_markdown, md_text
from app.services.explore import figures as F
from app.services.session.sessions import SessionRegistry
from app.services.settings import Settings
from core.pi import PIModel


@pytest.fixture(scope="module")
def server() -> Iterator[Any]:
    import viser

    s = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield s
    s.stop()


@pytest.fixture
def view(server: Any) -> Iterator[SessionView]:
    reg = SessionRegistry()
    downloads: list[tuple[str, bytes]] = []
    toasts: list[tuple[str, str, bool]] = []
    v = SessionView(server.gui, reg, reg.create(), Settings(), notify=lambda *a: toasts.append(a),
                    download=lambda n, b: downloads.append((n, b)), scene=server.scene)
    v.downloads, v.toasts = downloads, toasts  # type: ignore[attr-defined]
    assert v.worker.wait_idle(30)
    yield v
    v.close()


def _idle(v: SessionView) -> None:
    assert v.worker.wait_idle(30)


def _md(handle: Any) -> str:
    """A markdown handle's text without the escapes of md_text."""
    return html.unescape(handle.content.replace("\\", ""))


def _loop_y(v: SessionView) -> np.ndarray:
    assert v.shown_figure == "loop"
    return F.values(v.ui.plot.figure.data[0]["y"])


def test_opens_on_example1_with_loop_drawn(view: SessionView) -> None:
    assert view.rendered_version == 0
    m = PIModel.from_dict(view.session.config.model)
    assert m.p0 == 0.72 and m.n == 6
    res = view.last_result
    assert res is not None
    np.testing.assert_allclose(res.y, m(res.u))
    assert "1.518" in view.ui.model_md.content  # max loop width of Example 1
    assert res.digitized is not None and "digits" in view.ui.digi_md.content


def test_slider_updates_session_and_plot(view: SessionView) -> None:
    before = _loop_y(view)
    view.ui.param_sliders["weights[0]"].value = 1.2
    _idle(view)
    assert view.session.config.model["weights"][0] == 1.2
    assert view.rendered_version == view.session.version
    # the loop's top (an extremum: drawn exactly, however few samples the line is cut to)
    assert not np.isclose(before.max(), _loop_y(view).max())


def test_a_slider_move_checks_its_config_once(view: SessionView,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """One move of a slider checks the new config once: its rules, its model built from the
    document, its cost, the operator limit and the signal each once (they were three checks,
    the operator limit twice), and the document is not copied whole through JSON: what the
    move did not touch is shared with the previous model, which stays as it was."""
    import app.services.explore.controls as C
    import app.services.explore.cost as cost
    import app.services.explore.simulation as sim
    import core.base
    from app.services.explore.config import SignalSpec

    here = threading.get_ident()  # the callbacks fire inline; the render thread is not counted
    calls: dict[str, int] = {}

    def counting(owner: Any, name: str) -> None:
        real = getattr(owner, name)

        def count(*args: Any, **kwargs: Any) -> Any:
            if threading.get_ident() == here:
                calls[name] = calls.get(name, 0) + 1
            return real(*args, **kwargs)
        monkeypatch.setattr(owner, name, count)

    for owner, name in [(C, "check_rules"), (cost, "check_document"), (cost, "check_model"),
                        (core.base, "model_from_dict"), (sim, "operator_count"),
                        (SignalSpec, "validate")]:
        counting(owner, name)
    before = view.session.config.model
    view.ui.param_sliders["weights[0]"].value = 1.2
    _idle(view)
    after = view.session.config.model
    assert after["weights"][0] == 1.2 and before["weights"][0] != 1.2
    assert calls == {"check_rules": 1, "check_document": 1, "check_model": 1,
                     "model_from_dict": 1, "operator_count": 1, "validate": 1}, calls
    assert after["thresholds"] is before["thresholds"]  # shared, not copied through JSON


def test_threshold_past_its_neighbour_stops_short_of_it(view: SessionView) -> None:
    """Dragging r3 past r4 (1.8) keeps it one step below r4 and says so with the slider's
    labels; the next slider still applies (no bad value is left behind)."""
    r3 = view.ui.param_sliders["thresholds[2]"]
    assert r3.label == "r3"
    r3.value = 3.345
    _idle(view)
    assert view.session.config.model["thresholds"][2] == pytest.approx(1.799)
    assert r3.value == pytest.approx(1.799)
    assert "r3 stops at 1.799, just below r4 = 1.8" in _md(view.ui.params_md)
    assert "thresholds[" not in _md(view.ui.params_md)
    view.ui.param_sliders["weights[0]"].value = 0.5
    _idle(view)
    assert view.session.config.model["weights"][0] == 0.5
    assert json.loads(view.ui.json_in.value)["weights"][0] == 0.5  # the JSON box follows
    view.ui.param_sliders["thresholds[0]"].value = -1.0  # r1 must stay > 0: said so
    _idle(view)
    assert view.session.config.model["thresholds"][0] == pytest.approx(0.001)
    assert "r1 stops at 0.001: it must be > 0" in _md(view.ui.params_md)


def test_refused_change_puts_sliders_back(view: SessionView,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """A change the rules do not catch but the model refuses (simulated by letting the
    clamp pass everything) puts the sliders back at the stored model: the next move
    applies."""
    from app.services.explore import controls as C

    monkeypatch.setattr(C, "clamp", lambda doc, path, value, controls=None: C.Clamped(value))
    r3 = view.ui.param_sliders["thresholds[2]"]
    r3.value = 3.3
    _idle(view)
    assert "Not applied" in _md(view.ui.params_md) and "r4" in _md(view.ui.params_md)
    assert view.session.config.model["thresholds"][2] == 1.35 and r3.value == 1.35
    view.ui.param_sliders["p0"].value = 0.9
    _idle(view)
    assert view.session.config.model["p0"] == 0.9


def test_non_invertible_weights_message(view: SessionView) -> None:
    view.ui.param_sliders["p0"].value = -0.2
    _idle(view)
    assert "not invertible" in view.ui.inverse_md.content
    view.ui.view_dd.value = "Inverse"
    _idle(view)
    assert view.shown_figure == "inverse"
    assert "not invertible" in json.dumps(view.ui.plot.figure.layout)


def test_operator_count_rebuilds_sliders(view: SessionView) -> None:
    view.ui.n_ops.value = 12
    _idle(view)
    assert sum(p.startswith("thresholds[") for p in view.ui.param_sliders) == 12
    assert len(view.session.config.model["weights"]) == 12
    view.ui.n_ops.value = 10_000  # beyond the limit: set to it, and said so
    _idle(view)
    top = view.settings.max_operators
    assert len(view.session.config.model["weights"]) == top and view.ui.n_ops.value == top
    assert f"at most {top} operators: n is set to {top}" in _md(view.ui.params_md)


def test_store_to_gui_sync_without_write_back(view: SessionView) -> None:
    v0 = view.session.version
    view.session.update(lambda c: c.with_model({"type": "pi", "p0": 1.1, "thresholds": [1.0, 2.0],
                                                "weights": [0.3, 0.2]}))
    _idle(view)
    assert view.ui.param_sliders["p0"].value == pytest.approx(1.1)
    assert sum(p.startswith("weights[") for p in view.ui.param_sliders) == 2
    assert view.session.version == v0 + 1  # the sync did not write back


def _upload_pi(v: SessionView, samples: int) -> None:
    """Upload a recording of a known PI model (1 kHz, 3 Hz sine of amplitude 3)."""
    t = np.arange(samples) * 1e-3
    u = 3 * np.sin(2 * np.pi * 3 * t)
    y = PIModel(0.7, [0.5, 1.0], [0.5, 0.4])(u)
    text = "t,u,y\n" + "\n".join(f"{a},{b},{c}" for a, b, c in zip(t, u, y, strict=True))
    v.ui.upload._impl.value = SimpleNamespace(name="m.csv", content=text.encode())
    v._csv_uploaded(SimpleNamespace(target=v.ui.upload, client=None))


def test_csv_fit_diagnose_export(view: SessionView) -> None:
    _upload_pi(view, 800)
    assert "800 samples" in view.ui.data_md.content
    view.ui.fit_n.value = 6
    view._fit_clicked(SimpleNamespace(client=None))
    assert "RMS error" in view.ui.report_md.content
    _idle(view)
    assert view.shown_figure == "fit" and "Fit overlay" in view.ui.plot.figure.to_json()
    view._diagnose_clicked(SimpleNamespace(client=None))
    assert "Diagnosis" in view.ui.report_md.content
    view._report_clicked(SimpleNamespace(client=None))
    assert view.downloads[-1][0].endswith(".html")  # type: ignore[attr-defined]
    view._export(SimpleNamespace(client=None), "json")
    name, payload = view.downloads[-1]  # type: ignore[attr-defined]
    assert name.endswith(".json") and "model" in json.loads(payload)
    if shutil.which("gcc") and importlib.util.find_spec("fmpy"):  # the FMU menu
        view.ui.fmi.value = "2.0"
        view._export(SimpleNamespace(client=None), "fmu", True)
        name, payload = view.downloads[-1]  # type: ignore[attr-defined]
        assert name.endswith("-compensator-fmi2.fmu") and payload[:2] == b"PK"
        with zipfile.ZipFile(io.BytesIO(payload)) as zf:
            assert 'fmiVersion="2.0"' in zf.read("modelDescription.xml").decode()


def test_bad_csv_message(view: SessionView) -> None:
    view.ui.upload._impl.value = SimpleNamespace(name="bad.csv", content=b"t,u,y\n0,1,x\n")
    view._csv_uploaded(SimpleNamespace(target=view.ui.upload, client=None))
    md = view.ui.data_md.content
    assert "line 2" in md and md_text("'y' (column 2)") in md


def test_markup_in_csv_name_and_cells_is_text(view: SessionView) -> None:
    evil = "<img src=x onerror=alert(1)>"
    view.ui.upload._impl.value = SimpleNamespace(name=f"{evil}.csv",
                                              content=f"t,u,y\n0,1,{evil}\n".encode())
    view._csv_uploaded(SimpleNamespace(target=view.ui.upload, client=None))
    assert "<img" not in view.ui.data_md.content and "&lt;img" in view.ui.data_md.content
    rows = "\n".join(f"{k * 1e-3},{np.sin(k / 9)},{np.sin(k / 9)}" for k in range(50))
    view.ui.upload._impl.value = SimpleNamespace(name=f"{evil}.csv",
                                              content=f"t,{evil},y\n{rows}\n".encode())
    view._csv_uploaded(SimpleNamespace(target=view.ui.upload, client=None))
    assert view.session.recording is not None
    assert "<img" not in view.ui.data_md.content and "&lt;img" in view.ui.data_md.content


def test_deadzone_operators_stack_on_the_dead_zoned_input(view: SessionView) -> None:
    from app.services.explore.simulation import preset_doc

    view.session.update(lambda c: c.with_model(preset_doc("paper001-example4")["model"]))
    view.ui.view_dd.value = "Operators"
    _idle(view)
    fig = view.ui.plot.figure
    parts = [F.values(t["y"]) for t in fig.data if t.get("stackgroup")]
    total = next(F.values(t["y"]) for t in fig.data if t["name"] == "y (sum)")
    np.testing.assert_allclose(np.sum(parts, axis=0), total, atol=1e-4 * np.ptp(total))


def test_digitized_preset_input_spans_its_loop_and_steps(view: SessionView) -> None:
    title = next(t for t, n in view._preset_names.items() if n == "paper000-three-operators")
    view.ui.preset.value = title
    view._preset_clicked(SimpleNamespace(client=None))
    view.ui.view_dd.value = "Digitized states"
    _idle(view)
    sig = view.session.config.signal
    assert sig.offset - sig.amplitude < 0 and sig.offset + sig.amplitude > 10  # 0…10 spanned
    last = int(view.ui.digi_step.value)
    view._step_by(-1)
    assert int(view.ui.digi_step.value) == last - 1
    assert f"State {last - 1}/" in view.ui.digi_md.content
    # the figure's current-state marker follows the step
    cur = next(t for t in view.ui.plot.figure.data if t["name"] == "current state")
    tr = view.last_result.digitized.trace
    assert cur["x"] == [float(tr.x_b[last - 1])]


def test_join_other_session(view: SessionView) -> None:
    other = view.registry.create()  # codes are made by the server only (issue 10)
    view.ui.code_in.value = other.code.upper()
    view._join_clicked(SimpleNamespace(client=None))
    _idle(view)
    assert view.session is other
    n = len(view.registry)
    for typed in ("room-42", "abcd-efgh-jkmn-pqrs"):  # malformed, well-formed but unknown
        view.ui.code_in.value = typed
        view._join_clicked(SimpleNamespace(client=None))
        title, body, error = view.toasts[-1]
        assert title == "No such session" and error, view.toasts[-1]
        assert "3-32" not in body and "abcd-efgh-jkmn-pqrs" in body and "expired" in body
        assert view.session is other  # refused, never a blank new session
    assert len(view.registry) == n
    for _ in range(25):  # unknown codes are rate-limited, as on the REST API
        view._join_clicked(SimpleNamespace(client=None))
    assert "too many" in view.toasts[-1][1]


def test_join_shows_the_sessions_preset(view: SessionView) -> None:
    """A view joining a session that holds Example 4 shows that preset, not the first one;
    a model changed since names no preset (the dropdown keeps what it showed)."""
    from app.services.session import actions

    other = view.registry.create()
    actions.load_preset(other, "paper001-example4", with_input=True)
    title = next(t for t, n in view.ui.preset_names.items() if n == "paper001-example4")
    assert view.ui.preset.value != title
    view.ui.code_in.value = other.code
    view._join_clicked(SimpleNamespace(client=None))
    _idle(view)
    assert view.session is other and view.ui.preset.value == title
    assert "dead zones" in view.ui.preset_md.content
    changed = dict(other.config.model, p0=0.5)
    assert actions.matching_preset(changed) is None


def test_generic_parameter_sliders_for_gpi(view: SessionView) -> None:
    from app.services.explore.simulation import preset_doc

    doc = preset_doc("paper001-example4")
    view.session.update(lambda c: c.with_model(doc["model"]))
    _idle(view)
    assert not view.ui.pi_folder.visible and view.ui.param_folder.visible
    # the GPI's plays are counted (not "? operators", "n = ?")
    assert "6 operators" in view.ui.model_md.content
    assert "n = 6" in json.dumps(view.ui.plot.figure.layout)
    h = view.ui.param_sliders["pi.p0"]
    h.value = 0.8
    _idle(view)
    assert view.session.config.model["pi"]["p0"] == 0.8
    # the dead zones are numbered around rho_0 = 0, which is a constant; a dead-zone
    # threshold dragged past its neighbour stops one step short of it
    assert view.ui.param_sliders["deadzone.thresholds[0]"].label == "ρ-11"
    assert view.ui.param_sliders["deadzone.thresholds[11]"].disabled
    view.ui.param_sliders["deadzone.thresholds[0]"].value = 2.9
    _idle(view)
    assert view.session.config.model["deadzone"]["thresholds"][0] == pytest.approx(-2.751)
    assert "ρ-11 stops at -2.751, just below ρ-10 = -2.75" in _md(view.ui.params_md)


def test_teacher_push_reaches_other_sessions(view: SessionView) -> None:
    other = view.registry.create()
    view.settings = Settings(teacher_token="s3cret")
    view.ui.param_sliders["p0"].value = 1.3
    _idle(view)
    view.ui.teacher_token.value = "s3cret"
    view._push_clicked(SimpleNamespace(client=None))
    assert other.config.model["p0"] == 1.3


def test_teacher_push_needs_the_token_also_on_loopback(view: SessionView) -> None:
    """Another page the teacher opens on this computer must not push to every session: a
    loopback server without a teacher token cannot push from the GUI, and one with a token
    needs it; a tab that gave it once keeps it (on loopback only), a wrong one forgets it."""
    other = view.registry.create()
    view.ui.param_sliders["p0"].value = 1.2
    _idle(view)
    view._push_clicked(SimpleNamespace(client=None))  # Settings(): loopback, no token
    assert other.config.model["p0"] != 1.2
    assert view.toasts[-1][0] == "Not pushed" and "--teacher-token-file" in view.toasts[-1][1]
    view.settings = Settings(teacher_token="s3cret")
    view._push_clicked(SimpleNamespace(client=None))
    assert other.config.model["p0"] != 1.2 and not view.teacher
    view.ui.teacher_token.value = "s3cret"
    view._push_clicked(SimpleNamespace(client=None))
    assert other.config.model["p0"] == 1.2 and view.teacher
    view.ui.param_sliders["p0"].value = 1.4
    _idle(view)
    view._push_clicked(SimpleNamespace(client=None))  # remembered: the field stays empty
    assert other.config.model["p0"] == 1.4
    view.ui.teacher_token.value = "wrong"
    view._push_clicked(SimpleNamespace(client=None))
    assert not view.teacher and view.toasts[-1][0] == "Not pushed"
    public = Settings(host="0.0.0.0", teacher_token="s3cret")
    view.settings = public
    view.ui.teacher_token.value = "s3cret"
    view._push_clicked(SimpleNamespace(client=None))
    assert view.toasts[-1][0] == "Pushed" and not view.teacher  # a projector: every time


def test_teacher_push_checks_the_token_with_teacher_ok(view: SessionView,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """The GUI's push uses Settings.teacher_ok (constant time) and the REST rule: a public
    server without a token refuses."""
    calls: list[str | None] = []
    real = Settings.teacher_ok
    monkeypatch.setattr(Settings, "teacher_ok",
                        lambda self, tok: calls.append(tok) or real(self, tok))
    other = view.registry.create()
    view.ui.param_sliders["p0"].value = 1.1
    _idle(view)
    for settings, token, pushed in ((Settings(teacher_token="s3cret"), "nope", False),
                                    (Settings(teacher_token="s3cret"), "", False),
                                    (Settings(host="0.0.0.0"), "", False),
                                    (Settings(teacher_token="s3cret"), "s3cret", True)):
        view.settings = settings
        view.ui.teacher_token.value = token
        view._push_clicked(SimpleNamespace(client=None))
        assert view.ui.teacher_token.value == ""  # never left on a projector
        assert (other.config.model["p0"] == 1.1) is pushed, (settings, token)
        assert view.toasts[-1][0] == ("Pushed" if pushed else "Not pushed")
    # each typed token is checked twice: typing it (a right one shows the teacher's
    # buttons) and pressing the push
    assert calls == ["nope", "nope", None, "s3cret", "s3cret"]


def test_diagnosis_markdown() -> None:
    from types import SimpleNamespace

    from app.services.analysis.diagnosis import DiagnosisSummary

    md = diagnosis_markdown(SimpleNamespace(  # type: ignore[arg-type]
        result=None, summary=DiagnosisSummary(("Found a delay.",), 0.5, None, ("delay",))))
    # the sentences only: no engine name, no field names (issue 19)
    assert "- Found a delay\\." in md and "core" not in md and "rmse" not in md


def test_latest_wins_worker_skips_stale_requests() -> None:
    import threading
    import time

    gate = threading.Event()
    calls: list[int] = []
    state = {"v": 0}

    def render() -> None:
        calls.append(state["v"])
        gate.wait(5)

    w = LatestWinsWorker(render)
    w.request()
    time.sleep(0.05)
    for v in range(1, 50):
        state["v"] = v
        w.request()
    gate.set()
    assert w.wait_idle(5)
    w.stop()
    assert calls[0] == 0 and calls[-1] == 49 and len(calls) <= 3


def test_recording_units_label_the_axes(view: SessionView) -> None:
    rows = "\n".join(f"{k * 1e-3},{3 * np.sin(k / 20)},{2 * np.sin(k / 20)}" for k in range(300))
    view.ui.upload._impl.value = SimpleNamespace(
        name="piezo.csv", content=f"t [s],u [V],y [µm]\n{rows}\n".encode())
    view._csv_uploaded(SimpleNamespace(target=view.ui.upload, client=None))
    assert view.session.recording is not None
    assert view.session.recording.units["input"] == "V"
    _idle(view)
    lay = view.ui.plot.figure.layout
    assert lay["xaxis"]["title"]["text"] == "input u [V]"
    assert lay["yaxis"]["title"]["text"] == "output y [µm]"
    assert "| u [V] |" in view.ui.data_md.content


def test_second_fit_while_one_runs_is_refused(view: SessionView) -> None:
    rows = "\n".join(f"{k * 1e-3},{3 * np.sin(k / 20)},{2 * np.sin(k / 20)}" for k in range(300))
    view.ui.upload._impl.value = SimpleNamespace(name="r.csv", content=f"t,u,y\n{rows}\n".encode())
    view._csv_uploaded(SimpleNamespace(target=view.ui.upload, client=None))
    view._work_lock.acquire()  # a diagnosis is running
    try:
        view._guarded(view._fit_clicked)(SimpleNamespace(client=None))
    finally:
        view._work_lock.release()
    assert view.session.fitted is None
    assert any("already running" in body for _, body, _ in view.toasts)
    view._guarded(view._fit_clicked)(SimpleNamespace(client=None))
    assert view.session.fitted is not None and not view.ui.fit_btn.disabled


def test_fit_is_a_killable_job_with_progress_and_cancel(
        server: Any, tmp_path: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    """A fit from viser is a job of the job manager (the REST API's), in a worker process:
    a session already running a job is refused in words for the user; the fit's progress
    shows under the buttons; Cancel kills its worker at once and the session keeps the
    fit it had (before: the fit ran in the server process, with neither)."""
    from app.services.jobs import tasks
    from app.services.jobs.manager import JobManager
    from app.services.jobs.worker import Task
    from tests.app import job_work

    jobs = JobManager(max_workers=1)
    reg = SessionRegistry()
    toasts: list[tuple[str, str, bool]] = []
    v = SessionView(server.gui, reg, reg.create(), Settings(),
                    notify=lambda *a: toasts.append(a), jobs=jobs)
    try:
        _upload_pi(v, 600)
        code = v.session.code
        v.ui.fit_n.value = 4
        v._guarded(v._fit_clicked)(SimpleNamespace(client=None))  # a real fit, as a job
        first = v.session.fitted
        assert first is not None and "RMS error" in v.ui.report_md.content
        assert [(j.kind, j.state) for j in jobs.recent(code)] == [("fit", "done")]

        gate = tmp_path / "go"  # a job started elsewhere (the REST API) is running
        other = jobs.submit(code, "diagnose", Task(job_work.until_file, (str(gate),)))
        v._guarded(v._fit_clicked)(SimpleNamespace(client=None))
        assert any("already has a fit or diagnosis running" in body for _, body, _ in toasts)
        assert not any("job" in body for _, body, _ in toasts)  # the manager's word
        jobs.cancel(code, other.id)

        monkeypatch.setattr(tasks, "run_fit", job_work.stalled_fit)
        v.ui.fit_n.value = 5
        clicked = threading.Thread(target=v._guarded(v._fit_clicked),
                                   args=(SimpleNamespace(client=None),))
        clicked.start()
        deadline = time.monotonic() + 60
        while not (jobs.workers() and v.ui.job_bar.value >= 50):
            assert time.monotonic() < deadline, "the fit reported no progress"
            time.sleep(0.05)
        [pid] = jobs.workers()
        job = jobs.recent(code)[0]
        assert (job.kind, job.state) == ("fit", "running") and job.worker is not None
        assert v.ui.cancel_btn.visible and v.ui.cancel_btn.label == "Cancel the fit"
        assert "fitting… 50 %" in v.ui.report_md.content
        # a long run says how long it has left (issue 31), from the job's cost-model estimate
        job.expected_s = 600.0
        deadline = time.monotonic() + 30
        while "min left" not in v.ui.report_md.content:
            assert time.monotonic() < deadline, v.ui.report_md.content
            time.sleep(0.05)
        v._guarded(v._cancel_clicked)(SimpleNamespace(client=None))
        assert job.state == "cancelled" and jobs.running() == 0  # the slot is free now
        job_work.wait_gone(pid)
        clicked.join(30)
        assert not clicked.is_alive()
        assert v.session.fitted == first
        assert "Fit cancelled" in v.ui.report_md.content
        assert not v.ui.cancel_btn.visible and not v.ui.fit_btn.disabled
    finally:
        v.close()
        jobs.cancel_all()


def test_creep_time_constants_move_in_log10_in_viser(view: SessionView) -> None:
    """viser's creep τ sliders move in log10 of the value (decades marked): τ1 = 0.01 s sits
    at -2; moved to -2.5 the stored value is 10^-2.5 s and the note says it in seconds; past
    the left end the strict limit τ > 0 still holds."""
    view.session.update(lambda c: c.with_model(
        {"type": "creep", "taus_s": [0.01, 0.1, 1.0], "weights": [0.02, 0.02, 0.02]}))
    _idle(view)
    t1 = view.ui.param_sliders["taus_s[0]"]
    assert t1.value == pytest.approx(-2.0) and t1.min == pytest.approx(-3.0)
    t1.value = -2.5
    _idle(view)
    assert view.session.config.model["taus_s"][0] == pytest.approx(10 ** -2.5, rel=5e-3)
    assert "τ1 = 0.00316 s" in _md(view.ui.params_md)
    assert view.ui.param_sliders["weights[0]"].value == pytest.approx(0.02)  # linear


def _running_job(jobs: Any, code: str) -> tuple[Any, int]:
    """The session's running job and its worker's pid, once it has reported progress."""
    deadline = time.monotonic() + 60
    while True:
        job = next(iter(jobs.recent(code)), None)
        pids = jobs.workers()
        if job is not None and job.state == "running" and pids and job.progress > 0:
            return job, pids[0]
        assert time.monotonic() < deadline, "the diagnosis reported no progress"
        time.sleep(0.02)


def test_diagnosis_is_a_killable_job_and_a_closed_tab_cancels_it(server: Any) -> None:
    """A diagnosis from viser is a job of the job manager in a worker process (issue 18):
    its progress shows under the buttons, Cancel kills the worker at once (the job is
    ``cancelled`` and its slot free when Cancel returns) and nothing is stored; a tab
    closed during a diagnosis cancels it too; a diagnosis left to finish shows its
    findings. Before, the diagnosis ran in the server process and stopped only at its next
    progress report (9 s measured), and a closed tab's diagnosis ran on."""
    from app.services.jobs.manager import JobManager
    from tests.app import job_work

    jobs = JobManager(max_workers=1)
    reg = SessionRegistry()
    v = SessionView(server.gui, reg, reg.create(), Settings(), jobs=jobs)
    try:
        _upload_pi(v, 60_000)  # a long recording: the diagnosis runs for many seconds
        code = v.session.code
        clicked = threading.Thread(target=v._guarded(v._diagnose_clicked),
                                   args=(SimpleNamespace(client=None),))
        clicked.start()
        job, pid = _running_job(jobs, code)
        assert job.kind == "diagnose" and job_work.alive(pid)
        assert v.ui.cancel_btn.visible and v.ui.cancel_btn.label == "Cancel the diagnosis"
        deadline = time.monotonic() + 30
        while "diagnosing…" not in v.ui.report_md.content:  # its progress, under the buttons
            assert time.monotonic() < deadline, v.ui.report_md.content
            time.sleep(0.02)
        v._guarded(v._cancel_clicked)(SimpleNamespace(client=None))
        assert job.state == "cancelled" and jobs.running() == 0  # the slot is free now
        job_work.wait_gone(pid)
        clicked.join(30)
        assert not clicked.is_alive()
        assert v.session.diagnosis is None and v.session.diagnosis_result is None
        assert "Diagnosis cancelled" in v.ui.report_md.content
        assert not v.ui.cancel_btn.visible and not v.ui.diag_btn.disabled

        clicked = threading.Thread(target=v._guarded(v._diagnose_clicked),
                                   args=(SimpleNamespace(client=None),))
        clicked.start()
        job, pid = _running_job(jobs, code)
        v.close()  # the tab closes
        assert job.state == "cancelled" and jobs.running() == 0
        job_work.wait_gone(pid)
        clicked.join(30)
        assert not clicked.is_alive() and v.session.diagnosis is None
    finally:
        v.close()

    w = SessionView(server.gui, reg, reg.create(), Settings(), jobs=jobs)
    try:
        _upload_pi(w, 800)
        w._guarded(w._diagnose_clicked)(SimpleNamespace(client=None))
        assert [(j.kind, j.state) for j in jobs.recent(w.session.code)] == [("diagnose", "done")]
        findings = w.session.diagnosis.summary.findings
        assert findings and _md(w.ui.report_md).startswith("### Diagnosis")
        assert all(str(f).replace("\\", "")[:40] in _md(w.ui.report_md) for f in findings)
        assert w.session.diagnosis_result is not None and not w.ui.report_btn.disabled
    finally:
        w.close()
        jobs.cancel_all()


def _csv(v: SessionView, name: str, header: str, rows: int = 200) -> None:
    t = np.arange(rows) * 1e-3
    u = 2 * np.sin(2 * np.pi * 5 * t)
    text = header + "\n" + "\n".join(f"{a},{b},{0.5 * b}" for a, b in zip(t, u, strict=True))
    v.ui.upload._impl.value = SimpleNamespace(name=name, content=text.encode())
    v._csv_uploaded(SimpleNamespace(target=v.ui.upload, client=None))


def test_the_column_fields_show_the_columns_the_reader_chose(view: SessionView) -> None:
    """Issue 33: after mapping the columns itself the tab showed empty column fields. They
    hold the file's header names now; a new file is mapped afresh (the names filled in for
    the last one go), a name typed by hand stays and is used."""
    ui = view.ui
    _csv(view, "a.csv", "time_s,drive_V,disp_um")
    assert (ui.t_col.value, ui.u_col.value, ui.y_col.value) == ("time_s", "drive_V", "disp_um")
    _csv(view, "b.csv", "t,volts,microns")
    assert view.session.recording is not None and view.session.recording.name.startswith("b")
    assert (ui.t_col.value, ui.u_col.value, ui.y_col.value) == ("t", "volts", "microns")
    ui.u_col.value, ui.y_col.value = "microns", "volts"  # typed: input and output swapped
    _csv(view, "b2.csv", "t,volts,microns")
    rec = view.session.recording
    assert (ui.u_col.value, ui.y_col.value) == ("microns", "volts")
    assert rec is not None and np.allclose(rec.y, 2 * rec.u)  # the swap was used
