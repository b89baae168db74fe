"""The viser GUI's widgets: every control and plot of one tab, built and laid out here.

:class:`Widgets` adds the controls to a ``GuiApi`` (``client.gui``, private to a tab) in
tabs (Model, Input, Inverse, Digitized, Data, Export), the plot in a floating panel (in the
control sheet on a phone) and the model's parameter sliders, built from the description the
services derive from the model types' field declarations
(:func:`app.services.explore.controls.model_controls`, the same the web page draws). It holds no
behaviour: :class:`app.gui.controller.SessionView` wires the callbacks to the services.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from app.services.explore import catalog
from app.services.explore import figures as F
from app.services.explore.config import CONTROLS
from app.services.explore.controls import (
    ModelControls,
    Slider,
    log_step,
    slider_position,
    unit_text,
)
from app.services.settings import Settings
from app.services.words import type_words

__all__ = [
    "NARROW_PX",
    "PANEL_PX",
    "PROJECTOR_PX",
    "TITLES",
    "Widgets",
    "is_narrow",
    "set_value",
]

#: The views of the *View* dropdown: figure key -> title.
TITLES = {"loop": "Loop", "time": "Time", "operators": "Operators", "loading": "Loading curve",
          "inverse": "Inverse", "digitized": "Digitized states", "closed-loop": "Closed loop",
          "fit": "Fit", "diagnosis": "Diagnosis"}
#: Browser widths (CSS px) below which the plot moves into the control sheet.
NARROW_PX = 700
#: Width of the floating plot panel, CSS px (leaves the 3D cube in view on a laptop).
PANEL_PX = 470
#: Width a phone's plot is laid out for, CSS px: the control sheet takes the phone's width
#: (:data:`PHONE_SHEET_CSS`), leaving the plot the width less about 37 px (353 px on a
#: 390 px phone, 283 px on a 320 px one; a title broken for 350 px was cut at both sides in
#: viser's own 20em sheet, whose plot was about 230 px).
PHONE_PLOT_PX = 280
#: The panel's width in projector mode, CSS px (62 % of a 1920 px projector).
PROJECTOR_PX = 1200
#: The screen width projector mode is made for, CSS px.
PROJECTOR_SCREEN_PX = 1920
#: A canvas this much higher than wide is a phone held upright (or a window as narrow).
PORTRAIT = 1.15
#: Groups with more sliders than this start collapsed.
OPEN_GROUP_SLIDERS = 8


def is_narrow(width: float, height: float) -> bool:
    """Whether the plot belongs in the control sheet, from the canvas size viser reports.

    viser reports the canvas in device pixels, scaled by its adaptive pixel ratio (0.75 to
    1 times the screen's): a phone at ratio 3 reports 800-1200 px wide, so the width alone
    misses it. Its shape does not depend on the ratio: a canvas higher than wide by
    :data:`PORTRAIT` is a phone held upright, as is one narrower than :data:`NARROW_PX`.
    """
    return width < NARROW_PX or height > PORTRAIT * width


def toast_css(projector: bool) -> str:
    """A style element that moves viser's toasts (top left, 20em wide, over the floating
    plot panel) off the panel: to the bottom left under the usual panel (about 470 x 420 px
    from the top left), beside the projector's panel (1200 px wide, as high as the screen).
    Phones (narrower than :data:`NARROW_PX`) show no panel and keep viser's place."""
    where = (f"left: {10 + PROJECTOR_PX + 16}px !important; max-width: 18em !important;"
             if projector else "top: auto !important; bottom: 1em !important;")
    return (f"<style>@media (min-width: {NARROW_PX}px) {{ [class*='Notifications-root'] "
            f"{{ {where} }} }}</style>")


#: A style element of the phone's *Plot* folder (rendered only while the plot lives in the
#: control sheet): viser's sheet is 20em (266 px) at the bottom right of a 390 px phone and
#: left the plot about 230 px wide; the sheet takes the screen's width (the plot ~350 px).
_SHEET = "[class*='Paper-root'][style*='position: fixed'][style*='bottom: 0'][style*='right: 0']"
PHONE_SHEET_CSS = (f"<style>{_SHEET}, {_SHEET} [class*='ScrollArea-root'] > div > "
                   "[style*='width: 20em'], [class*='ScrollArea-content'] > [style*='width: 20em']"
                   " { width: 100% !important; }</style>")


