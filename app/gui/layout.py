"""The viser GUI: one private view per browser tab, bound to a session by code.

Every browser tab gets its own controls (``client.gui``), so students never see each
other's changes. A view is bound to a :class:`~app.state.Session`; typing another code
re-binds it (that is how a student comes back after a reload, or how REST changes and
teacher broadcasts reach the GUI). GUI edits build a new config and store it in the
session; session changes (from any source) are pushed back into the controls under a
re-entrancy guard and rendered by a :class:`~app.gui.render.LatestWinsWorker`.
"""

from __future__ import annotations

import json
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import replace
from typing import Any

import numpy as np

from core.exceptions import NotInvertibleError, ParameterError
from core.pi import PIModel
from core.presets import list_presets
from core.signals import SIGNALS

from .. import figures as F
from ..compute import (
    Result,
    build_model,
    compute,
    diagnosed_model,
    operator_count,
    preset_doc,
    validate_config,
)
from ..data import (
    diagnose_session,
    diagnosis_html,
    fit_kinds,
    fit_session,
    recording_from_csv,
    store_recording,
)
from ..events import HUB
from ..exports import export_session, parameter_set_model
from ..services.ratelimit import RateLimiter
from ..settings import Settings
from ..state import Config, Session, SessionRegistry, SignalSpec
from .render import LatestWinsWorker
from .text import md_text

__all__ = ["ExplorerGui", "SessionView", "attach_gui"]

#: Largest number of operators the GUI shows individual sliders for.
GUI_MAX_SLIDERS = 25
PLOTS = F.FIGURES
_TITLES = {"loop": "Loop", "time": "Time", "operators": "Operators", "loading": "Loading curve",
           "inverse": "Inverse", "digitized": "Digitized states", "closed-loop": "Closed loop",
           "fit": "Fit"}
