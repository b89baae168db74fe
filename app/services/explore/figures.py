"""Plotly figure builders shared by the viser GUI and the REST API / static page.

Every builder is a pure function of computed results (:class:`~.simulation.Result`, a
recording and a fitted output): nothing here simulates, inverts or evaluates a model.
Figures are built as plain plotly JSON (``{"data": [...], "layout": {...}}``) and wrapped
in :class:`FigureJSON`, which serialises once. The viser plot handle only needs
``figure.to_json()``, REST returns :meth:`FigureJSON.to_dict`, and the static page hands
that to ``Plotly.react``: one code path for both UIs. Skipping ``plotly.graph_objects``
validation keeps a slider update within its latency budget (building a validated
``go.Figure`` of the same content costs about 10 ms more); tests check that every figure
is valid with ``go.Figure(fig.to_dict())``.

Traces are decimated to at most :data:`MAX_POINTS` points (keeping every reversal of the
input, so loops keep their corners) and sent as base64 float32 typed arrays
(``{"dtype": "f4", "bdata": ...}``), which plotly.js decodes natively.
"""

from __future__ import annotations

import base64
import json
import re
from typing import Any

import numpy as np

from app.services.explore.simulation import (
    FULL_GRAPH_DIGITS,
    VIEWS,
    Loading,
    Result,
    decimate_index,
    operator_count,
    pi_part,
    state_text,
    visited_path,
)
from app.services.words import model_words, unit_words
from core.fitting.thresholds import reversal_indices
from core.recordings import Recording
from core.validation import filled

__all__ = [
    "MAX_POINTS",
    "PLOT_CONFIG",
    "FigureJSON",
    "closed_loop_figure",
    "decimate_index",
    "diagnosis_figure",
    "digitized_figure",
    "fit_figure",
    "fit_to_pixels",
    "inverse_figure",
    "large_text",
    "loading_figure",
    "loop_figure",
    "message_figure",
    "operators_figure",
    "pixel_index",
    "time_figure",
]

#: Largest number of points sent per trace.
MAX_POINTS = 800
#: plotly's toolbar without anything that talks to an outside service (``showLink`` and
#: ``showEditInChartStudio`` are off by default in plotly.js, and plotly.py's HTML writer
#: warns about them, so they are left out).
PLOT_CONFIG = {"displaylogo": False, "showSendToCloud": False, "plotlyServerURL": "",
               "modeBarButtonsToRemove": ["sendDataToCloud", "sendChartToCloud",
                                          "editInChartStudio"]}
#: Most filled bands in the operators view (neighbouring operators are summed beyond,
#: and the legend names the operators of each band).
MAX_BANDS = 6

_BLUE, _ORANGE, _GREEN, _RED, _GREY = "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#7f7f7f"


class FigureJSON:
    """A plotly figure as JSON, serialised once and shared by every consumer.

    Parameters
    ----------
    data : list of dict
        Plotly traces.
    layout : dict
        Plotly layout.
    """

    __slots__ = ("_json", "data", "layout")

    def __init__(self, data: list[dict[str, Any]], layout: dict[str, Any]) -> None:
        self.data = data
        self.layout = layout
        self._json: str | None = None

    def to_json(self) -> str:
        """The figure as a JSON string (cached)."""
        if self._json is None:
            self._json = json.dumps(
                {"data": self.data, "layout": self.layout}, separators=(",", ":")
            )
        return self._json

    def to_dict(self) -> dict[str, Any]:
        """``{"data": ..., "layout": ...}``."""
        return {"data": self.data, "layout": self.layout}


def _num(x: np.ndarray) -> dict[str, str]:
    """A plotly typed array (``{"dtype": "f4", "bdata": base64}``) of ``x``.

    float32 keeps 7 significant digits (plenty for a plot), encodes about 20x faster than
    a JSON list of floats and is a third of its size; NaN draws a gap.
    """
    a = np.ascontiguousarray(np.asarray(x, dtype=np.float64).astype("<f4"))
    return {"dtype": "f4", "bdata": base64.b64encode(a.tobytes()).decode("ascii")}


def values(arr: Any) -> np.ndarray:
    """Decode a trace array (plain list or typed array) back to float64 (tests, clients)."""
    if isinstance(arr, dict) and "bdata" in arr:
        return np.frombuffer(base64.b64decode(arr["bdata"]), dtype=np.dtype(arr["dtype"]))
    return np.asarray(arr, dtype=np.float64)


def _layout(title: str, **kw: Any) -> dict[str, Any]:
    lay: dict[str, Any] = {
        "title": {"text": title, "font": {"size": 14}},
        "margin": {"l": 55, "r": 15, "t": 40, "b": 45},
        "legend": {"orientation": "h", "y": -0.22},
        "template": "plotly_white",
        "uirevision": "keep",
    }
    lay.update(kw)
    # an axis without a range says autorange outright: with uirevision "keep" plotly.js
    # otherwise keeps the previous figure's fixed range, or its default -1..4, when the view
    # shown before had one (the Fit view's loop after the Loop view on the measurement's
    # range was drawn on y = -1..4)
    for key in ("xaxis", "yaxis"):
        lay.setdefault(key, {})
    for key, axis in list(lay.items()):
        if _AXIS.match(key) and isinstance(axis, dict) and "range" not in axis:
            lay[key] = {"autorange": True, **axis}
    return lay


_AXIS = re.compile(r"^[xy]axis\d*$")


def _unit(units: dict[str, str] | None, role: str) -> str:
    """The unit of ``role`` ("time", "input", "output"): the recording's, else s / a.u."""
    u = unit_words((units or {}).get(role, ""))
    return u or ("s" if role == "time" else "a.u.")


def _ax(units: dict[str, str] | None, role: str, label: str | None = None) -> dict[str, Any]:
    """An axis title with quantity and unit, e.g. ``input u [V]``."""
    if role == "time" and label is None and _unit(units, role) == "sample":
        return {"text": "sample number (the file has no time column)"}
    text = label or {"time": "time t", "input": "input u", "output": "output y"}[role]
    return {"text": f"{text} [{_unit(units, role)}]"}


def _line(x: Any, y: Any, name: str, color: str, **kw: Any) -> dict[str, Any]:
    tr = {"type": "scatter", "mode": "lines", "x": x, "y": y, "name": name,
          "line": {"color": color, "width": 2}}
    tr.update(kw)
    return tr