#: Tooltips (viser's ``hint``) of the widgets, by attribute of :class:`Widgets`; set after
#: the widgets are built, so every control says what it does (the model's sliders bring
#: their own, from their declarations).
HINTS = {
    "join_btn": "continue the session whose code you typed",
    "push_btn": "send this tab's model (as you edited it) to every student now",
    "preset": "models and inputs taken from the papers' examples",
    "load_preset": "replace the model and the input by the chosen preset's",
    "n_ops": "number of play operators; thresholds spread evenly up to the widest",
    "json_in": "the session's model as JSON: any model type, edited by hand",
    "json_btn": "use the model typed in the JSON box",
    "kind": "shape of the input signal u(t)",
    "amp": "peak value of the input (in the input's unit)",
    "freq": "cycles per second of the input",
    "offset": "value the input oscillates around",
    "duration": "length of the simulated input",
    "samples": "number of time steps simulated (more: smoother, slower)",
    "use_rec": "drive the model with the uploaded recording's input",
    "digi_step": "which state of the digitized trace to show",
    "play_speed": "states shown per second while playing",
    "prev_btn": "one state back", "next_btn": "one state forward",
    "play_btn": "play the states from the start", "stop_btn": "stop playing",
    "upload": "a CSV file with time, input and output columns",
    "t_col": "time column: name or 0-based index (empty: found automatically)",
    "u_col": "input column: name or 0-based index (empty: found automatically)",
    "y_col": "output column: name or 0-based index (empty: found automatically)",
    "remap": "load the CSV again with the columns typed above",
    "fit_n": "number of operators of the fitted model",
    "fit_kind": "which model type the fit identifies",
    "fit_btn": "fit the chosen model to the recording (it replaces the session's model)",
    "diag_btn": "find what the PI model misses, proved on rows the fit never saw",
    "report_btn": "the full diagnosis report as an HTML file",
    "dl_json": "the model as a parameter set (JSON) to continue later",
    "dl_mat": "the model for MATLAB / Octave",
    "dl_c": "C code of the model and its inverse for a controller",
    "ps_upload": "load a parameter set saved earlier (JSON)",
    "_dd_wide": "which view of the model the plot shows",
    "_dd_narrow": "which view of the model the plot shows",
}


def set_value(handle: Any, value: Any) -> None:
    """Set a handle's value only when it differs (each set is sent to the browser)."""
    if handle.value != value:
        handle.value = value