#: Largest number of digits drawn as a 3D hypercube in the viser scene.
CUBE_MAX_DIGITS = 7
#: Browser widths (CSS px) below which the plot moves into the control sheet.
NARROW_PX = 700


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
    ) -> None:
        self.gui = gui
        self.scene = scene
        self.camera = camera
        self._cube_key: tuple | None = None
        self._cube_points: np.ndarray | None = None
        self._cube_center = np.zeros(3)
        self._marker: Any = None
        self._play_stop = threading.Event()
        self._play_thread: threading.Thread | None = None
        self.registry = registry
        self.session = session
        self.settings = settings
        # failed joins of this tab, as the REST API limits unknown codes per client
        self._lookups = RateLimiter(burst=20, per_minute=20)
        self._notify = notify
        self._download = download
        self._syncing = threading.local()
        self._lock = threading.RLock()
        self._work_lock = threading.Lock()
        self.rendered_version = -1
        self.last_result: Result | None = None
        self.shown_figure = ""
        self._shown_state = -1
        self._state_sent = 0.0
        self._build()
        self.worker = LatestWinsWorker(self._render, self._render_error, name=f"render-{id(self)}")
        session.add_listener(self._on_session_change)
        self._sync_controls(session.snapshot()[0])
        self.worker.request()

    # ------------------------------------------------------------------ layout
    def _build(self) -> None:
        g = self.gui
        self.code_md = g.add_markdown("")
        # viser shows no floating panel on a phone: there the plot lives at the top of
        # the control sheet instead (see :meth:`set_narrow`)
        with g.add_folder("Plot", visible=False) as self.narrow_folder:
            self._dd_narrow = g.add_dropdown("View", tuple(_TITLES.values()),
                                             initial_value=_TITLES["loop"])
            self._plot_narrow = g.add_plotly(F.message_figure("", "computing…"),
                                             aspect=0.9, config=F.PLOT_CONFIG)
        with g.add_folder("Session", expand_by_default=False):
            self.code_in = g.add_text("Session code", initial_value="")
            self.join_btn = g.add_button("Join / restore session")
            # viser 1.1 has no password field: the token is typed here and the field is
            # cleared after each push, so a projector shows it for a moment at most
            self.teacher_token = g.add_text("Teacher token", initial_value="",
                                            hint="needed when the server was started with "
                                                 "--teacher-token; cleared after use")
            self.push_btn = g.add_button("Teacher: push this model to every session")
        tabs = g.add_tab_group()
        with tabs.add_tab("Model"):
            g.add_markdown("*A PI model adds play operators (width r_i, weight p_i) to a "
                           "linear term p0·u. Start from a preset from the papers.*")
            self._preset_names = {p.title: p.name for p in list_presets()}
            titles = tuple(self._preset_names)
            self.preset = g.add_dropdown("Preset", titles, initial_value=titles[0])
            self.preset_md = g.add_markdown("")
            self.load_preset = g.add_button("Load preset (model and its input)")
            self.model_md = g.add_markdown("")
            with g.add_folder("Classical PI") as self.pi_folder:
                self.p0 = g.add_slider("p0", min=-0.5, max=3.0, step=0.001, initial_value=0.72)
                self.n_ops = g.add_number("Operators n", 6, min=1,
                                          max=self.settings.max_operators, step=1)
                self.state0 = g.add_slider("Initial state", min=-5.0, max=5.0, step=0.01,
                                           initial_value=0.0)
                self.r_folder = g.add_folder("Thresholds r_i", expand_by_default=False)
                self.w_folder = g.add_folder("Weights p_i", expand_by_default=True)
            self.r_sliders: list[Any] = []
            self.w_sliders: list[Any] = []
            self.param_folder = g.add_folder("Model parameters", visible=False)
            self.param_sliders: dict[str, Any] = {}
            self._param_paths: tuple[str, ...] = ()
            self.json_in = g.add_text("Model JSON (any type)", initial_value="", multiline=True)
            self.json_btn = g.add_button("Apply model JSON")
        with tabs.add_tab("Input"):
            g.add_markdown("*The signal u(t) that drives the model; its amplitude must exceed "
                           "the widest operator for the loop to open fully.*")
            kinds = tuple(SIGNALS)
            self.kind = g.add_dropdown("Signal", kinds, initial_value=kinds[0])
            self.amp = g.add_slider("Amplitude", min=0.0, max=10.0, step=0.05, initial_value=4.0)
            self.freq = g.add_slider("Frequency [Hz]", min=0.1, max=20.0, step=0.1,
                                     initial_value=1.0)
            self.offset = g.add_slider("Offset", min=-5.0, max=5.0, step=0.05, initial_value=0.0)
            self.duration = g.add_slider("Duration [s]", min=0.5, max=20.0, step=0.5,
                                         initial_value=2.0)
            self.samples = g.add_number("Samples", 2000, min=10, max=self.settings.max_samples,
                                        step=1)
            self.use_rec = g.add_checkbox("Use uploaded recording", False)
            self.signal_md = g.add_markdown("")
        with tabs.add_tab("Inverse"):
            g.add_markdown("*The inverse turns a wanted output into the input that makes it; "
                           "mismatch makes the real plant differ from the model.*")
            self.mismatch = g.add_slider("Model mismatch", min=-0.5, max=0.5, step=0.01,
                                         initial_value=0.0,
                                         hint="plant thresholds ×(1+m), weights ×(1−m)")
            self.inverse_md = g.add_markdown("")
        with tabs.add_tab("Digitized"):
            g.add_markdown("*Paper 000: each operator is one binary digit; the red ball is "
                           "the current state on the cube. Choose the Digitized view.*")
            self.digi_md = g.add_markdown("")
            self.digi_step = g.add_slider("State step", min=0, max=1, step=1, initial_value=0)
            with g.add_folder("Playback"):
                self.play_speed = g.add_slider("Speed (states/s)", min=0.25, max=8.0,
                                               step=0.25, initial_value=2.0)
                self.prev_btn = g.add_button("◀ Step back")
                self.next_btn = g.add_button("Step forward ▶")
                self.play_btn = g.add_button("Play from the start")
                self.stop_btn = g.add_button("Stop")
        with tabs.add_tab("Data"):
            g.add_markdown("*Upload a recording (CSV: time, input, output), then fit a model "
                           "or run the diagnosis, which names what a PI model misses.*")
            self.upload = g.add_upload_button("Upload CSV", mime_type="text/csv")
            self.t_col = g.add_text("Time column", initial_value="")
            self.u_col = g.add_text("Input column", initial_value="")
            self.y_col = g.add_text("Output column", initial_value="")
            self.remap = g.add_button("Apply column mapping")
            self.data_md = g.add_markdown("No recording yet: upload a CSV (t, u, y).")
            self.fit_n = g.add_number("Fit operators n", 10, min=1,
                                      max=self.settings.max_operators, step=1)
            kinds = fit_kinds()
            self.fit_kind = g.add_dropdown("Fit model", kinds, initial_value=kinds[0])
            self.fit_btn = g.add_button("Fit model")
            self.diag_btn = g.add_button("Run diagnosis")
            self.report_btn = g.add_button("Download diagnosis report (HTML)", disabled=True)
            self.report_md = g.add_markdown("")
        with tabs.add_tab("Export"):
            self.dl_json = g.add_button("Download parameter set (JSON)")
            self.dl_mat = g.add_button("Download .mat")
            self.dl_c = g.add_button("Download C code")
            self.ps_upload = g.add_upload_button("Upload parameter set", mime_type="*/*")
            self.export_md = g.add_markdown("")
        # One plot and a view selector: the browser draws a single plotly figure and the
        # server builds only the figure on show (tabs would render every figure each time).
        self.fit_figure: F.FigureJSON | None = None
        # The plot panel floats at the left of a wide screen, leaving the 3D cube (at the
        # scene origin, centre of the canvas) in view; on a narrow screen viser docks
        # panels, and the plot is also in the control sheet's "Plot" tab below.
        self.panel = g.add_panel()
        self.panel.float(x=10, y=10, width=470)
        with self.panel.add_tab("Plots"):
            self._dd_wide = g.add_dropdown("View", tuple(_TITLES.values()),
                                           initial_value=_TITLES["loop"])
            # viser 1.1.1 draws the plot ``aspect`` times as high as wide (its docstring
            # says width/height; measured in Chromium: height = width * aspect).
            self._plot_wide = g.add_plotly(F.message_figure("", "computing…"), aspect=0.72,
                                           config=F.PLOT_CONFIG)
        self.narrow = False
        self.view_dd, self.plot = self._dd_wide, self._plot_wide
        self.status_md = g.add_markdown("")
        self._wire()

    def _wire(self) -> None:
        for h in (self.p0, self.state0, self.mismatch, self.amp, self.freq, self.offset,
                  self.duration, self.samples, self.kind, self.use_rec):
            h.on_update(self._guarded(self._controls_changed))
        self.n_ops.on_update(self._guarded(self._n_changed))
        for dd in (self._dd_wide, self._dd_narrow):
            dd.on_update(self._guarded(self._view_chosen))
        self.digi_step.on_update(self._guarded(self._step_changed))
        self.play_btn.on_click(self._guarded(self._play_clicked))
        self.stop_btn.on_click(self._guarded(lambda ev: self._play_stop.set()))
        self.prev_btn.on_click(self._guarded(lambda ev: self._step_by(-1)))
        self.next_btn.on_click(self._guarded(lambda ev: self._step_by(1)))
        self.preset.on_update(self._guarded(self._preset_chosen))
        self.load_preset.on_click(self._guarded(self._preset_clicked))
        self.json_btn.on_click(self._guarded(self._json_clicked))
        self.join_btn.on_click(self._guarded(self._join_clicked))
        self.push_btn.on_click(self._guarded(self._push_clicked))
        self.upload.on_upload(self._guarded(self._csv_uploaded))
        self.remap.on_click(self._guarded(self._remap_clicked))
        self.fit_btn.on_click(self._guarded(self._fit_clicked))
        self.diag_btn.on_click(self._guarded(self._diagnose_clicked))
        self.report_btn.on_click(self._guarded(self._report_clicked))
        self.ps_upload.on_upload(self._guarded(self._paramset_uploaded))
        for btn, fmt in ((self.dl_json, "json"), (self.dl_mat, "mat"), (self.dl_c, "c")):
            btn.on_click(self._guarded(lambda ev, fmt=fmt: self._export(ev, fmt)))

    def _view_chosen(self, event: Any) -> None:
        other = self._dd_narrow if self.view_dd is self._dd_wide else self._dd_wide
        self._syncing.on = True
        try:
            other.value = self.view_dd.value = event.target.value
        finally:
            self._syncing.on = False
        self.worker.request()

    def set_narrow(self, narrow: bool) -> None:
        """Show the plot in the control sheet (phones) or in the floating panel."""
        if narrow == self.narrow:
            return
        self.narrow = narrow
        self.narrow_folder.visible = narrow
        self.panel.visible = not narrow
        value = self.view_dd.value
        self.view_dd, self.plot = ((self._dd_narrow, self._plot_narrow) if narrow
                                   else (self._dd_wide, self._plot_wide))
        self._syncing.on = True
        try:
            self.view_dd.value = value
        finally:
            self._syncing.on = False
        self.worker.request()

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

    def _toast(self, title: str, body: str, error: bool = False) -> None:
        if self._notify is not None:
            self._notify(title, body, error)

    # ------------------------------------------------------------------ store -> GUI
    def _on_session_change(self, session: Session, config: Config, version: int) -> None:
        if not getattr(self._syncing, "from_gui", False):
            self._sync_controls(config)
        self.worker.request()

    def _set(self, handle: Any, value: Any) -> None:
        if handle.value != value:
            handle.value = value

    def _sync_controls(self, cfg: Config) -> None:
        """Push ``cfg`` into the controls without triggering write-back."""
        self._syncing.on = True
        try:
            with self._lock:
                self.code_md.content = (
                    f"**Session code: `{self.session.code}`**  \n"
                    "type it under *Session* after a reload to continue"
                )
                m = cfg.model
                is_pi = m.get("type") == "pi"
                self.pi_folder.visible = is_pi
                if is_pi:
                    r, w = list(m["thresholds"]), list(m["weights"])
                    self._set(self.p0, float(np.clip(m["p0"], self.p0.min, self.p0.max)))
                    self._set(self.n_ops, len(r))
                    s0 = m.get("state0")
                    self._set(self.state0, float(np.clip(np.mean(s0) if s0 else 0.0, -5, 5)))
                    self._ensure_sliders(r, w)
                self.param_folder.visible = not is_pi
                if not is_pi:
                    self._ensure_param_sliders(m)
                self.json_in.value = json.dumps(m)
                sig = cfg.signal
                if sig.kind in self.kind.options:
                    self._set(self.kind, sig.kind)
                self._set(self.amp, float(np.clip(sig.amplitude, 0, self.amp.max)))
                self._set(self.freq, float(np.clip(sig.frequency, 0.1, 20)))
                self._set(self.offset, float(np.clip(sig.offset, -5, 5)))
                self._set(self.duration, float(np.clip(sig.duration, 0.5, 20)))
                self._set(self.samples, int(sig.samples))
                self._set(self.mismatch, float(cfg.mismatch))
                self._set(self.use_rec, bool(cfg.use_recording))
        finally:
            self._syncing.on = False

    def _ensure_sliders(self, r: list[float], w: list[float]) -> None:
        n = len(r)
        show = n <= GUI_MAX_SLIDERS
        if len(self.r_sliders) != (n if show else 0):
            for h in (*self.r_sliders, *self.w_sliders):
                h.remove()
            self.r_sliders, self.w_sliders = [], []
            if show:
                rmax = max(10.0, 2 * max(r))
                with self.r_folder:
                    for i in range(n):
                        h = self.gui.add_slider(f"r{i + 1}", min=0.001, max=rmax, step=0.001,
                                                initial_value=r[i])
                        h.on_update(self._guarded(self._controls_changed))
                        self.r_sliders.append(h)
                with self.w_folder:
                    for i in range(n):
                        h = self.gui.add_slider(f"p{i + 1}", min=-1.5, max=2.0, step=0.001,
                                                initial_value=float(np.clip(w[i], -1.5, 2.0)))
                        h.on_update(self._guarded(self._controls_changed))
                        self.w_sliders.append(h)
            return
        for h, v in zip(self.r_sliders, r, strict=True):
            if v > h.max:
                h.max = 2 * v
            self._set(h, float(v))
        for h, v in zip(self.w_sliders, w, strict=True):
            self._set(h, float(np.clip(v, h.min, h.max)))

    def _ensure_param_sliders(self, m: dict[str, Any]) -> None:
        """One slider per numeric parameter of a non-PI model (grouped by field)."""
        leaves = numeric_leaves(m)
        paths = tuple(p for p, _ in leaves)
        if paths != self._param_paths:
            for h in self.param_sliders.values():
                h.remove()
            for f in getattr(self, "_param_subfolders", []):
                f.remove()
            self.param_sliders, self._param_subfolders = {}, []
            groups: dict[str, list[tuple[str, float]]] = {}
            for path, v in leaves[:MAX_PARAM_SLIDERS]:
                groups.setdefault(path.split("[")[0], []).append((path, v))
            with self.param_folder:
                for group, items in groups.items():
                    folder = self.gui.add_folder(group, expand_by_default=len(items) <= 4)
                    self._param_subfolders.append(folder)
                    with folder:
                        for path, v in items:
                            span = max(1.0, 2 * abs(v))
                            h = self.gui.add_slider(path.split(".")[-1], min=round(v - span, 3),
                                                    max=round(v + span, 3), step=0.001,
                                                    initial_value=round(v, 3), hint=path)
                            h.on_update(self._guarded(self._params_changed))
                            self.param_sliders[path] = h
            self._param_paths = paths
            return
        for path, v in leaves[:MAX_PARAM_SLIDERS]:
            h = self.param_sliders.get(path)
            if h is not None:
                if not h.min <= v <= h.max:
                    h.min, h.max = v - max(1.0, 2 * abs(v)), v + max(1.0, 2 * abs(v))
                self._set(h, float(v))

    def _params_changed(self, event: Any) -> None:
        def fn(cfg: Config) -> Config:
            m = json.loads(json.dumps(cfg.model))
            for path, h in self.param_sliders.items():
                set_leaf(m, path, float(h.value))
            return cfg.with_model(m)

        self._commit(fn)

    # ------------------------------------------------------------------ GUI -> store
    def _commit(self, fn: Callable[[Config], Config]) -> None:
        """Validate and store a config change made in this view."""
        cfg = fn(self.session.snapshot()[0])
        try:
            validate_config(cfg, self.session.recording, self.settings.max_operators,
                            self.settings.max_samples)
        except ParameterError as exc:
            self.model_md.content = f"⚠️ **Not applied:** {md_text(exc)}"
            return
        self._syncing.from_gui = True
        try:
            self.session.set_config(cfg)
        finally:
            self._syncing.from_gui = False

    def _pi_from_controls(self, cfg: Config) -> dict[str, Any]:
        m = dict(cfg.model)
        if m.get("type") != "pi":
            return m
        m["p0"] = float(self.p0.value)
        if self.r_sliders:
            m["thresholds"] = [float(h.value) for h in self.r_sliders]
            m["weights"] = [float(h.value) for h in self.w_sliders]
        s0 = float(self.state0.value)
        m.pop("state0", None)
        if s0 != 0:
            m["state0"] = s0
        return m

    def _controls_changed(self, event: Any) -> None:
        def fn(cfg: Config) -> Config:
            sig = replace(cfg.signal, kind=str(self.kind.value), amplitude=float(self.amp.value),
                          frequency=float(self.freq.value), offset=float(self.offset.value),
                          duration=float(self.duration.value), samples=int(self.samples.value))
            return replace(cfg, model=self._pi_from_controls(cfg), signal=sig,
                           mismatch=float(self.mismatch.value),
                           use_recording=bool(self.use_rec.value))

        self._commit(fn)

    def _n_changed(self, event: Any) -> None:
        n = int(self.n_ops.value)
        if not 1 <= n <= self.settings.max_operators:
            self.model_md.content = f"⚠️ n must be between 1 and {self.settings.max_operators}"
            return

        def fn(cfg: Config) -> Config:
            m = cfg.model
            rmax = float(m["thresholds"][-1]) if m.get("thresholds") else 2.7
            total = float(np.sum(m.get("weights", [1.0])))
            new = {"type": "pi", "p0": float(m.get("p0", self.p0.value)),
                   "thresholds": (rmax * np.arange(1, n + 1) / n).tolist(),
                   "weights": [total / n] * n}
            return cfg.with_model(new)

        self._syncing.from_gui = True
        try:
            self.session.update(fn)
        finally:
            self._syncing.from_gui = False
        self._sync_controls(self.session.snapshot()[0])

    def _preset_chosen(self, event: Any) -> None:
        doc = preset_doc(self._preset_names[str(self.preset.value)])
        self.preset_md.content = f"*{md_text(doc['description'])}*"

    def _preset_clicked(self, event: Any) -> None:
        doc = preset_doc(self._preset_names[str(self.preset.value)])
        sig = SignalSpec(**doc["input"])
        self.session.update(lambda c: replace(c.with_model(doc["model"]), signal=sig,
                                              use_recording=False))
        self._toast("Preset loaded", doc["title"])

    def _json_clicked(self, event: Any) -> None:
        try:
            doc = json.loads(self.json_in.value)
            m = parameter_set_model(doc)
        except (json.JSONDecodeError, ParameterError, ValueError, TypeError) as exc:
            self.model_md.content = f"⚠️ **Model JSON not applied:** {md_text(exc)}"
            return
        self.session.update(lambda c: c.with_model(m.to_dict()))

    def _join_clicked(self, event: Any) -> None:
        code = str(self.code_in.value).strip()
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
        self.bind(new)
        self._toast("Session", f"now in session {new.code}")

    def _push_clicked(self, event: Any) -> None:
        given = str(self.teacher_token.value)
        self.teacher_token.value = ""
        if not self.settings.may_teach(given or None):
            self._toast("Not pushed", "wrong teacher token", True)
            return
        n = self.registry.push_model(self.session.snapshot()[0].model)
        HUB.broadcast({"kind": "push", "preset": None, "title": "the teacher's model"})
        self._toast("Pushed", f"model sent to {n} sessions")

    def bind(self, session: Session) -> None:
        """Show ``session`` in this view (re-binding listeners)."""
        self.session.remove_listener(self._on_session_change)
        self.session = session
        session.add_listener(self._on_session_change)
        self._sync_controls(session.snapshot()[0])
        self.worker.request()

    # ------------------------------------------------------------------ data
    def _csv_uploaded(self, event: Any) -> None:
        f = event.target.value
        self._csv_text = f.content.decode("utf-8-sig", errors="replace")
        self._csv_name = f.name
        self._load_csv()

    def _remap_clicked(self, event: Any) -> None:
        if getattr(self, "_csv_text", None) is None:
            self.data_md.content = "⚠️ upload a CSV first"
            return
        self._load_csv()

    def _load_csv(self) -> None:
        if len(self._csv_text) > self.settings.max_upload_bytes:
            self.data_md.content = (
                f"⚠️ file larger than {self.settings.max_upload_bytes} bytes")
            return
        try:
            rec = recording_from_csv(
                self._csv_text, t_col=self.t_col.value or None, u_col=self.u_col.value or None,
                y_col=self.y_col.value or None, max_samples=self.settings.max_samples,
                name=self._csv_name)
        except ParameterError as exc:  # core.csvio.CSVError names the line and the column
            self.data_md.content = f"⚠️ **CSV not loaded:** {md_text(exc)}"
            return
        store_recording(self.session, rec)
        head = "\n".join(f"| {a:.4g} | {b:.4g} | {c:.4g} |"
                         for a, b, c in zip(rec.t[:5], rec.u[:5], rec.y[:5], strict=True))
        self.data_md.content = (
            f"✅ **{md_text(rec.name)}**: {rec.n_samples} samples, "
            f"t = {rec.t[0]:.4g}…{rec.t[-1]:.4g} s\n\n"
            f"| t [{md_text(rec.units.get('time') or 's')}] "
            f"| u [{md_text(rec.units.get('input') or 'a.u.')}] "
            f"| y [{md_text(rec.units.get('output') or 'a.u.')}] |\n|---|---|---|\n{head}"
        )
        self.report_md.content = ""
        self._commit(lambda c: replace(c, use_recording=True))

    def _fit_clicked(self, event: Any) -> None:
        rec = self.session.recording
        if rec is None:
            self.report_md.content = "⚠️ upload a recording first"
            return
        n = int(self.fit_n.value)
        kind = str(self.fit_kind.value)
        with self._busy("fitting"):
            model, report = fit_session(self.session, n, kind)
        self.fit_figure = F.fit_figure(rec, model(rec.u), f"fitted {kind} (n={n})")
        self.view_dd.value = _TITLES["fit"]
        self.report_md.content = (
            f"**Fit ({kind}, n = {n})**: RMS error {report['rms_error']:.4g}, "
            f"max error {report['max_error']:.4g} ({report['nrmse_percent']:.3g} % of range)"
        )

    def _diagnose_clicked(self, event: Any) -> None:
        rec = self.session.recording
        if rec is None:
            self.report_md.content = "⚠️ upload a recording first"
            return
        with self._busy("diagnosing (10–40 s for a long recording)"):
            rep = diagnose_session(self.session)
        self.report_md.content = diagnosis_markdown(rep)
        self.report_btn.disabled = False

    @contextmanager
    def _busy(self, what: str) -> Iterator[None]:
        """Disable fit and diagnosis while ``what`` runs; the report says "working…".

        A click that arrives before the browser has greyed the buttons out is refused
        (a ``ValueError``, shown as a toast) instead of starting a second run.
        """
        if not self._work_lock.acquire(blocking=False):
            raise ValueError("a fit or diagnosis is already running: wait for it to finish")
        for b in (self.fit_btn, self.diag_btn):
            b.disabled = True
        self.report_md.content = f"⏳ **working… {what}**"
        try:
            yield
        finally:
            if self.report_md.content.startswith("⏳"):
                self.report_md.content = ""  # it failed: the toast says why
            for b in (self.fit_btn, self.diag_btn):
                b.disabled = False
            self._work_lock.release()

    def _report_clicked(self, event: Any) -> None:
        result = self.session.diagnosis_result
        if result is None:
            self.report_md.content += "\n\n⚠️ run the diagnosis first"
            return
        text = diagnosis_html(result)
        self._send(event, f"diagnosis-{self.session.code}.html", text.encode())

    def _send(self, event: Any, name: str, payload: bytes) -> None:
        client = getattr(event, "client", None)
        if client is not None:
            client.send_file_download(name, payload, save_immediately=True)
        elif self._download is not None:
            self._download(name, payload)

    def _paramset_uploaded(self, event: Any) -> None:
        f = event.target.value
        try:
            m = parameter_set_model(json.loads(f.content.decode("utf-8-sig")))
        except (json.JSONDecodeError, UnicodeDecodeError, ParameterError, ValueError) as exc:
            self.export_md.content = f"⚠️ **Parameter set not loaded:** {md_text(exc)}"
            return
        self.session.update(lambda c: c.with_model(m.to_dict()))
        self.export_md.content = f"✅ loaded {md_text(f.name)} ({m.type_name})"

    def _export(self, event: Any, fmt: str) -> None:
        name, payload = export_session(self.session, fmt)
        self._send(event, name, payload)
        self.export_md.content = f"sent {md_text(name)} ({len(payload)} bytes)"

    # ------------------------------------------------------------------ render
    @property
    def figure_name(self) -> str:
        """Key of the figure selected in the *View* dropdown."""
        inv = {v: k for k, v in _TITLES.items()}
        return inv.get(str(self.view_dd.value), "loop")

    def _render(self) -> None:
        session = self.session
        cfg, v = session.snapshot()
        name = self.figure_name
        # only what the view on show needs; the digitized state also drives the 3D cube,
        # so it is kept up to date while the cube is small enough to draw
        small = (operator_count(build_model(cfg.model, self.settings.max_operators)) or 0
                 ) <= CUBE_MAX_DIGITS
        res = compute(cfg, version=v, recording=session.recording,
                      max_operators=self.settings.max_operators,
                      max_samples=self.settings.max_samples,
                      with_inverse=name == "inverse",
                      with_digitized=name == "digitized" or (small and self.scene is not None)
                      or self.scene is None,
                      with_operators=name == "operators",
                      diagnosed=diagnosed_model(session))
        if name == "fit":
            fig = self.fit_figure or F.message_figure("Fit", "upload a recording and fit a model")
        else:
            fig = F.build(name, res, cfg.mismatch)
        if session is not self.session or self.session.snapshot()[1] != v:
            return  # stale: a newer version is queued, skip sending this one
        aspect = {"inverse": 0.5, "fit": 0.5, "digitized": 1.0,
                  "closed-loop": 0.75}.get(name, 0.72)
        # side-by-side panels are stacked: the floating panel is narrow (it leaves the
        # 3D scene in view), a phone's control sheet narrower still
        fig, bands = F.stack_columns(fig, compact=self.narrow)
        if self.narrow:
            aspect = max(0.9, 0.8 * bands)
        elif bands > 1:
            aspect = min(1.35, 0.68 * bands)
        self.plot.aspect = aspect
        self.plot.figure = fig
        self.shown_figure = name
        d = res.digitized
        self._shown_state = len(d.trace.sample) - 1 if name == "digitized" and d else -1
        self.last_result = res
        self.rendered_version = v
        m = res.model
        pi = m if isinstance(m, PIModel) else None
        lines = [f"**{m.type_name}** model, {getattr(m, 'n', '?')} operators"]
        if pi is not None:
            lines.append("slopes " + ", ".join(f"{s:.3g}" for s in pi.slopes))
            lines.append(f"max loop width σ = {pi.max_loop_width:.4g}")
        self.model_md.content = "  \n".join(lines) + (
            f"  \n⚠️ {md_text(res.inverse_error)}" if res.inverse_error else "")
        inv_err = res.inverse_error
        if inv_err is None and res.y_comp is None:
            try:
                m.inverse()
            except (NotInvertibleError, ValueError) as exc:
                inv_err = str(exc)
        if inv_err:
            self.inverse_md.content = f"⚠️ **No inverse:** {md_text(inv_err)}"
        elif res.y_comp is not None:
            err = res.y_comp - res.u
            self.inverse_md.content = (f"RMS tracking error {np.sqrt(np.mean(err**2)):.4g}, "
                                       f"max {np.max(np.abs(err)):.4g}")
            if res.inverse_warning:
                self.inverse_md.content += (
                    f"  \n⚠️ **The inverse clipped part of the input:** "
                    f"{md_text(res.inverse_warning)}")
        else:
            self.inverse_md.content = "*choose the Inverse view to compute the compensation*"
        self._show_digitized(res)
        self.status_md.content = f"v{v} · {res.u.size} samples · {res.elapsed_ms:.1f} ms"

    # ------------------------------------------------------------------ digitized view
    def _show_digitized(self, res: Result) -> None:
        d = res.digitized
        self._play_stop.set()
        if d is None:
            why = res.messages[0] if res.messages else "choose the Digitized view"
            self.digi_md.content = f"⚠️ {md_text(why)}"
            self.digi_step.disabled = True
            if self._marker is not None:
                self._marker.visible = False
            return
        rows = len(d.trace.sample)
        self.digi_step.disabled = False
        self._syncing.on = True
        try:
            self.digi_step.max = max(1, rows - 1)
            self.digi_step.value = rows - 1
        finally:
            self._syncing.on = False
        self._draw_cube(d)
        self._show_state(rows - 1)

    def _show_state(self, k: int, force: bool = False) -> None:
        res = self.last_result
        if res is None or res.digitized is None:
            return
        d = res.digitized
        tr = d.trace
        k = int(np.clip(k, 0, len(tr.sample) - 1))
        digits = tr.digits[k]
        row = " ".join(str(int(b)) for b in digits[::-1])
        H = d.H
        fmt = lambda a: " ".join(f"{v:.3g}" for v in a)  # noqa: E731
        self.digi_md.content = (
            f"**State {k}/{len(tr.sample) - 1}** at t = {res.t[tr.sample[k]]:.3f} s  \n"
            f"digits b{d.model.n}…b1: `{row}`  \n"
            f"state point (X, Y) = ({tr.x_b[k]:.4g}, {tr.y_b[k]:.4g})  \n"
            f"H: Δx = [{fmt(H[0])}], Δy = [{fmt(H[1])}]  \n"
            f"H⁻¹ swaps the rows (Δx ↔ Δy)  \n"
            f"max |digitized − classical| = {np.max(np.abs(d.y - d.y_classical)):.3g}"
        )
        if self._marker is not None and self._cube_points is not None:
            self._marker.position = tuple(self._embed(digits) - self._cube_center)
            self._marker.visible = True
        if self.shown_figure == "digitized" and k != self._shown_state:
            now = time.monotonic()
            if force or now - self._state_sent >= 0.1 or k == len(tr.sample) - 1:
                # the loop plot's current state and the digit rows' time line follow
                fig = F.digitized_figure(res, highlight=k)
                self.plot.figure = F.stack_columns(fig, compact=self.narrow)[0]
                self._state_sent, self._shown_state = now, k

    def _step_by(self, d: int) -> None:
        """Stop the animation and move ``d`` states along the trace."""
        self._play_stop.set()
        k = int(np.clip(int(self.digi_step.value) + d, 0, self.digi_step.max))
        self._syncing.on = True
        try:
            self.digi_step.value = k
        finally:
            self._syncing.on = False
        self._show_state(k, force=True)

    def _embed(self, digits: np.ndarray) -> np.ndarray:
        n = digits.size
        if n <= 3:
            dirs = np.eye(3)[:n]
        else:
            a = 2 * np.pi * np.arange(n) / n
            dirs = np.column_stack((np.cos(a), np.sin(a), 0.35 * (-1.0) ** np.arange(n)))
        return np.asarray(digits, dtype=float) @ dirs

    def _draw_cube(self, d: Any) -> None:
        """The state hypercube in the 3D scene (small n); larger n use the 2D figure."""
        if self.scene is None:
            return
        g = d.graph
        n = d.model.n
        key = (n,)
        if g is None or n > CUBE_MAX_DIGITS:
            if self._cube_key is not None:
                self.scene.add_frame("/states", show_axes=False, visible=False)
            self._cube_key = None
            self._cube_points = None
            if self._marker is not None:
                self._marker.visible = False
            return
        if key == self._cube_key:
            return
        raw = np.array([self._embed(row) for row in g.digits])
        self._cube_center = raw.mean(axis=0)
        pts = raw - self._cube_center  # centred on the scene origin (camera target)
        self._cube_points = pts
        self.scene.add_frame("/states", show_axes=False, visible=True)
        self.scene.add_point_cloud("/states/nodes", pts.astype(np.float32),
                                   colors=(120, 120, 120), point_size=0.06,
                                   point_shape="circle")
        up = np.stack((pts[g.up[:, 0]], pts[g.up[:, 1]]), axis=1)
        down = np.stack((pts[g.down[:, 0]], pts[g.down[:, 1]]), axis=1)
        self.scene.add_line_segments("/states/up", up.astype(np.float32), colors=(31, 119, 180),
                                     thickness=2.0, thickness_units="screen")
        self.scene.add_line_segments("/states/down", (down + 0.01).astype(np.float32),
                                     colors=(255, 127, 14), thickness=2.0,
                                     thickness_units="screen")
        if n <= 4:
            for c, p in zip(g.strings, pts, strict=True):
                self.scene.add_label(f"/states/label_{c}", c, position=tuple(p + 0.06),
                                     font_screen_scale=1.6, anchor="bottom-left")
        self._marker = self.scene.add_icosphere("/states/current", radius=0.09,
                                                color=(214, 39, 40))
        self._cube_key = key
        self._aim_camera(pts)

    def _aim_camera(self, pts: np.ndarray) -> None:
        """Look at the cube from off its diagonal, so no two vertices overlap (000/111)."""
        if self.camera is None:
            return
        radius = float(np.max(np.linalg.norm(pts, axis=1))) or 1.0
        direction = np.array([0.55, -1.0, 0.45])
        direction /= np.linalg.norm(direction)
        try:
            self.camera.up_direction = (0.0, 0.0, 1.0)
            # viser moves look_at with the position: set the target afterwards
            self.camera.position = tuple(3.2 * radius * direction)
            self.camera.look_at = (0.0, 0.0, 0.0)
        except Exception:  # noqa: BLE001 - a camera of a closing tab
            pass

    def _step_changed(self, event: Any) -> None:
        self._show_state(int(self.digi_step.value), force=True)

    def _play_clicked(self, event: Any) -> None:
        res = self.last_result
        if res is None or res.digitized is None:
            return
        self._play_stop.set()
        if self._play_thread is not None:
            self._play_thread.join(timeout=1)
        self._play_stop = stop = threading.Event()
        rows = len(res.digitized.trace.sample)

        def play() -> None:
            for k in range(rows):
                # read the speed at every step, so the slider acts during playback
                if stop.wait(1.0 / max(0.25, float(self.play_speed.value))):
                    return
                self._syncing.on = True
                try:
                    self.digi_step.value = k
                finally:
                    self._syncing.on = False
                self._show_state(k)

        self._play_thread = threading.Thread(target=play, daemon=True, name="play")
        self._play_thread.start()

    def _render_error(self, exc: BaseException) -> None:
        self.model_md.content = f"⚠️ **Cannot draw this model:** {md_text(exc)}"

    def close(self) -> None:
        """Detach from the session and stop the worker."""
        self._play_stop.set()
        self.session.remove_listener(self._on_session_change)
        self.worker.stop()