def message_figure(title: str, message: str) -> FigureJSON:
    """An empty figure that shows ``message`` (e.g. why a view is unavailable)."""
    return FigureJSON(
        [],
        _layout(
            title,
            xaxis={"visible": False},
            yaxis={"visible": False},
            annotations=[{"text": message, "showarrow": False, "x": 0.5, "y": 0.5,
                          "xref": "paper", "yref": "paper", "font": {"size": 13}}],
        ),
    )


def time_figure(res: Result) -> FigureJSON:
    """Input ``u(t)`` (top) and output ``y(t)`` (bottom), plus the measurement if any."""
    idx = decimate_index(res.u, MAX_POINTS)
    t = _num(res.t[idx])
    data = [
        _line(t, _num(res.u[idx]), "input u", _BLUE, xaxis="x", yaxis="y"),
        _line(t, _num(res.y[idx]), "model output y", _ORANGE, xaxis="x", yaxis="y2"),
    ]
    if res.y_measured is not None:
        data.append(_line(t, _num(res.y_measured[idx]), "measured y", _GREY, xaxis="x",
                          yaxis="y2", line={"color": _GREY, "width": 1, "dash": "dot"}))
    un = res.units
    lay = _layout(
        "Input and output in time",
        # the shared time axis under the lower plot: anchored to the upper one, its title
        # fell inside the lower plot in a short panel (viser's 470 px, issue 33)
        xaxis={"title": _ax(un, "time"), "anchor": "y2"},
        yaxis={"title": _ax(un, "input"), "domain": [0.55, 1.0], "anchor": "x"},
        yaxis2={"title": _ax(un, "output"), "domain": [0.0, 0.45], "anchor": "x"},
        # the legend at the figure's foot, under the axis title whatever the plot's height
        # (a fraction of a short plot's height put it on the title)
        legend={"orientation": "h", "yref": "container", "y": 0.0, "yanchor": "bottom"},
        margin={"l": 55, "r": 15, "t": 40, "b": 80},
    )
    return FigureJSON(data, lay)


def loop_figure(res: Result) -> FigureJSON:
    """The hysteresis loop ``y`` against ``u`` with the initial loading curve."""
    idx = decimate_index(res.u, MAX_POINTS)
    data = [_line(_num(res.u[idx]), _num(res.y[idx]), "loop y(u)", _ORANGE)]
    if res.y_measured is not None:
        data.append(_line(_num(res.u[idx]), _num(res.y_measured[idx]), "measured", _GREY,
                          line={"color": _GREY, "width": 1, "dash": "dot"}))
    m = res.model
    ld = res.loading
    if ld is not None and ld.curve_u is not None and ld.curve_y is not None:
        data.append(_line(_num(ld.curve_u), _num(ld.curve_y), "initial loading curve", _GREEN,
                          line={"color": _GREEN, "width": 1, "dash": "dash"}))
    n = operator_count(m)  # the plays of a GPI's PI part too; no "n = ?" for a map
    title = f"Hysteresis loop ({model_words(m)}{'' if n is None else f', n = {n}'})"
    yaxis: dict[str, Any] = {"title": _ax(res.units, "output")}
    note = _off_range(res) if res.y_measured is not None else None
    if note is not None:  # the measurement's range, not a model it was never fitted to
        yaxis["range"], text = note
    elif res.y_measured is not None:  # a page that showed the range above lets go of it
        yaxis["autorange"] = True
    lay = _layout(title, xaxis={"title": _ax(res.units, "input")}, yaxis=yaxis)
    if note is not None:
        lay["meta"] = {"notes": [text]}
    return FigureJSON(data, lay)


#: A model whose output spans more than this many times the measurement's (or lies
#: beside it) is drawn on the measurement's range, with a note.
OFF_RANGE = 3.0


def _off_range(res: Result) -> tuple[list[float], str] | None:
    """The measured output's range (padded 8 %) and a note, when the model's output on the
    recording's input runs far off it (a preset on a real recording: Example 1 driven at
    +-150 V spans +-380 um against the piezo's +-20 um, which flattens the measurement to
    a line); ``None`` when both fit on one plot."""
    ym = np.asarray(res.y_measured, dtype=float)
    ok = np.isfinite(ym)
    if not ok.any():
        return None
    lo, hi = float(np.min(ym[ok])), float(np.max(ym[ok]))
    y = np.asarray(res.y, dtype=float)
    y = y[np.isfinite(y)]
    span = max(hi - lo, 1e-12 * max(1.0, abs(hi)))
    if not len(y):
        return None
    mlo, mhi = float(np.min(y)), float(np.max(y))
    if mhi - mlo <= OFF_RANGE * span and mlo >= lo - span and mhi <= hi + span:
        return None
    pad = 0.08 * span
    unit = _unit(res.units, "output")
    return [lo - pad, hi + pad], (
        f"The model was not fitted to this recording: on its input the model's output "
        f"spans {mlo:.3g} to {mhi:.3g} {unit}, the measurement {lo:.3g} to {hi:.3g} {unit}. "
        "The plot shows the measurement's range; fit a model (Data section) to compare "
        "them.")


def operators_figure(res: Result) -> FigureJSON:
    """Stacked contributions ``p0 w`` and ``p_i Γ_{r_i}[w]``; their sum is ``y``.

    ``w`` is the PI's own input (:attr:`Result.pi_u`): ``u`` for a classical PI, the
    dead-zoned or enveloped input of a generalized PI, so the stack always adds up to the
    PI's output (``y`` when the PI is the last stage).
    """
    m = pi_part(res.model)
    if res.contributions is None or res.contrib_idx is None or m is None:
        return message_figure("Operator outputs", "Only available for classical PI models")
    idx = res.contrib_idx
    t = _num(res.t[idx])
    w = res.u if res.pi_u is None else res.pi_u
    mapped = w is not res.u
    stages = getattr(res.model, "stages", ())
    pi_last = not stages or stages[-1] is m
    # bands are fills without an outline (mode "none"): the colour change shows each
    # band's edge, and the browser paints one path per band instead of two
    data = [{"type": "scatter", "mode": "none", "x": t, "y": _num(m.p0 * w[idx]),
             "name": "p0·γ(u)" if mapped else "p0·u", "stackgroup": "c"}]
    # beyond MAX_BANDS operators neighbours share a band (their sum): a stack of 25
    # hairline bands is unreadable, and each filled band costs the browser ~3 ms
    groups = np.array_split(np.arange(m.n), min(m.n, MAX_BANDS))
    for grp in groups:
        a, b = int(grp[0]), int(grp[-1])
        name = (f"p{a + 1}·Γ(r={m.thresholds[a]:.3g})" if a == b else
                f"p{a + 1}…p{b + 1}·Γ(r={m.thresholds[a]:.3g}…{m.thresholds[b]:.3g})")
        data.append({"type": "scatter", "mode": "none", "x": t,
                     "y": _num(res.contributions[:, grp].sum(axis=1)), "stackgroup": "c",
                     "name": name})
    if pi_last:
        data.append(_line(t, _num(res.y[idx]), "y (sum)", "#000000",
                          line={"color": "#000000", "width": 1.5, "dash": "dot"}))
    else:  # a map after the PI: the stack is the PI's output, not y
        data.append(_line(t, _num(filled(res.pi_y)[idx]), "PI output (sum)", "#000000",
                          line={"color": "#000000", "width": 1.5, "dash": "dot"}))
    title = ("Operator contributions (stacked, on the PI's input γ(u))" if mapped
             else "Operator contributions (stacked)")
    lay = _layout(title, xaxis={"title": _ax(res.units, "time")},
                  yaxis={"title": _ax(res.units, "output", "contribution to y")},
                  showlegend=True)
    if len(groups) < m.n:
        lay["legend"] = {**lay["legend"], "title": {
            "text": f"{m.n} operators in {len(groups)} bands (neighbours summed)",
            "side": "top"}}
    return FigureJSON(data, lay)