class Widgets:
    """The handles of one tab's controls and plots.

    Parameters
    ----------
    gui : viser.GuiApi
        ``client.gui`` (private to a tab) or ``server.gui`` (headless tests).
    settings : Settings
        Limits (operators, samples) of the number fields.
    """

    def __init__(self, gui: Any, settings: Settings) -> None:
        self.gui = g = gui
        #: The parameter sliders by JSON path (``pi.thresholds[2]``) and their description.
        self.param_sliders: dict[str, Any] = {}
        self.param_specs: dict[str, Slider] = {}
        self._param_layout = ""
        #: The slider groups shown, in order: what each shows (:func:`_group_key`) and its
        #: handles (folder, note, sliders), so a rebuild keeps the groups that stay.
        self._param_groups: list[tuple[tuple[Any, ...], list[Any]]] = []
        self.code_md = g.add_markdown("")
        self.pushed_md = g.add_markdown("")  # the teacher's last push, said in words
        # viser shows no floating panel on a phone: there the plot lives at the top of
        # the control sheet instead (see :meth:`use_narrow`)
        with g.add_folder("Plot", visible=False) as self.narrow_folder:
            self._dd_narrow = g.add_dropdown("View", tuple(TITLES.values()),
                                             initial_value=TITLES["loop"])
            self._plot_narrow = g.add_plotly(F.message_figure("", "computing…"),
                                             aspect=0.9, config=F.PLOT_CONFIG)
            self._notes_narrow = g.add_markdown("")
            self._sheet_style = g.add_html(PHONE_SHEET_CSS)
        with g.add_folder("Session", expand_by_default=False):
            self.code_in = g.add_text("Session code", initial_value="",
                                      hint="the code of a session to continue (shown at the "
                                           "top of the page that uses it)")
            self.join_btn = g.add_button("Join / restore session")
            self.name_in = g.add_text("Your name", initial_value="",
                                      hint="optional: shown in the teacher's list of who is "
                                           "connected (your session code is not)")
            # viser 1.1 has no password field: the token is typed here and the field is
            # cleared after each push, so a projector shows it for a moment at most
            self.teacher_token = g.add_text("Teacher token", initial_value="",
                                            hint="the teacher's buttons appear once it is "
                                                 "right (the token hyst serve was given or "
                                                 "generated); cleared after use, on a server "
                                                 "of this computer the tab remembers it")
            # the teacher's buttons: a student never sees them (shown by a right token)
            self.push_btn = g.add_button("Teacher: push this model to every session",
                                         visible=False)
            self.who_btn = g.add_button("Teacher: who is connected?", visible=False,
                                        hint="counts and names only, never session codes")
            self.who_md = g.add_markdown("")
        tabs = g.add_tab_group()
        with tabs.add_tab("Model"):
            g.add_markdown("*A PI model adds play operators (width r_i, weight p_i) to a "
                           "linear term p0·u. Start from a preset from the papers, then "
                           "drag the sliders.*")
            self.preset_names = catalog.preset_titles()
            titles = tuple(self.preset_names)
            self.preset = g.add_dropdown("Preset", titles, initial_value=titles[0])
            self.preset_md = g.add_markdown("")
            self.load_preset = g.add_button("Load preset (model and its input)")
            self.model_md = g.add_markdown("")
            with g.add_folder("Classical PI") as self.pi_folder:
                self.n_ops = g.add_number("Operators n", 6, min=1,
                                          max=settings.max_operators, step=1)
            #: What a slider's rule changed, or why a change was refused.
            self.params_md = g.add_markdown("")
            self.param_folder = g.add_folder("Model parameters")
            self.json_in = g.add_text("Model JSON (any type)", initial_value="", multiline=True)
            self.json_btn = g.add_button("Apply model JSON")
        with tabs.add_tab("Input"):
            g.add_markdown("*The signal u(t) that drives the model; its amplitude must exceed "
                           "the widest operator for the loop to open fully.*")
            kinds = catalog.signal_kinds()
            self.kind = g.add_dropdown("Signal", kinds, initial_value=kinds[0])
            self.amp = _slider(g, "amplitude", 4.0)
            self.freq = _slider(g, "frequency", 1.0)
            self.offset = _slider(g, "offset", 0.0)
            self.duration = _slider(g, "duration", 2.0)
            self.samples = g.add_number("Samples", 2000, min=10, max=settings.max_samples,
                                        step=1)
            self.use_rec = g.add_checkbox("Use uploaded recording", False)
            self.signal_md = g.add_markdown("")
        with tabs.add_tab("Inverse"):
            g.add_markdown("*The inverse turns a wanted output into the input that makes it; "
                           "mismatch makes the real plant differ from the model.*")
            self.mismatch = _slider(g, "mismatch", 0.0,
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
            # uneven time stamps: the upload waits for one of these (shown only then)
            self.timing_resample = g.add_button(
                "Resample onto an even grid", visible=False,
                hint="linear interpolation onto evenly spaced time stamps (the step shown)")
            self.timing_keep = g.add_button(
                "Keep the time stamps as measured", visible=False,
                hint="a PI model does not depend on the step; rate-dependent effects "
                     "assume an even one")
            self.fit_n = g.add_number("Fit operators n", 10, min=1,
                                      max=settings.max_operators, step=1)
            #: the fit menu shows the registry's words; the kind is looked up from them
            self.fit_kinds = {type_words(k): k for k in catalog.fit_kinds()}
            kinds = tuple(self.fit_kinds)
            self.fit_kind = g.add_dropdown("Fit model", kinds, initial_value=kinds[0])
            self.fit_btn = g.add_button("Fit model")
            self.diag_btn = g.add_button("Run diagnosis")
            # a running diagnosis: how far it is, and how to stop it
            self.job_bar = g.add_progress_bar(0.0, visible=False, animated=True)
            self.cancel_btn = g.add_button("Cancel the diagnosis", visible=False, color="red")
            self.report_btn = g.add_button("Download diagnosis report (HTML)", disabled=True)
            self.report_md = g.add_markdown("")
        with tabs.add_tab("Export"):
            self.dl_json = g.add_button("Download parameter set (JSON)")
            self.dl_mat = g.add_button("Download .mat")
            self.dl_c = g.add_button("Download C code")
            self.fmi = g.add_dropdown("FMI version", ("3.0", "2.0"), initial_value="3.0")
            self.dl_fmu_inv = g.add_button("Download FMU: compensator")
            self.dl_fmu_fwd = g.add_button("Download FMU: model")
            self.ps_upload = g.add_upload_button("Upload parameter set", mime_type="*/*")
            self.export_md = g.add_markdown("")
        # One plot and a view selector: the browser draws a single plotly figure and the
        # server computes only the view on show (tabs would render every figure each time).
        # The plot panel floats at the left of a wide screen, leaving the 3D cube (at the
        # scene origin, centre of the canvas) in view; on a narrow screen viser docks
        # panels, and the plot is also in the control sheet's "Plot" tab below.
        self.panel = g.add_panel()
        self.panel.float(x=10, y=10, width=PANEL_PX)
        with self.panel.add_tab("Plots"):
            self.projector = g.add_checkbox(
                "Projector: large plot", False,
                hint=f"for a screen {PROJECTOR_SCREEN_PX} px wide: the plot "
                     f"{PROJECTOR_PX} px wide, its text 16 px and larger")
            self._dd_wide = g.add_dropdown("View", tuple(TITLES.values()),
                                           initial_value=TITLES["loop"])
            # viser 1.1.1 draws the plot ``aspect`` times as high as wide (its docstring
            # says width/height; measured in Chromium: height = width * aspect).
            self._plot_wide = g.add_plotly(F.message_figure("", "computing…"), aspect=0.72,
                                           config=F.PLOT_CONFIG)
            self._notes_wide = g.add_markdown("")
            # viser puts its toasts at the top left, on this panel's view selector and plot
            # title: while the panel is shown they go where it is not (toast_css)
            self.toast_style = g.add_html(toast_css(False))
        self.narrow = False
        #: The *View* dropdown and the plot on show (the panel's, or the sheet's on a phone).
        self.view_dd, self.plot = self._dd_wide, self._plot_wide
        #: The notes under the plot on show (what the figure's ``meta.notes`` say).
        self.notes_md = self._notes_wide
        for attr, text in HINTS.items():
            handle = getattr(self, attr, None)
            if handle is not None and not getattr(handle, "hint", None):
                handle.hint = text
        self.status_md = g.add_markdown("")

    @property
    def figure_name(self) -> str:
        """Key of the figure selected in the *View* dropdown."""
        inv = {v: k for k, v in TITLES.items()}
        return inv.get(str(self.view_dd.value), "loop")

    def use_narrow(self, narrow: bool) -> bool:
        """Show the plot in the control sheet (phones) or in the floating panel; returns
        whether that changed. The caller carries the *View* choice over (guarded)."""
        if narrow == self.narrow:
            return False
        self.narrow = narrow
        self.narrow_folder.visible = narrow
        self.panel.visible = not narrow
        self.view_dd, self.plot = ((self._dd_narrow, self._plot_narrow) if narrow
                                   else (self._dd_wide, self._plot_wide))
        self.notes_md.content = ""
        self.notes_md = self._notes_narrow if narrow else self._notes_wide
        return True

    def use_projector(self, on: bool) -> None:
        """The floating plot panel at projector size (``on``) or at its usual width."""
        self.panel.float(x=10, y=10, width=PROJECTOR_PX if on else PANEL_PX)
        self.toast_style.content = toast_css(on)

    @property
    def view_dropdowns(self) -> tuple[Any, Any]:
        """Both *View* dropdowns (panel and sheet): :attr:`view_dd`, the shown one, holds the
        view; the other is given it when it is shown (:meth:`SessionView.set_narrow`)."""
        return self._dd_wide, self._dd_narrow

    def ensure_param_sliders(self, controls: ModelControls,
                             on_change: Callable[[str], Callable[[Any], None]]) -> None:
        """The model's sliders as ``controls`` describes them, one folder per group:
        rebuilt when the model's structure (or a value beyond a slider's range) asks for
        it, else moved to the values. ``on_change(path)`` gives the callback of the slider
        at ``path``. Call it with the controller's write-back guard on."""
        specs = {s.path: s for s in controls.sliders()}
        fits = all(self.param_specs[p].min <= s.value <= self.param_specs[p].max
                   for p, s in specs.items() if p in self.param_specs)
        if controls.layout != self._param_layout or not fits:
            self._rebuild(controls, on_change)
            return
        for path, spec in specs.items():
            set_value(self.param_sliders[path], float(slider_position(spec, spec.value)))
        self.param_specs = specs

    def _rebuild(self, controls: ModelControls,
                 on_change: Callable[[str], Callable[[Any], None]]) -> None:
        """The groups of ``controls``: the leading groups that show the same sliders as
        before are kept (their sliders moved to the values), the others removed and added
        (a lesson's step that only adds the initial play outputs to the model adds their
        group: every slider removed and added again cost each viser tab ~0.2 s of main
        thread mounting them, issue 33)."""
        keys = [_group_key(g) for g in controls.groups]
        keep = 0
        while (keep < min(len(keys), len(self._param_groups))
               and keys[keep] == self._param_groups[keep][0]):
            keep += 1
        for _, handles in reversed(self._param_groups[keep:]):
            for h in reversed(handles):  # the sliders and the note before their folder
                h.remove()
        self._param_groups = self._param_groups[:keep]
        specs = {s.path: s for s in controls.sliders()}
        kept = {s.path for g in controls.groups[:keep] for s in g.sliders}
        self.param_sliders = {p: h for p, h in self.param_sliders.items() if p in kept}
        for path, h in self.param_sliders.items():
            set_value(h, float(slider_position(specs[path], specs[path].value)))
        self.param_specs = {p: specs[p] for p in self.param_sliders}
        with self.param_folder:
            for group, key in zip(controls.groups[keep:], keys[keep:], strict=True):
                title = group.title + (f" ({group.unit})" if group.unit else "")
                folder = self.gui.add_folder(
                    title, expand_by_default=len(group.sliders) <= OPEN_GROUP_SLIDERS)
                handles = [folder]
                with folder:
                    if group.note:
                        handles.append(self.gui.add_markdown(f"*{group.note}*"))
                    for spec in group.sliders:
                        h = self._param_slider(spec, _hint(spec))
                        h.on_update(on_change(spec.path))
                        handles.append(h)
                        self.param_sliders[spec.path] = h
                        self.param_specs[spec.path] = spec
                self._param_groups.append((key, handles))
        self._param_layout = controls.layout

    def _param_slider(self, spec: Slider, hint: str) -> Any:
        """One parameter slider; a log one (``spec.log``) moves in ``log10`` of the value,
        with the decades marked in real values and its label saying so."""
        if not spec.log:
            return self.gui.add_slider(
                spec.label, min=spec.min, max=spec.max, step=spec.step,
                initial_value=float(spec.value), hint=hint, disabled=spec.fixed)
        lo, hi = slider_position(spec, spec.min), slider_position(spec, spec.max)
        unit = unit_text(spec.unit)
        decades = range(math.ceil(lo), math.floor(hi) + 1)
        marks = tuple((float(e), f"{10.0 ** e:g}") for e in decades)
        return self.gui.add_slider(
            f"{spec.label} (log)", min=lo, max=hi, step=log_step(spec),
            initial_value=float(slider_position(spec, spec.value)), marks=marks or None,
            hint=f"{hint}; logarithmic: the thumb moves in powers of ten"
                 + (f" of {unit}" if unit else ""), disabled=spec.fixed)


def _hint(spec: Slider) -> str:
    """The hint of a parameter slider: its label, unit, rule and whether it is fixed."""
    unit = unit_text(spec.unit)
    return (f"{spec.label}" + (f" in {unit}" if unit else "")
            + (f"; {spec.rule}" if spec.rule else "")
            + ("; a constant of this model" if spec.fixed else ""))


def _group_key(group: Any) -> tuple[Any, ...]:
    """What a slider group shows but its values: its title, unit, note and each slider's
    path, label, range, step, scale, hint and whether it is fixed (a group of equal key is
    kept across a rebuild, its sliders moved to the new values)."""
    return (group.title, group.unit, group.note, len(group.sliders) <= OPEN_GROUP_SLIDERS,
            tuple((s.path, s.label, s.min, s.max, s.step, s.log, s.fixed, _hint(s))
                  for s in group.sliders))


def _slider(g: Any, name: str, initial: float, **kw: Any) -> Any:
    """The viser slider of control ``name`` (its range from
    :data:`app.services.explore.config.CONTROLS`, shared with the checks of lessons)."""
    c = CONTROLS[name]
    label = f"{c.label} [{c.unit}]" if c.unit else c.label
    return g.add_slider(label, min=c.low, max=c.high, step=c.step, initial_value=initial, **kw)