#: Largest number of generic parameter sliders (non-PI models).
MAX_PARAM_SLIDERS = 80


def numeric_leaves(d: Any, prefix: str = "") -> list[tuple[str, float]]:
    """``(path, value)`` of every number in a model document (``pi.weights[2]``, ...)."""
    out: list[tuple[str, float]] = []
    if isinstance(d, dict):
        for k, v in d.items():
            if k == "type":
                continue
            out += numeric_leaves(v, f"{prefix}.{k}" if prefix else str(k))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            out += numeric_leaves(v, f"{prefix}[{i}]")
    elif isinstance(d, int | float) and not isinstance(d, bool):
        out.append((prefix, float(d)))
    return out


def set_leaf(d: Any, path: str, value: float) -> None:
    """Set the number at ``path`` (as produced by :func:`numeric_leaves`) in place."""
    import re

    tokens = re.findall(r"[^.\[\]]+|\[\d+\]", path)
    node = d
    for tok in tokens[:-1]:
        node = node[int(tok[1:-1])] if tok.startswith("[") else node[tok]
    last = tokens[-1]
    if last.startswith("["):
        node[int(last[1:-1])] = value
    else:
        node[last] = value


def diagnosis_markdown(rep: dict[str, Any]) -> str:
    """A diagnosis report as Markdown (findings first, then the numbers)."""
    lines = ["### Diagnosis", f"*engine: {md_text(rep.get('engine', '?'))}*", ""]
    for f in rep.get("findings", []) or []:
        lines.append(f"- {md_text(f if isinstance(f, str) else json.dumps(f))}")
    for k, v in rep.items():
        if k in ("findings", "engine") or isinstance(v, dict | list):
            continue
        key = md_text(str(k).replace("_", " "))
        lines.append(f"- **{key}**: {v:.4g}" if isinstance(v, float)
                     else f"- **{key}**: {md_text(v)}")
    return "\n".join(lines)