def loading_figure(ld: Loading | None, units: dict[str, str] | None = None) -> FigureJSON:
    """Initial loading curve φ(r) with each segment's slope and the maximum loop width."""
    if ld is None:
        return message_figure("Initial loading curve", "Only available for classical PI models")
    knots, phi = ld.knots, ld.phi
    data = [_line(_num(knots), _num(phi), "φ(r)", _GREEN, mode="lines+markers")]
    ann = []
    for i in range(knots.size - 1):
        xm, ym = 0.5 * (knots[i] + knots[i + 1]), 0.5 * (phi[i] + phi[i + 1])
        ann.append({"x": xm, "y": ym, "text": f"S{i + 1}={ld.slopes[i]:.3g}",
                    "showarrow": False, "yshift": 12, "font": {"size": 10}})
    inv = "invertible" if ld.invertible else "NOT invertible (a slope ≤ 0)"
    ann.append({"x": 0.02, "y": 0.98, "xref": "paper", "yref": "paper", "showarrow": False,
                "xanchor": "left", "align": "left",
                "text": f"max loop width σ = {ld.max_loop_width:.4g}<br>{inv}"})
    lay = _layout("Initial loading curve",
                  xaxis={"title": _ax(units, "input", "input travel r")},
                  yaxis={"title": _ax(units, "output", "loading curve φ(r)")}, annotations=ann)
    return FigureJSON(data, lay)


def inverse_figure(res: Result) -> FigureJSON:
    """Inverse loop, ``P∘P⁻¹`` against the identity and the tracking error."""
    if res.v is None or res.y_comp is None:
        return message_figure("Inverse compensation", res.inverse_error or "no inverse")
    idx = decimate_index(res.u, MAX_POINTS)
    yd, v, yc = res.u[idx], res.v[idx], res.y_comp[idx]
    err = res.y_comp - res.u
    lim = [float(np.min(yd)), float(np.max(yd))]
    data = [
        _line(_num(yd), _num(v), "inverse loop v = P⁻¹(y_d)", _BLUE, xaxis="x", yaxis="y"),
        _line(_num(yd), _num(yc), "P̃∘P⁻¹", _ORANGE, xaxis="x2", yaxis="y2"),
        _line(lim, lim, "identity", _GREY, xaxis="x2", yaxis="y2",
              line={"color": _GREY, "dash": "dash", "width": 1}),
        _line(_num(res.t[idx]), _num(err[idx]), "tracking error", _RED, xaxis="x3",
              yaxis="y3"),
    ]
    rms = float(np.sqrt(np.mean(err**2)))
    span = float(np.ptp(res.u)) or 1.0
    un = res.units
    err_axis: dict[str, Any] = {"title": _ax(un, "output", "error y − y_d"), "anchor": "x3"}
    if float(np.max(np.abs(err))) < 1e-9 * span:  # exact inverse: do not zoom into rounding
        err_axis["range"] = [-0.05 * span, 0.05 * span]
    yd_title = _ax(un, "output", "desired y_d")
    lay = _layout(
        f"Inverse compensation (mismatch {res.mismatch:+.0%}, RMS error {rms:.3g})",
        xaxis={"domain": [0, 0.3], "title": yd_title, "anchor": "y"},
        yaxis={"title": _ax(un, "input", "plant input v"), "anchor": "x"},
        xaxis2={"domain": [0.36, 0.64], "title": yd_title, "anchor": "y2"},
        yaxis2={"title": _ax(un, "output", "achieved y"), "anchor": "x2"},
        xaxis3={"domain": [0.72, 1.0], "title": _ax(un, "time"), "anchor": "y3"},
        yaxis3=err_axis,
    )
    if res.inverse_warning:
        lay["annotations"] = [{
            "text": "⚠ the inverse clipped part of the input: " + _wrap(res.inverse_warning),
            "showarrow": False, "xref": "paper", "yref": "paper", "x": 0.0, "y": 1.0,
            "xanchor": "left", "yanchor": "top", "align": "left",
            "font": {"color": _RED, "size": 11}, "bgcolor": "rgba(255,255,255,0.85)"}]
        lay["meta"] = {"notes": [f"The inverse clipped part of the input: {res.inverse_warning}"]}
    return FigureJSON(data, lay)


def _wrap(text: str, width: int = 90) -> str:
    """``text`` with ``<br>`` line breaks about every ``width`` characters (annotations)."""
    import textwrap

    safe = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return "<br>".join(textwrap.wrap(safe, width))


def fit_figure(rec: Recording, y_fit: np.ndarray, label: str = "fit") -> FigureJSON:
    """Measured vs fitted output over time and the residual, plus the loop overlay; a
    recording that holds several runs of its file (extra channel ``"run position"``, see
    :mod:`app.services.analysis.loops`) is drawn with a gap between runs, never a line
    joining the end of one loop to the start of the next."""
    idx = decimate_index(rec.u, MAX_POINTS)
    res = rec.y - y_fit
    position = rec.extra.get("run position")
    cut = (np.flatnonzero(np.diff(np.asarray(position)[idx]) != 0) + 1
           if position is not None else np.zeros(0, dtype=int))

    def gapped(a: np.ndarray) -> dict[str, str]:
        return _num(np.insert(np.asarray(a, dtype=float)[idx], cut, np.nan))

    u = gapped(rec.u)
    data = [
        _line(u, gapped(rec.y), "measured", _GREY, xaxis="x", yaxis="y"),
        _line(u, gapped(y_fit), label, _ORANGE, xaxis="x", yaxis="y"),
        _line(gapped(rec.t), gapped(res), "residual y − ŷ", _RED, xaxis="x2", yaxis="y2"),
    ]
    rms = float(np.sqrt(np.mean(res**2)))
    un = dict(rec.units)
    return FigureJSON(data, _loop_and_residual_layout(
        f"Fit overlay and residual (RMS {rms:.3g} {_unit(un, 'output')})", un,
        "residual y − ŷ"))


