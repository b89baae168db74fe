"""The viser GUI's controller: one tab's widgets bound to one session through the services.

Every browser tab gets its own controls (``client.gui``, see :mod:`app.gui.layout`), so
students never see each other's changes. A :class:`SessionView` is bound to a
:class:`~app.services.session.sessions.Session`; typing another code re-binds it (that is how a
student comes back after a reload, or how REST changes and teacher pushes reach the GUI).
Control callbacks call :mod:`app.services.session.actions` (the transitions the REST routers
call too); session changes from any source are pushed back into the controls under a
re-entrancy guard and drawn by a :class:`~app.gui.render.LatestWinsWorker`, which computes
only the view on show. The 3D state cube is :mod:`app.gui.scene`, the digitized playback
:mod:`app.gui.playback`.
"""

from __future__ import annotations

import json
import os
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Mapping
from contextlib import AbstractContextManager, contextmanager, nullcontext
from dataclasses import replace
from typing import Any

import numpy as np

from app.services.analysis import upload_check
from app.services.analysis.fitting import FitResult
from app.services.analysis.recordings import Timing, UnevenUpload, seconds_text
from app.services.errors import DamagedSessionError, ParameterError, QuotaError
from app.services.explore import controls as C
from app.services.explore import figures as F
from app.services.explore.config import Config
from app.services.explore.simulation import Result, inverse_problem, operator_count
from app.services.guard.jsonbody import read_document
from app.services.guard.ratelimit import RateLimiter
from app.services.jobs.manager import Job, JobBusy, JobManager, JobView
from app.services.jobs.tasks import diagnose_task, fit_task
from app.services.jobs.worker import OutOfMemory, Task, Worker, WorkerDied
from app.services.session import actions
from app.services.session.sessions import Session, SessionRegistry
from app.services.settings import Settings
from app.services.teaching import lessons
from app.services.teaching.events import HUB
from app.services.words import type_words

from .layout import PANEL_PX, PHONE_PLOT_PX, PROJECTOR_PX, TITLES, Widgets, set_value
from .lesson import LessonPanel
from .playback import Playback
from .render import LatestWinsWorker
from .scene import CUBE_MAX_DIGITS, StateCube
from .text import (
    diagnosis_markdown,
    inverse_markdown,
    md_text,
    model_markdown,
    recording_markdown,
    state_markdown,
)

__all__ = ["SessionView"]


def _busy_text(message: str) -> str:
    """The job manager's refusal in the GUI's words."""
    if message.startswith("this session already has"):
        return ("this session already has a fit or diagnosis running (perhaps from another "
                "tab or the web page): wait for it or cancel it")
    return message

#: Plot height / width of each view in the floating panel.
ASPECT = {"inverse": 0.5, "fit": 0.5, "digitized": 1.0, "closed-loop": 0.75}
#: Plot height / width in projector mode (a 1200 px wide plot fits a 1080 px high screen).
PROJECTOR_ASPECT = 0.6
#: Shortest interval between two progress updates of a running diagnosis or fit, s.
PROGRESS_S = 0.3

_JOBS: JobManager | None = None
_JOBS_LOCK = threading.Lock()


def _default_jobs() -> JobManager:
    """The job manager of views built without one (a GUI without the REST app's)."""
    global _JOBS
    with _JOBS_LOCK:
        if _JOBS is None:
            _JOBS = JobManager()
        return _JOBS
#: Shortest interval between two redraws of the digitized figure during playback, s.
STATE_REDRAW_S = 0.1
#: Heavy views computing in worker processes at once, for every tab of the server together
#: (the REST API's figure workers are bounded the same way: one per core, at least 2).
GUI_FIGURE_SLOTS = threading.BoundedSemaphore(max(2, os.cpu_count() or 2))
#: After a lesson's move, the step's text leaves for the tab on its own (flushed) at least
#: this long before the step's plot, s: viser applies a batch of GUI messages as it comes,
#: so the text is committed and painted before plotly's redraw takes the tab's main thread
#: (a class of thirty: the text waited on the plot's long tasks, issue 33).
TEXT_FIRST_S = 0.08
#: Width, CSS px, of the plot in the tab's *Expand plot* window (viser's "xl" modal): a
#: plot's lines are cut to the samples its largest showing draws (:meth:`SessionView._cut`).
EXPAND_PX = 780


def _ignore(fraction: float, message: str = "") -> None:
    """A progress report nobody shows (a view's worker)."""