class ExplorerGui:
    """Binds a viser server to the session registry: one :class:`SessionView` per tab.

    Parameters
    ----------
    server : viser.ViserServer
    registry : SessionRegistry
    settings : Settings
    """

    def __init__(self, server: Any, registry: SessionRegistry, settings: Settings) -> None:
        self.server = server
        self.registry = registry
        self.settings = settings
        self.views: dict[int, SessionView] = {}
        self._lock = threading.Lock()
        server.gui.configure_theme(show_share_button=False, control_width="large",
                                   titlebar_content=None, show_logo=False)
        server.on_client_connect(self._connect)
        server.on_client_disconnect(self._disconnect)

    def _connect(self, client: Any) -> None:
        client.gui.configure_theme(show_share_button=False, control_width="large",
                                   show_logo=False)

        def notify(title: str, body: str, error: bool) -> None:
            client.add_notification(title, body, auto_close_seconds=6.0,
                                    color="red" if error else None)

        view = SessionView(client.gui, self.registry, self.registry.create(), self.settings,
                           notify=notify, scene=client.scene, camera=client.camera)

        def on_camera(camera: Any) -> None:
            width = getattr(camera, "image_width", 0) or 0
            if width:
                view.set_narrow(width < NARROW_PX)

        client.camera.on_update(on_camera)
        on_camera(client.camera)
        with self._lock:
            self.views[client.client_id] = view

    def _disconnect(self, client: Any) -> None:
        with self._lock:
            view = self.views.pop(client.client_id, None)
        if view is not None:
            view.close()

    def close(self) -> None:
        """Stop every view's worker."""
        with self._lock:
            views, self.views = list(self.views.values()), {}
        for v in views:
            v.close()


def attach_gui(server: Any, registry: SessionRegistry, settings: Settings) -> ExplorerGui:
    """Give every browser tab connecting to ``server`` its own explorer view."""
    return ExplorerGui(server, registry, settings)