def _loop_and_residual_layout(title: str, un: dict[str, str], residual: str
                              ) -> dict[str, Any]:
    """Loop (output against input) at the left, a residual in time at the right."""
    return _layout(
        title,
        xaxis={"domain": [0, 0.46], "title": _ax(un, "input"), "anchor": "y"},
        yaxis={"title": _ax(un, "output"), "anchor": "x"},
        xaxis2={"domain": [0.54, 1.0], "title": _ax(un, "time"), "anchor": "y2"},
        yaxis2={"title": _ax(un, "output", residual), "anchor": "x2"},
    )


def diagnosis_figure(rec: Recording, y_base: np.ndarray, y_final: np.ndarray,
                     base_label: str, final_label: str,
                     heldout: tuple[float, float] | None = None) -> FigureJSON:
    """Before / after a diagnosis: the loops (measured, the base model, the model with the
    effects found) and their residuals in time, in the recording's units.

    Parameters
    ----------
    rec : Recording
        The diagnosed recording (time, input, output and their units).
    y_base, y_final : ndarray of shape (N,)
        The base model's and the final model's simulated outputs.
    base_label, final_label : str
        Legend names of the two models.
    heldout : (float, float), optional
        The diagnosis's held-out RMS errors before and after (output units): the numbers
        its findings give, so the title says the same (without them, the RMS of the
        residuals drawn, over every row).
    """
    idx = decimate_index(rec.u, MAX_POINTS)
    t, u = _num(rec.t[idx]), _num(rec.u[idx])
    un = dict(rec.units)
    eb, ef = rec.y - y_base, rec.y - y_final
    rb, rf = float(np.sqrt(np.mean(eb**2))), float(np.sqrt(np.mean(ef**2)))
    yu = _unit(un, "output")
    data = [
        _line(u, _num(rec.y[idx]), "measured", _GREY, xaxis="x", yaxis="y"),
        _line(u, _num(y_base[idx]), f"before: {base_label}", _RED, xaxis="x", yaxis="y",
              line={"color": _RED, "width": 1.5}),
        _line(u, _num(y_final[idx]), f"after: {final_label}", _BLUE, xaxis="x", yaxis="y",
              line={"color": _BLUE, "width": 1.5}),
        _line(t, _num(eb[idx]), f"residual before (RMS {rb:.3g} {yu})", _RED, xaxis="x2",
              yaxis="y2", line={"color": _RED, "width": 1}),
        _line(t, _num(ef[idx]), f"residual after (RMS {rf:.3g} {yu})", _BLUE, xaxis="x2",
              yaxis="y2", line={"color": _BLUE, "width": 1}),
    ]
    if heldout is not None:  # one "after" number on the screen: the findings' own
        title = (f"Diagnosis: before and after (held-out RMS {heldout[0]:.3g} → "
                 f"{heldout[1]:.3g} {yu})")
        data[3]["name"], data[4]["name"] = "residual before", "residual after"
    else:
        title = f"Diagnosis: before and after (residual RMS {rb:.3g} → {rf:.3g} {yu})"
    return FigureJSON(data, _loop_and_residual_layout(title, un, "residual measured − model"))


def _matrix_text(name: str, m: np.ndarray) -> str:
    rows = ["  ".join(f"{v:8.4g}" for v in row) for row in m]
    return f"{name} = [" + "<br>   ".join(rows) + "]"