class SessionView:
    """The controls and plots of one browser tab, bound to one session.

    Parameters
    ----------
    gui : viser.GuiApi
        ``client.gui`` (private to a tab) or ``server.gui`` (headless tests).
    registry : SessionRegistry
        Where sessions are looked up by code.
    session : Session
        The session shown first.
    settings : Settings
        Limits.
    notify : callable, optional
        ``notify(title, body, error)`` shows a toast (per client); ignored when ``None``.
    download : callable, optional
        ``download(filename, content)`` sends a file to this tab.
    scene, camera : optional
        The tab's 3D scene and camera (the digitized state cube).
    on_session : callable, optional
        ``on_session(code)`` is called with the code of each session the view shows (the
        explorer remembers it for the browser, so a reload keeps the session).

    Notes
    -----
    The widgets are :attr:`ui` (:class:`~app.gui.layout.Widgets`): ``view.ui.plot``.
    """

    def __init__(
        self,
        gui: Any,
        registry: SessionRegistry,
        session: Session,
        settings: Settings,
        notify: Callable[[str, str, bool], None] | None = None,
        download: Callable[[str, bytes], None] | None = None,
        scene: Any = None,
        camera: Any = None,
        on_session: Callable[[str], None] | None = None,
        jobs: JobManager | None = None,
        flush: Callable[[], None] | None = None,
        atomic: Callable[[], AbstractContextManager[Any]] | None = None,
    ) -> None:
        self.registry = registry
        self._flush = flush  # sends the tab's queued messages now (viser's client.flush)
        # groups the messages of one render into one batch the tab applies at once
        # (viser's client.atomic): one React commit instead of one per widget
        self._atomic = atomic if atomic is not None else nullcontext
        #: Cut each line of a plot to the samples its pixels draw (:meth:`_cut`).
        self.pixel_cut = True
        self._text_sent = 0.0  # when a lesson move's text was flushed (time.monotonic)
        #: runs this tab's fits in killable worker processes (the REST API's manager)
        self.jobs = jobs if jobs is not None else _default_jobs()
        self._job: Job | None = None  # the fit or diagnosis job running now
        self._on_session = on_session
        self.session = session
        self.settings = settings
        self.camera = camera
        self.ui = Widgets(gui, settings)
        self.cube = StateCube(scene, camera)
        self.playback = Playback(lambda: float(self.ui.play_speed.value), self._play_step)
        # failed joins of this tab, as the REST API limits unknown codes per client
        self._lookups = RateLimiter(burst=20, per_minute=20)
        #: This tab gave the right teacher token on a loopback server (kept for its pushes).
        self.teacher = False
        self._notify = notify
        self._download = download
        self._syncing = threading.local()
        self._lock = threading.RLock()
        self._work_lock = threading.Lock()
        self._cancel = threading.Event()  # set by Cancel or close: the running job is killed
        self._csv: tuple[str, str] | None = None  # (text, file name) of the last upload
        # the column names this tab filled in after the reader chose them ("": typed / none)
        self._filled_cols: tuple[str, ...] = ("", "", "")
        self._timing: Timing | None = None  # its uneven time stamps, while a choice is due
        self.fit_figure: F.FigureJSON | None = None
        self.rendered_version = -1
        self.last_result: Result | None = None
        self._figure_worker: Worker | None = None  # a heavy view's worker process, running
        self._closed = False
        self.shown_figure = ""
        self._shown_state = -1
        self._state_sent = 0.0
        self._wire()
        self.lesson = LessonPanel(self)  # the class's lesson (app/gui/lesson.py)
        self.worker = LatestWinsWorker(self._render, self._render_error, name=f"render-{id(self)}")
        session.add_listener(self._on_session_change)
        self._sync_controls(session.snapshot()[0])
        self._attend()
        self._redraw()

    @property
    def narrow(self) -> bool:
        """Whether the plot is in the control sheet (a phone) instead of the panel."""
        return self.ui.narrow

    @property
    def figure_name(self) -> str:
        """Key of the figure selected in the *View* dropdown."""
        return self.ui.figure_name

    @property
    def projecting(self) -> bool:
        """Whether the plot is at projector size (asked for, and not on a phone)."""
        return bool(self.ui.projector.value) and not self.ui.narrow

    @property
    def _preset_names(self) -> dict[str, str]:
        return self.ui.preset_names

    @property
    def _cube_points(self) -> np.ndarray | None:
        return self.cube.points

    # ------------------------------------------------------------------ wiring
    def _wire(self) -> None:
        ui = self.ui
        for h in (ui.mismatch, ui.amp, ui.freq, ui.offset, ui.duration, ui.samples, ui.kind,
                  ui.use_rec):
            h.on_update(self._guarded(self._controls_changed))
        ui.n_ops.on_update(self._guarded(self._n_changed))
        ui.projector.on_update(self._guarded(self._projector_changed))
        for dd in ui.view_dropdowns:
            dd.on_update(self._guarded(self._view_chosen))
        ui.digi_step.on_update(self._guarded(self._step_changed))
        ui.play_btn.on_click(self._guarded(self._play_clicked))
        ui.stop_btn.on_click(self._guarded(lambda ev: self.playback.stop()))
        ui.prev_btn.on_click(self._guarded(lambda ev: self._step_by(-1)))
        ui.next_btn.on_click(self._guarded(lambda ev: self._step_by(1)))
        ui.preset.on_update(self._guarded(self._preset_chosen))
        ui.load_preset.on_click(self._guarded(self._preset_clicked))
        ui.json_btn.on_click(self._guarded(self._json_clicked))
        ui.join_btn.on_click(self._guarded(self._join_clicked))
        ui.push_btn.on_click(self._guarded(self._push_clicked))
        ui.who_btn.on_click(self._guarded(self._who_clicked))
        ui.teacher_token.on_update(self._guarded(self._token_typed))
        ui.name_in.on_update(self._guarded(lambda ev: self._attend()))
        ui.upload.on_upload(self._guarded(self._csv_uploaded))
        ui.remap.on_click(self._guarded(self._remap_clicked))
        ui.timing_resample.on_click(self._guarded(lambda ev: self._load_csv("resample")))
        ui.timing_keep.on_click(self._guarded(lambda ev: self._load_csv("keep")))
        ui.fit_btn.on_click(self._guarded(self._fit_clicked))
        ui.diag_btn.on_click(self._guarded(self._diagnose_clicked))
        ui.cancel_btn.on_click(self._guarded(self._cancel_clicked))
        ui.report_btn.on_click(self._guarded(self._report_clicked))
        ui.ps_upload.on_upload(self._guarded(self._paramset_uploaded))
        for btn, fmt in ((ui.dl_json, "json"), (ui.dl_mat, "mat"), (ui.dl_c, "c")):
            btn.on_click(self._guarded(lambda ev, fmt=fmt: self._export(ev, fmt)))
        for btn, inv in ((ui.dl_fmu_inv, True), (ui.dl_fmu_fwd, False)):
            btn.on_click(self._guarded(lambda ev, inv=inv: self._export(ev, "fmu", inv)))

    def _guarded(self, fn: Callable[[Any], None]) -> Callable[[Any], None]:
        """Skip callbacks fired by our own store→GUI sync; report errors in the GUI."""

        def cb(event: Any) -> None:
            if getattr(self._syncing, "on", False):
                return
            try:
                fn(event)
            except (ParameterError, ValueError) as exc:
                self._toast("Not applied", str(exc), True)
            except Exception as exc:  # noqa: BLE001 - a GUI callback must never crash
                traceback.print_exc()
                self._toast("Unexpected error", repr(exc), True)

        return cb

    @contextmanager
    def _flag(self, name: str) -> Iterator[None]:
        """Raise this thread's flag ``name`` while the block runs."""
        setattr(self._syncing, name, True)
        try:
            yield
        finally:
            setattr(self._syncing, name, False)

    def _quiet(self) -> AbstractContextManager[None]:
        """Set widgets without their callbacks writing back."""
        return self._flag("on")

    def _toast(self, title: str, body: str, error: bool = False) -> None:
        if self._notify is not None:
            self._notify(title, body, error)

    def _view_chosen(self, event: Any) -> None:
        with self._quiet():  # the hidden dropdown takes the view when shown (set_narrow)
            set_value(self.ui.view_dd, event.target.value)
        self._redraw()

    def _projector_changed(self, event: Any) -> None:
        self.ui.use_projector(bool(self.ui.projector.value))
        self._redraw()

    def set_narrow(self, narrow: bool) -> None:
        """Show the plot in the control sheet (phones) or in the floating panel."""
        value = self.ui.view_dd.value
        if not self.ui.use_narrow(narrow):
            return
        with self._quiet():
            self.ui.view_dd.value = value
        self._redraw()

    # ------------------------------------------------------------------ session -> GUI
    def _on_session_change(self, session: Session, config: Config, version: int) -> None:
        if not getattr(self._syncing, "from_gui", False):
            self.ui.params_md.content = ""  # a note on the previous model's sliders
            # a lesson's move: its view before the one render of the new model, and its
            # text out first, alone, before the controls of the step's model (a new
            # model's sliders took a tab ~0.2 s to mount, the text waiting on them) and
            # before the plot the render sends
            if self.lesson.take_step_view(config):
                self._text_first()
            self._sync_controls(config)
        self._redraw()

    def _text_first(self) -> None:
        """Send what is queued for the tab (the Lesson folder's step, the controls) now:
        the render holds the step's plot back until :data:`TEXT_FIRST_S` after it."""
        self._text_sent = time.monotonic()
        if self._flush is not None:
            try:
                self._flush()
            except Exception:  # noqa: BLE001 - a closing tab
                pass

    def _sync_controls(self, cfg: Config) -> None:
        """Push ``cfg`` into the controls without triggering write-back."""
        ui = self.ui
        with self._quiet(), self._lock:
            ui.code_md.content = (
                f"**Session code: `{self.session.code}`**  \n"
                "a reload keeps it in this browser; elsewhere type it under *Session*"
            )
            m = cfg.model
            preset = actions.matching_preset(m)
            if preset is not None:  # a joined session shows the preset it holds
                title = next(t for t, n in ui.preset_names.items() if n == preset)
                set_value(ui.preset, title)
                ui.preset_md.content = f"*{md_text(actions.preset_doc(preset)['description'])}*"
            # a session joined or restored with its diagnosis: its report can be downloaded
            ui.report_btn.disabled = not self.session.has_diagnosis
            is_pi = m.get("type") == "pi"
            ui.pi_folder.visible = is_pi
            if is_pi:
                set_value(ui.n_ops, len(m["thresholds"]))
            self._show_params(m)
            ui.json_in.value = json.dumps(m)
            sig = cfg.signal
            if sig.kind in ui.kind.options:
                set_value(ui.kind, sig.kind)
            set_value(ui.amp, float(np.clip(sig.amplitude, 0, ui.amp.max)))
            set_value(ui.freq, float(np.clip(sig.frequency, 0.1, 20)))
            set_value(ui.offset, float(np.clip(sig.offset, -5, 5)))
            set_value(ui.duration, float(np.clip(sig.duration, 0.5, 20)))
            set_value(ui.samples, int(sig.samples))
            set_value(ui.mismatch, float(cfg.mismatch))
            set_value(ui.use_rec, bool(cfg.use_recording))

    # ------------------------------------------------------------------ GUI -> session
    def _writing(self) -> AbstractContextManager[None]:
        """Store a change made in this view: its controls are not synced back from it."""
        return self._flag("from_gui")

    def _commit(self, fn: Callable[[Config], Config]) -> None:
        """Check and store a config change made in this view (a message if refused)."""
        with self._writing():
            try:
                actions.change_config(self.session, fn, self.settings)
            except ParameterError as exc:
                self.ui.model_md.content = f"⚠️ **Not applied:** {md_text(exc)}"

    def _controls_changed(self, event: Any) -> None:
        ui = self.ui

        def fn(cfg: Config) -> Config:
            sig = replace(cfg.signal, kind=str(ui.kind.value), amplitude=float(ui.amp.value),
                          frequency=float(ui.freq.value), offset=float(ui.offset.value),
                          duration=float(ui.duration.value), samples=int(ui.samples.value))
            return replace(cfg, signal=sig, mismatch=float(ui.mismatch.value),
                           use_recording=bool(ui.use_rec.value))

        self._commit(fn)

    def _show_params(self, model: dict[str, Any]) -> None:
        """The model's sliders, from the description the services derive from its types'
        field declarations (the web page's too). Call with the write-back guard on."""
        try:
            controls = C.model_controls(model)
        except (ParameterError, ValueError, TypeError) as exc:  # a damaged stored model
            self.ui.params_md.content = f"⚠️ **No sliders for this model:** {md_text(exc)}"
            return
        self.ui.ensure_param_sliders(controls, self._slider_callback)

    def _slider_callback(self, path: str) -> Callable[[Any], None]:
        return self._guarded(lambda event: self._param_moved(path))

    def _param_moved(self, path: str) -> None:
        """One slider moved: its value is kept inside its field's rules (limits, the order
        of the thresholds) and stored; the note says what a rule changed, in the labels the
        sliders show. A refused change puts every slider back at the stored model, so it
        never blocks the next move."""
        h = self.ui.param_sliders[path]
        spec = self.ui.param_specs[path]
        integer = spec.integer
        moved = C.slider_value(spec, float(h.value))  # a log slider's thumb is in log10
        out: dict[str, Any] = {}

        def fn(cfg: Config) -> Config:  # under the session's lock: no lost update
            done = C.clamp(cfg.model, path, moved)
            m = C.with_leaf(cfg.model, path, int(done.value) if integer else done.value)
            out.update(done=done, model=m)
            return cfg.with_model(m)

        with self._writing():
            try:
                actions.change_config(self.session, fn, self.settings)
            except ParameterError as exc:
                self.ui.params_md.content = (f"⚠️ **Not applied:** {md_text(exc)} The sliders "
                                            "are back at the last accepted values.")
                self._sync_controls(self.session.snapshot()[0])
                return
        done = out["done"]
        with self._quiet():
            pos = C.slider_position(spec, done.value)
            if pos != h.value:
                h.value = pos
            self.ui.json_in.value = json.dumps(out["model"])  # the JSON box follows
        note = done.note
        if spec.log:  # the thumb shows log10: say the value
            shown = f"{spec.label} = {done.value:.4g} {C.unit_text(spec.unit)}".rstrip()
            note = f"{shown}; {note}" if note else shown
        self.ui.params_md.content = f"ℹ️ {md_text(note)}" if note else ""

    def _n_changed(self, event: Any) -> None:
        """A new operator count; one beyond the server's limit is set to the limit, and the
        note under the sliders says so (the field shows the count in use)."""
        top = self.settings.max_operators
        asked = int(round(float(self.ui.n_ops.value)))
        n = min(max(asked, 1), top)
        with self._writing():
            try:
                actions.set_operator_count(self.session, n, self.settings)
            except ParameterError as exc:
                self.ui.params_md.content = f"⚠️ {md_text(exc)}"
                return
        self._sync_controls(self.session.snapshot()[0])
        self.ui.params_md.content = "" if n == asked else (
            f"ℹ️ this server allows at most {top} operators: n is set to {top}" if asked > top
            else "ℹ️ n must be at least 1: n is set to 1")

    #: The preset menu's first entry once the model is fitted to the recording.
    FITTED = "(a model fitted to the recording)"

    def _preset_chosen(self, event: Any) -> None:
        name = self.ui.preset_names.get(str(self.ui.preset.value))
        if name is None:  # the fitted model's entry
            return
        doc = actions.preset_doc(name)
        self.ui.preset_md.content = f"*{md_text(doc['description'])}*"

    def _show_fitted(self) -> None:
        """The preset menu says the model is the fit's, no longer the preset it shows."""
        ui = self.ui
        with self._quiet():
            ui.preset.options = (self.FITTED, *ui.preset_names)
            set_value(ui.preset, self.FITTED)
        ui.preset_md.content = ("*The session's model was fitted to the recording. Pick a "
                                "preset and load it to start from a paper's model again.*")

    def _preset_clicked(self, event: Any) -> None:
        name = self.ui.preset_names.get(str(self.ui.preset.value))
        if name is None:
            raise ValueError("pick a preset in the list first")
        if tuple(self.ui.preset.options) != tuple(self.ui.preset_names):
            self.ui.preset.options = tuple(self.ui.preset_names)
            set_value(self.ui.preset, next(t for t, n in self.ui.preset_names.items()
                                           if n == name))
        doc = actions.load_preset(self.session, name, with_input=True)
        self._toast("Preset loaded", doc["title"])

    def _json_clicked(self, event: Any) -> None:
        try:
            actions.load_parameter_set(
                self.session, read_document(str(self.ui.json_in.value), name="the model JSON"),
                self.settings)
        except (ParameterError, ValueError, TypeError) as exc:
            self.ui.model_md.content = f"⚠️ **Model JSON not applied:** {md_text(exc)}"

    def _join_clicked(self, event: Any) -> None:
        code = str(self.ui.code_in.value).strip()
        if not code:
            self._toast("Session", "type the session code first", True)
            return
        if not self._lookups.allowed("join"):
            self._toast("Not joined", "too many unknown session codes: wait a minute and "
                        "check the code", True)
            return
        try:  # codes are made by the server only: an unknown one is never a new session
            new = self.registry.get(code)
        except KeyError:
            self._lookups.take("join")
            self._toast("No such session", f"no session has the code {code[:40]!r}: check "
                        "it (it looks like abcd-efgh-jkmn-pqrs and is shown at the top of "
                        "the page that uses it), or it has expired", True)
            return
        except DamagedSessionError as exc:  # reset by the store: joining it now works
            self._toast("Session reset", str(exc), True)
            new = self.registry.get(code)
        self.bind(new)
        self._toast("Session", f"now in session {new.code}")

    def _attend(self) -> None:
        """Count this tab in the teacher's list, under the name typed (no code shown), and
        tell the explorer which session it shows."""
        HUB.attend(self, self.session.code, str(self.ui.name_in.value))
        if self._on_session is not None:
            self._on_session(self.session.code)

    def pushed(self, event: dict[str, Any]) -> None:
        """A teacher's push arrived (the session is already changed): say so in a notice
        and under the session code; the tab that pushed says "Pushed" itself."""
        if event.get("by") == id(self):
            return
        what = str(event.get("title") or event.get("preset") or
                   ("a new input" if event.get("signal") else "a model"))
        text = (f"Your teacher pushed {what}{' with its input' if event.get('signal') else ''}"
                f" at {time.strftime('%H:%M:%S')}. Your controls now start from it.")
        step = event.get("lesson")
        if isinstance(step, dict):  # a lesson's move, or the class step changed
            where = f"step {step.get('step')} of {step.get('steps')}: {step.get('step_title')}"
            text = (f"Your teacher changed the class step ({where}); your controls follow it."
                    if event.get("edit") else
                    f"Your teacher moved the class to {where}. Your controls follow it.")
        self.ui.pushed_md.content = f"**Teacher:** {md_text(text)}"
        if isinstance(step, dict) and not event.get("edit"):
            return  # a lesson's move: the Lesson folder's own toast says it (one per move:
            # each toast's transition cost a viser tab ~0.1 s of its main thread)
        self._toast("Your teacher pushed a change", text)

    def _token_typed(self, event: Any) -> None:
        """A right teacher token shows the teacher's buttons (a student never sees them);
        on a server without a token anything typed does, and their press says how to give
        the server one."""
        given = str(self.ui.teacher_token.value)
        if given and (self.settings.teacher_ok(given) or not self.settings.teacher_token):
            self.show_teacher()

    def show_teacher(self) -> None:
        """Show this tab the teacher's buttons (push, who is connected, lead a lesson)."""
        self.ui.push_btn.visible = self.ui.who_btn.visible = True
        self.lesson.show_teacher()

    def _teacher_allowed(self, refused: str) -> bool:
        """Whether this tab may act as the teacher: always with the teacher token, also on
        loopback (another page the teacher opens must not); on a loopback server a tab
        that gave the right token once keeps it (:attr:`teacher`). A refusal is a toast
        titled ``refused``."""
        given = str(self.ui.teacher_token.value)
        self.ui.teacher_token.value = ""
        if not self.settings.teacher_token:
            self._toast(refused, "this server has no teacher token, so the GUI cannot act "
                        "as the teacher; start hyst serve with --teacher-token-file FILE (or "
                        "set HYST_TEACHER_TOKEN) and type that token here", True)
            return False
        if given or not self.teacher:
            ok = self.settings.teacher_ok(given or None)
            self.teacher = ok and not self.settings.public
            if not ok:
                self._toast(refused, "wrong teacher token: type the token hyst serve "
                            "was given (or generated into teacher-token in its state "
                            "directory)", True)
                return False
        return True

    def _who_clicked(self, event: Any) -> None:
        """The teacher's list: counts and names, never session codes."""
        if self._teacher_allowed("Not shown"):
            self.ui.who_md.content = md_text(HUB.roster().text)

    def _push_clicked(self, event: Any) -> None:
        """Push this tab's model to every session (the teacher token, see
        :meth:`_teacher_allowed`)."""
        if not self._teacher_allowed("Not pushed"):
            return
        lessons.push_to_class(self.registry, model=self.session.snapshot()[0].model,
                              note={"preset": None, "title": "a model", "model": True,
                                    "by": id(self)})
        self._toast("Pushed", HUB.roster().sent_text("Pushed your model"))

    def bind(self, session: Session) -> None:
        """Show ``session`` in this view (re-binding listeners)."""
        self.session.remove_listener(self._on_session_change)
        self.session = session
        session.add_listener(self._on_session_change)
        self.lesson.follow(session)
        self._sync_controls(session.snapshot()[0])
        self._attend()
        self._redraw()

    # ------------------------------------------------------------------ data
    def upload_refusal(self, uuid: str, name: str, size: int, head: bytes | None
                       ) -> str | None:
        """Why a file sent to this view's *Upload CSV* button is refused, in the web page's
        words, before any of it is kept (called by the viser guard on the upload's start,
        ``head`` None, and on its first part): more than ``max_upload_bytes``, or first
        bytes that are not CSV text. The Data section says it too. Other buttons: None."""
        if uuid != self.ui.upload._impl.uuid:  # viser 1.1 has no public uuid
            return None
        why = (upload_check.too_large(name, size, self.settings.max_upload_bytes)
               if head is None else upload_check.not_text(name, head))
        if why is not None:
            self.ui.data_md.content = f"⚠️ **CSV not loaded:** {md_text(why)}"
        return why

    def _csv_uploaded(self, event: Any) -> None:
        f = event.target.value
        self._csv = (f.content.decode("utf-8-sig", errors="replace"), f.name)
        ui = self.ui
        # a new file is mapped afresh: the columns filled in for the last one go (those
        # typed by hand stay)
        for box, filled in zip((ui.t_col, ui.u_col, ui.y_col), self._filled_cols, strict=True):
            if filled and box.value == filled:
                box.value = ""
        self._load_csv()

    def _remap_clicked(self, event: Any) -> None:
        if self._csv is None:
            self.ui.data_md.content = "⚠️ upload a CSV first"
            return
        self._load_csv()

    def _load_csv(self, timing: str | None = None) -> None:
        """Upload the last CSV with the column mapping; uneven time stamps wait for the
        choice (``timing``: resample onto the step shown, or keep)."""
        ui = self.ui
        if self._csv is None:
            ui.data_md.content = "⚠️ upload a CSV first"
            return
        text, name = self._csv
        if len(text) > self.settings.max_upload_bytes:
            ui.data_md.content = f"⚠️ file larger than {self.settings.max_upload_bytes} bytes"
            return
        step = self._timing.step if timing == "resample" and self._timing else None
        try:
            up = actions.upload(self.session, text, self.settings, t_col=ui.t_col.value or None,
                                u_col=ui.u_col.value or None, y_col=ui.y_col.value or None,
                                name=name, timing=timing, step=step)
        except UnevenUpload as exc:
            self._ask_timing(exc.timing)
            return
        except (ParameterError, QuotaError) as exc:  # CSVError names the line and column
            ui.data_md.content = f"⚠️ **CSV not loaded:** {md_text(exc)}"
            return
        self._ask_timing(None)
        self._show_columns(up.recording.columns)
        ui.data_md.content = recording_markdown(up.recording)
        if up.time_steps:
            ui.data_md.content += f"\n\n{md_text(up.time_steps[0].upper() + up.time_steps[1:])}."
            self._toast("Recording loaded", up.time_steps)
        ui.report_md.content = ""
        self._commit(lambda c: replace(c, use_recording=True))

    def _show_columns(self, columns: Mapping[str, str]) -> None:
        """Fill the empty column fields with the columns the reader chose, so the mapping
        it made is on screen (to change, then *Apply column mapping*)."""
        ui = self.ui
        filled = []
        for box, role in ((ui.t_col, "time"), (ui.u_col, "input"), (ui.y_col, "output")):
            name = str(columns.get(role) or "")
            if not str(box.value).strip() and name:
                box.value = name
                filled.append(name)
            else:
                filled.append("")
        self._filled_cols = tuple(filled)

    def _ask_timing(self, timing: Timing | None) -> None:
        """Offer the choice for uneven time stamps (``None``: hide it)."""
        ui = self.ui
        self._timing = timing
        ui.timing_resample.visible = ui.timing_keep.visible = timing is not None
        if timing is None:
            return
        ui.timing_resample.label = f"Resample onto even {seconds_text(timing.step)} steps"
        ui.data_md.content = (
            f"⚠️ **CSV not loaded yet:** {md_text(timing.text)}.  \n"
            f"Choose below: resample onto an even grid of {md_text(seconds_text(timing.step))}"
            " steps (linear interpolation), or keep the time stamps as measured.")

    def _fit_clicked(self, event: Any) -> None:
        """Run the fit as a job of the session (:func:`~app.services.jobs.tasks.fit_task` in a
        worker process of the job manager), its progress under the buttons; Cancel kills
        the worker and the session's model and fit stay as they were."""
        ui = self.ui
        rec = self.session.recording
        if rec is None:
            ui.report_md.content = "⚠️ upload a recording first"
            return
        n = int(ui.fit_n.value)
        kind = ui.fit_kinds.get(str(ui.fit_kind.value), str(ui.fit_kind.value))
        if not 1 <= n <= self.settings.max_operators:
            raise ParameterError(f"the number of operators must be between 1 and "
                                 f"{self.settings.max_operators}, got {n}")
        view = self._run_job("fit", lambda: fit_task(self.session, n, kind, apply=True),
                             "fitting", "Fit cancelled: the model was not changed.")
        if view is None:
            return
        out: FitResult = view.result  # typed: read as it is, no JSON
        self.fit_figure = out.figure
        self._show_fitted()
        ui.view_dd.value = TITLES["fit"]
        unit = f" {out.output_unit}" if out.output_unit else ""
        ui.report_md.content = (
            f"**Fit ({md_text(type_words(kind))}, {n} operators)**: RMS error "
            f"{out.rms_error:.4g}{md_text(unit)}, max error {out.max_error:.4g}"
            f"{md_text(unit)} ({out.nrmse_percent:.3g} % of the output range)"
        ) + "".join(f"\n\n**Warning:** {md_text(w)}" for w in out.outcome.report.warnings)

    def _run_job(self, kind: str, task: Callable[[], Task], what: str,
                 cancelled: str) -> JobView | None:
        """Run ``task()`` as a ``kind`` job of the session in a worker process of the job
        manager, its progress under the buttons (``what``: "fitting", "diagnosing") with a
        Cancel button that kills the worker. Returns the finished job's view, or ``None``
        when it was cancelled (the report then says ``cancelled``).

        Raises
        ------
        ValueError
            Another job runs for the session, or the job failed (the words for the user).
        """
        ui = self.ui
        self._cancel.clear()
        ui.job_bar.value = 0.0
        with self._busy(what):
            try:
                job = self.jobs.submit(self.session.code, kind, task())
            except JobBusy as exc:
                raise ValueError(_busy_text(str(exc))) from None
            self._job = job
            ui.cancel_btn.label = f"Cancel the {'diagnosis' if kind == 'diagnose' else kind}"
            ui.job_bar.visible = ui.cancel_btn.visible = True
            try:
                if self._cancel.is_set():  # Cancel (or the tab's close) came meanwhile
                    self.jobs.cancel(job.code, job.id)
                self._follow(job, what)
            finally:
                self._job = None
                ui.job_bar.visible = ui.cancel_btn.visible = False
            view = job.view()
            if view.state == "cancelled":
                ui.report_md.content = cancelled
                return None
            if view.state != "done":
                word = "diagnosis" if kind == "diagnose" else kind
                raise ValueError(f"the {word} failed: {view.error or view.message}")
        return view

    def _follow(self, job: Job, what: str) -> None:
        """Show ``job``'s progress until it finishes (a Cancel click cancels it)."""
        ui = self.ui
        while not self.jobs.wait(job, PROGRESS_S):
            if self._cancel.is_set():
                self.jobs.cancel(job.code, job.id)
                continue
            v = job.view()
            ui.job_bar.value = float(100 * v.progress)
            ui.report_md.content = (f"⏳ **{what}… {100 * v.progress:.0f} %**"
                                    + (f", {v.time_left}" if v.time_left else "")
                                    + (f" ({md_text(v.message)})" if v.message else ""))

    def _cancel_clicked(self, event: Any) -> None:
        """Stop the running diagnosis or fit: its worker process is killed at once."""
        self._cancel.set()
        job = self._job
        if job is not None:
            self.jobs.cancel(job.code, job.id)

    def _diagnose_clicked(self, event: Any) -> None:
        """Run the diagnosis as a job of the session (:func:`~app.services.jobs.tasks.diagnose_task`
        in a worker process of the job manager), its progress under the buttons; Cancel
        kills the worker and nothing is stored."""
        ui = self.ui
        if self.session.recording is None:
            ui.report_md.content = "⚠️ upload a recording first"
            return
        view = self._run_job("diagnose", lambda: diagnose_task(self.session), "diagnosing",
                             "Diagnosis cancelled: nothing was changed.")
        if view is None:
            return
        ui.report_md.content = diagnosis_markdown(view.result)
        ui.report_btn.disabled = False
        ui.view_dd.value = TITLES["diagnosis"]  # before and after, in the plot

    @contextmanager
    def _busy(self, what: str) -> Iterator[None]:
        """Disable fit and diagnosis while ``what`` runs; the report says "working…".

        A click that arrives before the browser has greyed the buttons out is refused
        (a ``ValueError``, shown as a toast) instead of starting a second run.
        """
        ui = self.ui
        if not self._work_lock.acquire(blocking=False):
            raise ValueError("a fit or diagnosis is already running: wait for it to finish")
        for b in (ui.fit_btn, ui.diag_btn):
            b.disabled = True
        ui.report_md.content = f"⏳ **working… {what}**"
        try:
            yield
        finally:
            if ui.report_md.content.startswith("⏳"):
                ui.report_md.content = ""  # it failed: the toast says why
            for b in (ui.fit_btn, ui.diag_btn):
                b.disabled = False
            self._work_lock.release()

    def _report_clicked(self, event: Any) -> None:
        text = actions.diagnosis_report(self.session)
        if text is None:
            self.ui.report_md.content += f"\n\n⚠️ {actions.no_report(self.session)}"
            return
        self._send(event, actions.diagnosis_report_name(self.session), text.encode())

    def _send(self, event: Any, name: str, payload: bytes) -> None:
        client = getattr(event, "client", None)
        if client is not None:
            client.send_file_download(name, payload, save_immediately=True)
        elif self._download is not None:
            self._download(name, payload)

    def _paramset_uploaded(self, event: Any) -> None:
        f = event.target.value
        try:
            m = actions.load_parameter_set(
                self.session, read_document(f.content.decode("utf-8-sig"),
                                            name="the parameter set"), self.settings)
        except (UnicodeDecodeError, ParameterError, ValueError) as exc:
            self.ui.export_md.content = f"⚠️ **Parameter set not loaded:** {md_text(exc)}"
            return
        self.ui.export_md.content = (f"✅ loaded {md_text(f.name)} "
                                     f"({md_text(type_words(m.type_name))})")

    def _export(self, event: Any, fmt: str, inverse: bool = False) -> None:
        name, payload = actions.export(self.session, fmt, fmi=self.ui.fmi.value,
                                       inverse=inverse)
        self._send(event, name, payload)
        self.ui.export_md.content = f"sent {md_text(name)} ({len(payload)} bytes)"

    # ------------------------------------------------------------------ render
    def _views(self, session: Session, name: str) -> set[str]:
        """What to compute: the view on show, and the digitized states while the 3D cube
        can show them (a small enough model: the session's model, parsed once per config)."""
        views = set() if name in ("fit", "diagnosis") else {name}
        if self.cube.scene is not None and (operator_count(
                actions.session_model(session, self.settings)) or 0) <= CUBE_MAX_DIGITS:
            views.add("digitized")
        return views

    def _render(self) -> None:
        ui = self.ui
        session = self.session
        v = session.snapshot()[1]
        name = ui.figure_name
        run = actions.session_result_run(session, self._views(session, name), self.settings)
        res = self._computed(run)
        if res is None:
            return  # stopped: a newer version is queued, or the tab closed
        if name == "fit":
            fig = self.fit_figure or F.message_figure("Fit", "upload a recording and fit a model")
        elif name == "diagnosis":
            fig = actions.diagnosis_figure(session) or F.message_figure(
                "Diagnosis", "upload a recording and run the diagnosis to see before and after")
        else:
            fig = F.build(name, res)
        if session is not self.session or self.session.snapshot()[1] != v:
            return  # stale: a newer version is queued, skip sending this one
        aspect = ASPECT.get(name, 0.72)
        # side-by-side panels are stacked: the floating panel is narrow (it leaves the
        # 3D scene in view), a phone's control sheet narrower still
        fig, bands = self._for_screen(fig)
        if ui.narrow:
            aspect = max(0.9, 0.8 * bands)
        elif self.projecting:
            aspect = PROJECTOR_ASPECT
        elif bands > 1:
            aspect = min(1.35, 0.68 * bands)
        fig = self._cut(fig, aspect)
        model_text = model_markdown(res)
        inverse_text = inverse_markdown(res, inverse_problem(res))
        wait = self._text_sent + TEXT_FIRST_S - time.monotonic()
        if wait > 0:  # a lesson's move: its text left alone, painted before this plot
            time.sleep(wait)
        with self._atomic():  # the plot and its texts in one batch
            ui.plot.aspect = aspect
            ui.plot.figure = fig
            notes = (fig.layout.get("meta") or {}).get("notes") or []
            ui.notes_md.content = "  \n".join(f"⚠️ {md_text(n)}" for n in notes)
            self.shown_figure = name
            d = res.digitized
            self._shown_state = len(d.trace.sample) - 1 if name == "digitized" and d else -1
            self.last_result = res
            self.rendered_version = v
            ui.model_md.content = model_text
            ui.inverse_md.content = inverse_text
            self._show_digitized(res)
            ui.status_md.content = f"v{v} · {res.u.size} samples · {res.elapsed_ms:.1f} ms"
        self.lesson.toast_due()  # a lesson move's toast after its text and plot

    def _computed(self, run: actions.FiguresRun) -> Result | None:
        """The result of ``run``: here when light, else in a worker process (issue 35 item
        4) that a newer version or the tab's closing kills (then ``None``), at most
        :data:`GUI_FIGURE_SLOTS` at once for every tab together.

        Raises
        ------
        ParameterError, NotInvertibleError
            The input was refused, or needed more memory than a worker may use.
        """
        if not run.killable:  # the same config's result is shared by every tab (a lesson step)
            return actions.figures_here(run)
        while not GUI_FIGURE_SLOTS.acquire(timeout=0.1):
            if self._closed:
                return None
        try:
            worker = Worker(run.task, self.settings.worker_memory_bytes)
            with self._lock:
                if self._closed:
                    return None
                self._figure_worker = worker
            try:
                out = worker.run(_ignore)
            except WorkerDied:
                if worker.stopped:
                    return None
                raise ParameterError("the figures could not be computed: the work stopped "
                                     "unexpectedly; try fewer samples or operators") from None
            except OutOfMemory as exc:
                raise ParameterError(str(exc)) from None
            return actions.figures_body(out)
        finally:
            with self._lock:
                self._figure_worker = None
            GUI_FIGURE_SLOTS.release()

    def _redraw(self) -> None:
        """Ask for a render of the newest state; a heavy view still computing for an older
        one is stopped (its worker process killed: nobody will see it)."""
        with self._lock:
            worker = self._figure_worker
        if worker is not None:
            worker.kill()
        self.worker.request()

    def _for_screen(self, fig: F.FigureJSON) -> tuple[F.FigureJSON, int]:
        """``fig`` shaped for this tab's screen: side-by-side panels stacked (the floating
        panel, a phone; :func:`~app.services.explore.figures.stack_columns`), its text large in
        projector mode. Returns the figure and its number of bands."""
        if self.projecting:  # wide enough for panels side by side, read from afar
            return F.large_text(fig, width=PROJECTOR_PX), 1
        fig, bands = F.stack_columns(fig, compact=self.ui.narrow)
        # the title under plotly's toolbar row, in lines the plot holds
        return F.below_toolbar(fig, PHONE_PLOT_PX if self.ui.narrow else PANEL_PX), bands

    def _cut(self, fig: F.FigureJSON, aspect: float) -> F.FigureJSON:
        """``fig`` with each line cut to the samples its largest showing on this tab draws
        (:func:`~app.services.explore.figures.fit_to_pixels`: within a quarter pixel, every
        extremum and reversal exact): the projector's width, else the *Expand plot*
        window's (wider than the panel or a phone's sheet). A 670-sample loop is drawn from
        about 40 samples: the tab's plotly has fewer points to lay out per move."""
        if not self.pixel_cut:
            return fig
        width = PROJECTOR_PX if self.projecting else max(
            EXPAND_PX, PHONE_PLOT_PX if self.ui.narrow else PANEL_PX)
        return F.fit_to_pixels(fig, width, width * aspect)

    def _render_error(self, exc: BaseException) -> None:
        self.ui.model_md.content = f"⚠️ **Cannot draw this model:** {md_text(exc)}"
        self.lesson.toast_due()

    # ------------------------------------------------------------------ digitized view
    def _show_digitized(self, res: Result) -> None:
        ui = self.ui
        d = res.digitized
        self.playback.stop()
        if d is None:
            why = res.messages[0] if res.messages else "choose the Digitized view"
            ui.digi_md.content = f"⚠️ {md_text(why)}"
            ui.digi_step.disabled = True
            self.cube.hide()  # another model: its state graph leaves the scene
            return
        rows = len(d.trace.sample)
        ui.digi_step.disabled = False
        with self._quiet():
            ui.digi_step.max = max(1, rows - 1)
            ui.digi_step.value = rows - 1
        self.cube.draw(d)
        self._show_state(rows - 1)

    def _show_state(self, k: int, force: bool = False) -> None:
        res = self.last_result
        if res is None or res.digitized is None:
            return
        tr = res.digitized.trace
        k = int(np.clip(k, 0, len(tr.sample) - 1))
        self.ui.digi_md.content = state_markdown(res, k)
        self.cube.show_state(tr.digits[k])
        if self.shown_figure == "digitized" and k != self._shown_state:
            now = time.monotonic()
            if force or now - self._state_sent >= STATE_REDRAW_S or k == len(tr.sample) - 1:
                # the loop plot's current state and the digit rows' time line follow
                fig = F.digitized_figure(res, highlight=k)
                self.ui.plot.figure = self._cut(self._for_screen(fig)[0], self.ui.plot.aspect)
                self._state_sent, self._shown_state = now, k

    def _step_by(self, d: int) -> None:
        """Stop the animation and move ``d`` states along the trace."""
        self.playback.stop()
        step = self.ui.digi_step
        k = int(np.clip(int(step.value) + d, 0, step.max))
        with self._quiet():
            step.value = k
        self._show_state(k, force=True)

    def _step_changed(self, event: Any) -> None:
        self._show_state(int(self.ui.digi_step.value), force=True)

    def _play_clicked(self, event: Any) -> None:
        res = self.last_result
        if res is None or res.digitized is None:
            return
        self.playback.start(len(res.digitized.trace.sample))

    def _play_step(self, k: int) -> None:
        with self._quiet():
            self.ui.digi_step.value = k
        self._show_state(k)

    def close(self) -> None:
        """Detach from the session, cancel its running fit or diagnosis (its worker process
        is killed: nobody is left to see it) and stop the render worker and the playback."""
        self._cancel_clicked(None)
        with self._lock:
            self._closed = True
            worker = self._figure_worker
        if worker is not None:  # a heavy view computing for nobody
            worker.kill()
        self.playback.stop()
        HUB.leave(self)
        self.session.remove_listener(self._on_session_change)
        self.lesson.close()
        self.worker.stop()