def digitized_figure(res: Result, highlight: int | None = None) -> FigureJSON:
    """Digitized PI view: state graph in the loop plane, digit rows in time, error.

    Parameters
    ----------
    res : Result
        A result whose ``digitized`` view exists (else a message figure).
    highlight : int, optional
        Trace row to highlight (default: the final state).
    """
    d = res.digitized
    if d is None:
        why = res.messages[0] if res.messages else "not available for this model"
        return message_figure("Digitized PI state diagram", why)
    tr, n = d.trace, d.model.n
    k = len(tr.sample) - 1 if highlight is None else int(np.clip(highlight, 0, len(tr.sample) - 1))
    cur = "".join(str(int(b)) for b in tr.digits[k][::-1])  # paper notation b_n ... b_1
    data: list[dict[str, Any]] = []
    g = d.graph
    shown = ""
    if n > FULL_GRAPH_DIGITS:  # the states the input visited, each named, and its moves
        states, up, down, first = visited_path(tr.digits)
        vx, vy = tr.x_b[first], tr.y_b[first]
        for pairs, color, name in ((up, _BLUE, "rising"), (down, _ORANGE, "falling")):
            if len(pairs):
                nan = np.full(len(pairs), np.nan)
                data.append(_line(
                    _num(np.column_stack((vx[pairs[:, 0]], vx[pairs[:, 1]], nan)).ravel()),
                    _num(np.column_stack((vy[pairs[:, 0]], vy[pairs[:, 1]], nan)).ravel()),
                    f"input {name}", color, xaxis="x", yaxis="y", showlegend=False,
                    line={"color": color, "width": 1.5}, hoverinfo="skip"))
        names = [state_text(r) for r in states]
        data.append({"type": "scatter", "mode": "markers+text" if len(names) <= 40
                     else "markers", "x": _num(vx), "y": _num(vy), "text": names,
                     "textposition": "top left", "textfont": {"size": 11},
                     "name": f"{len(names)} visited states", "hovertext": names,
                     "marker": {"size": 7, "color": _GREY}, "xaxis": "x", "yaxis": "y"})
        shown = (f"<br>the {len(names)} of {2**n} states the input visited; "
                 "blue: the input rising, orange: falling")
    elif g is not None:
        e = np.concatenate((g.up, g.down))
        nan = np.full(len(e), np.nan)
        ex = np.column_stack((g.x[e[:, 0]], g.x[e[:, 1]], nan)).ravel()
        ey = np.column_stack((g.y[e[:, 0]], g.y[e[:, 1]], nan)).ravel()
        data.append({"type": "scatter", "mode": "lines", "x": _num(ex), "y": _num(ey),
                     "name": "edges",
                     "line": {"color": "#cccccc", "width": 1}, "hoverinfo": "skip",
                     "xaxis": "x", "yaxis": "y"})
        show_text = n <= 5
        data.append({"type": "scatter", "mode": "markers+text" if show_text else "markers",
                     "x": _num(g.x), "y": _num(g.y), "text": g.strings,
                     "textposition": "top left", "textfont": {"size": 12},
                     "name": f"{2**n} states", "marker": {"size": 5 if n > 6 else 7,
                                                          "color": _GREY},
                     "hovertext": g.strings, "xaxis": "x", "yaxis": "y"})
    if n <= FULL_GRAPH_DIGITS:
        data.append(_line(_num(tr.x_b), _num(tr.y_b), "visited states", _BLUE,
                          mode="lines+markers", xaxis="x", yaxis="y", marker={"size": 5}))
    data.append({"type": "scatter", "mode": "markers+text", "x": [float(tr.x_b[k])],
                 "y": [float(tr.y_b[k])], "text": [cur], "textposition": "bottom right",
                 "textfont": {"size": 14, "color": _RED},
                 "name": "current state", "marker": {"size": 14, "color": _RED,
                                                     "symbol": "circle-open",
                                                     "line": {"width": 3}},
                 "xaxis": "x", "yaxis": "y"})
    # digit rows over time, drawn like a logic analyser: row i sits at height i and
    # steps up by 0.7 while b_{i+1} = 1 (state j is active from sample[j]). One trace
    # with gaps between the rows: cheap to draw, and no image (a heatmap would be an
    # inline data: image, which a strict Content-Security-Policy blocks).
    t_rows = res.t[np.minimum(tr.sample, res.t.size - 1)]
    t_rows = np.append(t_rows, res.t[-1])
    bits = np.vstack((tr.digits, tr.digits[-1:])).astype(float)  # (rows + 1, n)
    m = t_rows.size
    xs = np.full((n, m + 1), np.nan)
    ys = np.full((n, m + 1), np.nan)
    xs[:, :m] = t_rows
    ys[:, :m] = np.arange(n)[:, None] + 0.7 * bits.T
    data.append({"type": "scatter", "mode": "lines", "x": _num(xs.ravel()),
                 "y": _num(ys.ravel()), "name": "digits", "line": {"shape": "hv",
                                                                    "color": _BLUE, "width": 2},
                 "connectgaps": False, "hoverinfo": "skip", "xaxis": "x2", "yaxis": "y2"})
    idx = decimate_index(res.u, MAX_POINTS)
    err = d.y - d.y_classical
    data.append(_line(_num(res.t[idx]), _num(err[idx]), "digitized − classical", _RED,
                      xaxis="x3", yaxis="y3"))
    span = float(np.ptp(d.y)) or 1.0
    un = res.units
    err_axis: dict[str, Any] = {"domain": [0.3, 0.56], "anchor": "x3",
                                "title": _ax(un, "output", "error")}
    if float(np.max(np.abs(err))) < 1e-9 * span:  # identical: do not zoom into rounding
        err_axis["range"] = [-0.05 * span, 0.05 * span]
    t_k = float(res.t[min(int(tr.sample[k]), res.t.size - 1)])
    H = d.H
    txt = _matrix_text("H", H) + "<br>" + _matrix_text("H⁻¹", H[::-1])
    bound = float(d.model.reversal_error_bound())
    lay = _layout(
        f"Digitized PI: n = {n} digits, state {cur} (max |error| "
        f"{float(np.max(np.abs(err))):.3g}, bound {bound:.3g}){shown}",
        xaxis={"domain": [0, 0.5], "title": _ax(un, "input", "state X (input)"),
               "anchor": "y"},
        yaxis={"domain": [0.3, 1.0], "title": _ax(un, "output", "state Y (output)"),
               "anchor": "x"},
        xaxis2={"domain": [0.58, 1.0], "anchor": "y2", "showticklabels": False},
        yaxis2={"domain": [0.62, 1.0], "anchor": "x2", "title": {"text": "digits b_i"},
                "tickvals": list(range(n)) if n <= 12 else list(range(0, n, 4)),
                "ticktext": [f"b{i + 1}" for i in (range(n) if n <= 12 else range(0, n, 4))],
                "range": [-0.3, n], "zeroline": False, "showgrid": False},
        xaxis3={"domain": [0.58, 1.0], "anchor": "y3", "matches": "x2",
                "title": _ax(un, "time")},
        # the current state's time, across the digit rows and the error
        shapes=[{"type": "line", "xref": xr, "yref": f"{yr} domain", "x0": t_k, "x1": t_k,
                 "y0": 0, "y1": 1, "line": {"color": _RED, "width": 2}}
                for xr, yr in (("x2", "y2"), ("x3", "y3"))],
        yaxis3=err_axis,
        annotations=[{"text": txt, "showarrow": False, "xref": "paper", "yref": "paper",
                      "x": 0.0, "y": 0.15, "xanchor": "left", "yanchor": "top", "align": "left",
                      "font": {"family": "monospace", "size": 10}}],
        legend={"orientation": "h", "x": 0.56, "y": 0.15, "xanchor": "left", "yanchor": "top",
                "font": {"size": 10}},
        margin={"l": 55, "r": 15, "t": 62 if shown else 40, "b": 10},
    )
    return FigureJSON(data, lay)


def closed_loop_figure(res: Result) -> FigureJSON:
    """Paper 001 Fig. 16: reference vs plant output and tracking error, ± inverse."""
    cl, msg = res.closed_loop, res.closed_loop_note
    if cl is None:
        return message_figure("Closed loop", msg or "unavailable")
    colors = {"no compensation": _RED, "inverse feedforward": _GREEN,
              "inverse + reference feedforward": _BLUE}
    first = next(iter(cl.runs.values()))
    idx = decimate_index(first.r, MAX_POINTS)
    t = _num(first.t[idx])
    data = [_line(t, _num(first.r[idx]), "reference r", _GREY, xaxis="x", yaxis="y",
                  line={"color": _GREY, "dash": "dash", "width": 1.5})]
    parts = []
    for name, run in cl.runs.items():
        c = colors.get(name, _BLUE)
        data.append(_line(t, _num(run.y_o[idx]), f"output, {name}", c, xaxis="x", yaxis="y"))
        data.append(_line(t, _num(run.e[idx]), f"error, {name}", c, xaxis="x", yaxis="y2",
                          showlegend=False))
        parts.append(f"{name}: RMS {run.rms_error(0.0):.3g}")
    title = "Closed loop (paper 001 Fig. 15-16, mismatch {:+.0%}): {}".format(
        res.mismatch, "; ".join(parts))
    if msg:
        title += f" — {msg}"
    lay = _layout(
        title,
        xaxis={"title": _ax(res.units, "time"), "anchor": "y2"},
        yaxis={"title": _ax(res.units, "output", "plant output y_o"), "domain": [0.45, 1.0]},
        yaxis2={"title": _ax(res.units, "output", "error r − y_o"), "domain": [0.0, 0.37],
                "anchor": "x"},
    )
    lay["title"]["font"] = {"size": 12}
    if cl.explanation:  # the page prints meta.notes under the plot
        lay["meta"] = {"notes": [cl.explanation]}
    return FigureJSON(data, lay)


def _title_lines(text: str, room: int) -> list[str]:
    """``text`` broken at spaces into lines of at most ``room`` characters (a word longer
    than that keeps its own line)."""
    lines: list[str] = []
    for part in text.split("<br>"):
        line = ""
        for word in part.split(" "):
            if line and len(f"{line} {word}") > room:
                lines.append(line)
                line = word
            else:
                line = f"{line} {word}" if line else word
        lines.append(line)
    return lines


def large_text(fig: FigureJSON, size: int = 16, width: int | None = None) -> FigureJSON:
    """``fig`` with every text at least ``size`` px (a projector): tick labels, axis titles,
    legend; the title 4 px larger, broken into lines when a plot ``width`` px wide cannot
    hold it. The web page does the same in ``static/plots.js::largeText``."""
    lay = json.loads(json.dumps(fig.layout))
    lay["font"] = {**lay.get("font", {}), "size": size}
    title = lay.get("title")
    extra = 0
    if isinstance(title, dict):
        title["font"] = {**title.get("font", {}), "size": size + 4}
        text = title.get("text")
        if width and isinstance(text, str):
            lines = _title_lines(text, max(10, int((width - 40) / (0.56 * (size + 4)))))
            title["text"] = "<br>".join(lines)
            extra = (len(lines) - 1) * int(1.3 * (size + 4))
    legend = {**lay.get("legend", {}), "font": {"size": size}}
    below = (legend.get("yref") == "container" and float(legend.get("y", 1.0)) < 0.5) \
        or float(legend.get("y", 1.0)) < 0
    if below:  # below the plot: there the larger axis title sits on it; above the
        # plot, under the title, it has room of its own
        legend.update(orientation="h", x=0.0, xanchor="left", y=1.02, yanchor="bottom",
                      yref="paper")
        margin = lay.get("margin") or {}
        lay["margin"] = {**margin, "t": max(int(margin.get("t", 0) or 0), 4 * size + 50)}
    if extra:
        margin = lay.get("margin") or {}
        lay["margin"] = {**margin, "t": int(margin.get("t", 60) or 60) + extra}
    lay["legend"] = legend
    for k, ax in lay.items():
        if k.startswith(("xaxis", "yaxis")) and isinstance(ax, dict):
            ax["tickfont"] = {**ax.get("tickfont", {}), "size": size}
            if isinstance(ax.get("title"), dict):
                ax["title"]["font"] = {**ax["title"].get("font", {}), "size": size + 2}
    for a in lay.get("annotations", []) or []:
        a["font"] = {**a.get("font", {}), "size": max(size, a.get("font", {}).get("size", 0))}
    return FigureJSON(fig.data, lay)


#: Height of plotly's toolbar row at the top right of a plot, CSS px.
TOOLBAR_PX = 36


def below_toolbar(fig: FigureJSON, width: int) -> FigureJSON:
    """``fig`` with its title under plotly's toolbar (a row of about 30 px at the top
    right, where a centred title of a plot ``width`` px wide ran under it): the title at
    the figure's top, padded by the row, broken into lines the width holds, and the top
    margin grown to hold it. The web page does the same (``static/plots.js``
    ``belowToolbar``)."""
    title = fig.layout.get("title")
    if not isinstance(title, dict) or not isinstance(title.get("text"), str) \
            or not title["text"]:
        return fig
    lay = json.loads(json.dumps(fig.layout))
    size = int((title.get("font") or {}).get("size") or 17)  # plotly's title size
    text = title["text"]
    if "<br>" not in text:
        text = "<br>".join(_title_lines(text, max(10, int((width - 40) / (0.56 * size)))))
    lines = text.count("<br>") + 1
    lay["title"] = {**lay["title"], "text": text, "x": 0.5, "xanchor": "center", "y": 1,
                    "yref": "container", "yanchor": "top", "pad": {"t": TOOLBAR_PX}}
    margin = lay.get("margin") or {}
    lay["margin"] = {**margin, "t": max(int(margin.get("t") or 0),
                                        TOOLBAR_PX + int(lines * size * 1.3) + 12)}
    _legend_at_foot(lay, fig.data, width)
    return FigureJSON(fig.data, lay)


def _legend_at_foot(lay: dict[str, Any], data: list[dict[str, Any]], width: int) -> None:
    """A legend below the plot (at a fraction of the plot's height, the layouts' default)
    moved to the figure's foot in container coordinates, the bottom margin grown to hold the
    x-axis title and the legend's rows (in a short plot the fraction put the legend on the
    axis title: viser's 470 px panel, "input u [a.u.]" on "initial loading curve")."""
    legend = lay.get("legend")
    if not isinstance(legend, dict) or legend.get("yref") == "container" \
            or float(legend.get("y", 1.0)) >= 0:
        return
    names = [str(t.get("name") or "") for t in data
             if t.get("showlegend", True) is not False and t.get("name")]
    if not names:
        return
    # an entry is its symbol (about 40 px) and its text (about 0.56 em of 12 px a letter)
    px = sum(40 + 0.56 * 12 * len(n) for n in names)
    rows = max(1, int(np.ceil(px / max(100, width - 40))))
    lay["legend"] = {**legend, "yref": "container", "y": 0.0, "yanchor": "bottom"}
    margin = lay.get("margin") or {}
    lay["margin"] = {**margin, "b": max(int(margin.get("b") or 0), 52 + 22 * rows)}


def stack_columns(fig: FigureJSON, compact: bool = False) -> tuple[FigureJSON, int]:
    """``fig`` with its side-by-side panels stacked top to bottom (narrow plots).

    Panels are the groups of axes whose x axes share a horizontal domain; each gets a
    band of the height, in order of appearance, and every x axis spans the full width.
    ``compact`` (a phone) also drops the legend and the monospace side notes (the
    digitized view's matrices, which the GUI prints as text). Returns the new figure and
    the number of bands (1: ``fig`` itself, unchanged). The web page does the same in
    ``static/plots.js::fitLayout``.
    """
    lay = fig.layout
    xs = [k for k in lay if k.startswith("xaxis") and isinstance(lay[k], dict)]
    cols: list[tuple[float, ...]] = []
    col_of: dict[str, int] = {}
    for k in xs:
        d = tuple(lay[k].get("domain", (0.0, 1.0)))
        if d not in cols:
            cols.append(d)
        col_of[k] = cols.index(d)
    if len(cols) < 2:
        if not compact:
            return fig, 1
        return FigureJSON(fig.data, {**lay, "showlegend": False}), 1
    new = json.loads(json.dumps(lay))
    band = 1.0 / len(cols)
    gap = 0.25 * band  # room for tick labels and an axis title
    for k in xs:
        new[k]["domain"] = [0.0, 1.0]
    for k in [k for k in new if k.startswith("yaxis") and isinstance(new[k], dict)]:
        anchor = str(new[k].get("anchor", "x"))
        c = col_of.get("xaxis" + (anchor[1:] if anchor.startswith("x") else ""), 0)
        a, b = new[k].get("domain", (0.0, 1.0))
        top = 1.0 - c * band
        bottom = top - band + gap
        new[k]["domain"] = [bottom + a * (top - bottom), bottom + b * (top - bottom)]
    new["margin"] = {**new.get("margin", {}), "l": 50, "r": 10}
    # side notes in monospace (the digitized view's matrices) have no room left
    new["annotations"] = [a for a in new.get("annotations", [])
                          if a.get("font", {}).get("family") != "monospace"]
    if compact:
        new["showlegend"] = False
    elif "legend" in new:
        new["legend"] = {**new["legend"], "x": 0.0, "y": -0.06, "xanchor": "left",
                         "yanchor": "top"}
        new["margin"]["b"] = max(int(new["margin"].get("b", 45)), 70)
    if "title" in new:
        new["title"] = {**new["title"], "font": {"size": 11}}
    return FigureJSON(fig.data, new), len(cols)


#: Largest distance, in CSS px of the drawn plot, between a trace's line and the samples
#: :func:`fit_to_pixels` leaves out (a quarter pixel: below what antialiasing shows).
PIXEL_TOL = 0.25
#: Traces with fewer points are left whole (nothing to gain).
PIXEL_MIN_POINTS = 64


def pixel_index(x: np.ndarray, y: np.ndarray, tol: float = PIXEL_TOL) -> np.ndarray:
    """Indices of the samples of the polyline ``(x, y)`` (in pixels) that draw it to within
    ``tol`` pixels.

    Every extremum of ``x`` and of ``y`` (a reversal of the input on a loop, a peak in
    time; :func:`~core.fitting.thresholds.reversal_indices` of travel above ``tol``, so
    float noise on a plateau is not one) is kept exactly, as are the ends and each NaN (a
    gap) with its neighbours; between them the Ramer-Douglas-Peucker rule keeps the sample
    farthest from the chord while it is farther than ``tol`` (distance to the segment, so a
    curve turning back beyond its chord keeps its turn), every segment at once, level by
    level.

    Parameters
    ----------
    x, y : ndarray of shape (N,)
        The points in pixels (any offset).
    tol : float
        Largest distance, px, of a left-out sample from the drawn line.

    Returns
    -------
    ndarray of int
        Sorted indices, ``0`` and ``N - 1`` among them.
    """
    n = int(x.size)
    keep = np.zeros(n, dtype=bool)
    if n <= 2:
        keep[:] = True
        return np.flatnonzero(keep)
    keep[[0, -1]] = True
    bad = ~(np.isfinite(x) & np.isfinite(y))
    if bad.any():  # a gap: the NaN and the samples on each side of it
        keep |= bad | np.r_[bad[1:], False] | np.r_[False, bad[:-1]]
    for v in (x, y):  # its extrema (reversals of more than tol px: not float noise)
        keep[reversal_indices(np.where(bad, 0.0, v), tol)] = True
    while True:  # one level of the rule for every segment at once
        idx = np.flatnonzero(keep)
        inner = np.flatnonzero(~keep)
        if inner.size == 0:
            break
        seg = np.searchsorted(idx, inner) - 1  # the segment idx[seg] .. idx[seg + 1]
        a, b = idx[seg], idx[seg + 1]
        px, py = x[inner] - x[a], y[inner] - y[a]
        dx, dy = x[b] - x[a], y[b] - y[a]
        len2 = dx * dx + dy * dy
        t = np.clip((px * dx + py * dy) / np.where(len2 > 0, len2, 1.0), 0.0, 1.0)
        dist2 = (px - t * dx) ** 2 + (py - t * dy) ** 2
        starts = np.flatnonzero(np.r_[True, seg[1:] != seg[:-1]])
        worst = np.maximum.reduceat(dist2, starts)
        group = np.cumsum(np.r_[False, seg[1:] != seg[:-1]])
        far = (dist2 == worst[group]) & (dist2 > tol * tol)
        if not far.any():
            break
        _, first = np.unique(group[far], return_index=True)
        keep[inner[far][first]] = True
    return np.flatnonzero(keep)


#: Trace keys whose arrays run along the points (a trace with one of them as an array is
#: left whole by :func:`fit_to_pixels`).
_PER_POINT = ("text", "hovertext", "customdata", "ids", "error_x", "error_y")


def _axis_span(lay: dict[str, Any], key: str, lo: float, hi: float) -> float | None:
    """The data span a trace's axis ``key`` shows: the trace's own span, or the axis's
    fixed range when narrower; ``None`` for an axis not drawn linearly."""
    got = lay.get(key)
    ax: dict[str, Any] = got if isinstance(got, dict) else {}
    if ax.get("type") not in (None, "linear", "-"):
        return None
    span = hi - lo
    r = ax.get("range")
    if isinstance(r, (list, tuple)) and len(r) == 2:
        try:
            span = min(span, abs(float(r[1]) - float(r[0])))
        except (TypeError, ValueError):
            return None
    return span


def _cuttable(tr: dict[str, Any]) -> tuple[np.ndarray, np.ndarray] | None:
    """A trace's ``(x, y)`` as float64 when :func:`fit_to_pixels` may cut it: a solid line
    of straight segments (a step or spline shape would be drawn otherwise between the kept
    samples) without markers or per-point arrays, at least :data:`PIXEL_MIN_POINTS` samples
    (a stack's only vertically and without a norm); else ``None``."""
    if tr.get("type", "scatter") != "scatter" or "markers" in str(tr.get("mode", "lines")) \
            or any(isinstance(tr.get(k), (list, dict)) for k in _PER_POINT) \
            or "x" not in tr or "y" not in tr \
            or (tr.get("line") or {}).get("dash", "solid") != "solid" \
            or (tr.get("line") or {}).get("shape", "linear") != "linear" \
            or (tr.get("stackgroup") and (tr.get("orientation") == "h"
                                          or tr.get("groupnorm"))):
        return None
    try:  # (a plain list of text is left whole; None in one is a gap, NaN)
        x, y = values(tr["x"]).astype(np.float64), values(tr["y"]).astype(np.float64)
    except (TypeError, ValueError):
        return None
    if x.ndim == y.ndim == 1 and x.size == y.size and x.size >= PIXEL_MIN_POINTS:
        return x, y
    return None


def fit_to_pixels(fig: FigureJSON, width: float, height: float,
                  tol: float = PIXEL_TOL) -> FigureJSON:
    """``fig`` with each line trace cut to the samples a plot ``width`` x ``height`` CSS px
    draws (:func:`pixel_index`: within ``tol`` px; extrema, reversals and gaps exact).

    Each trace is measured on its own span of data mapped to the whole figure (an axis
    spans at least its traces' data, and a panel at most the figure), so the drawn error
    is at most ``tol`` px on any axis range plotly picks (an axis's fixed range is taken
    when narrower). Traces with markers, per-point text, a dashed line (its dashes run
    along the path's length, which a cut shortens by a fraction of a pixel per sample left
    out: they would shift) or non-linear axes are left whole.

    Parameters
    ----------
    fig : FigureJSON
        The figure (traces as :func:`_num` typed arrays or lists).
    width, height : float
        The drawn figure's size, CSS px (the largest it is shown at).
    tol : float
        Largest distance, px, between the drawn line and a left-out sample.

    Returns
    -------
    FigureJSON
        A new figure sharing ``fig``'s layout (``fig`` itself when nothing was cut).
    """
    lines: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for i, tr in enumerate(fig.data):
        xy = _cuttable(tr)
        if xy is not None:
            lines[i] = xy
    # a stack's bands, and the traces on its x array (its sum), keep one set of samples
    # (the bands add up sample by sample), or all stay whole when one of them must;
    # every other trace is cut on its own
    on_x = {(x.tobytes(), str(fig.data[i].get("xaxis", "x"))) for i, (x, _) in lines.items()
            if fig.data[i].get("stackgroup")}
    groups: dict[tuple[bytes, str], list[int]] = {}
    for i, (x, _) in lines.items():
        key = (x.tobytes(), str(fig.data[i].get("xaxis", "x")))
        groups.setdefault(key if key in on_x else (b"%d" % i, ""), []).append(i)
    for i, tr in enumerate(fig.data):  # a trace left whole on a stack's x: the stack too
        if i not in lines and "x" in tr:
            try:
                xb = values(tr["x"]).astype(np.float64).tobytes()
            except (TypeError, ValueError):
                continue
            groups.pop((xb, str(tr.get("xaxis", "x"))), None)
    stacks: dict[str, set[tuple[bytes, str]]] = {}
    for key, members in groups.items():
        for i in members:
            if fig.data[i].get("stackgroup"):
                stacks.setdefault(str(fig.data[i]["stackgroup"]), set()).add(key)
    data = list(fig.data)
    cut = False
    for members in groups.values():
        x = lines[members[0]][0]
        if any(len(stacks.get(str(fig.data[i].get("stackgroup")), ())) > 1 for i in members
               if fig.data[i].get("stackgroup")):
            continue  # a stack over several x arrays: its sums need every sample
        keep = _group_index(fig, members, lines, width, height, tol)
        if keep is None or keep.size == x.size:
            continue
        for i in members:
            data[i] = {**fig.data[i], "x": _num(x[keep]), "y": _num(lines[i][1][keep])}
        cut = True
    return FigureJSON(data, fig.layout) if cut else fig


def _group_index(fig: FigureJSON, members: list[int],
                 lines: dict[int, tuple[np.ndarray, np.ndarray]], width: float,
                 height: float, tol: float) -> np.ndarray | None:
    """The samples that draw every trace of ``members`` (one x array) within ``tol`` px:
    the union of each drawn line's :func:`pixel_index` (a stacked trace drawn at its
    running sum); ``None`` when an axis is not linear."""
    x = lines[members[0]][0]
    sums: dict[str, np.ndarray] = {}
    keep = np.zeros(x.size, dtype=bool)
    for i in members:
        tr = fig.data[i]
        y = lines[i][1]
        if tr.get("stackgroup"):
            g = str(tr["stackgroup"])
            y = sums[g] = sums.get(g, 0.0) + np.nan_to_num(y)
        ok = np.isfinite(x) & np.isfinite(y)
        if not ok.any():
            keep[:] = True
            continue
        sx = _axis_span(fig.layout, "xaxis" + str(tr.get("xaxis", "x"))[1:],
                        float(x[ok].min()), float(x[ok].max()))
        sy = _axis_span(fig.layout, "yaxis" + str(tr.get("yaxis", "y"))[1:],
                        float(y[ok].min()), float(y[ok].max()))
        if sx is None or sy is None:
            return None
        keep[pixel_index(x * (width / sx if sx > 0 else 0.0),
                         y * (height / sy if sy > 0 else 0.0), tol)] = True
    return np.flatnonzero(keep)


#: Names of the figures :func:`build` can build (one per view of
#: :func:`app.services.explore.simulation.compute`).
FIGURES = VIEWS


def build(name: str, res: Result) -> FigureJSON:
    """Build the figure ``name`` (one of :data:`FIGURES`) from ``res``.

    ``res`` must have been computed for that view (``compute(..., views=[name])``); a
    figure of a view it was not computed for says so.
    """
    if name not in FIGURES:
        raise KeyError(name)
    if name not in res.views:
        return message_figure(name, f"the {name} view was not computed for this result")
    if name == "time":
        return time_figure(res)
    if name == "loop":
        return loop_figure(res)
    if name == "operators":
        return operators_figure(res)
    if name == "loading":
        return loading_figure(res.loading, res.units)
    if name == "inverse":
        return inverse_figure(res)
    if name == "digitized":
        return digitized_figure(res)
    return closed_loop_figure(res)
