"""Plotly figure builders shared by the viser GUI and the REST API / static page.

Figures are built as plain plotly JSON (``{"data": [...], "layout": {...}}``) and wrapped
in :class:`FigureJSON`, which serialises once. The viser plot handle only needs
``figure.to_json()``, REST returns :meth:`FigureJSON.to_dict`, and the static page hands
that to ``Plotly.react``: one code path for both UIs. Skipping ``plotly.graph_objects``
validation keeps a slider update within its latency budget (building a validated
``go.Figure`` of the same content costs about 10 ms more); tests check that every figure
is valid with ``go.Figure(fig.to_dict())``.

Traces are decimated to at most :data:`MAX_POINTS` points (keeping every reversal of the
input, so loops keep their corners) and rounded to 5 significant digits.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from core.base import Model

from .state import Recording, Result, pi_part

__all__ = [
    "MAX_POINTS",
    "FigureJSON",
    "decimate_index",
    "fit_figure",
    "inverse_figure",
    "loading_figure",
    "loop_figure",
    "message_figure",
    "operators_figure",
    "time_figure",
]

#: Largest number of points sent per trace.
MAX_POINTS = 1500
#: Points per stacked operator-contribution trace.
MAX_POINTS_STACKED = 400

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


def _num(x: np.ndarray) -> list[float | None]:
    """Round to 5 significant digits and convert to a JSON list (non-finite -> null)."""
    a = np.asarray(x, dtype=np.float64)
    scale = float(np.nanmax(np.abs(a))) if a.size and np.isfinite(a).any() else 1.0
    dec = int(max(0, 4 - np.floor(np.log10(scale)))) if scale > 0 else 4
    r = np.round(a, dec)
    if np.isfinite(r).all():
        return r.tolist()
    return [float(v) if np.isfinite(v) else None for v in r]


def decimate_index(u: np.ndarray, max_points: int = MAX_POINTS) -> np.ndarray:
    """Indices of at most about ``max_points`` samples, always keeping input reversals.

    Parameters
    ----------
    u : ndarray of shape (N,)
        The input whose turning points must survive (loop corners).
    max_points : int
        Target number of points.

    Returns
    -------
    ndarray of int
        Sorted unique indices including ``0`` and ``N - 1``.
    """
    n = int(u.size)
    if n <= max_points:
        return np.arange(n)
    stride = int(np.ceil(n / max_points))
    base = np.arange(0, n, stride)
    d = np.sign(np.diff(u))
    turns = np.flatnonzero(d[1:] * d[:-1] < 0) + 1
    if turns.size > max_points // 2:
        turns = turns[:: int(np.ceil(2 * turns.size / max_points))]
    return np.unique(np.concatenate((base, turns, [n - 1])))


def _layout(title: str, **kw: Any) -> dict[str, Any]:
    lay: dict[str, Any] = {
        "title": {"text": title, "font": {"size": 14}},
        "margin": {"l": 55, "r": 15, "t": 40, "b": 45},
        "legend": {"orientation": "h", "y": -0.18},
        "template": "plotly_white",
        "uirevision": "keep",
    }
    lay.update(kw)
    return lay


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
    idx = decimate_index(res.u)
    t = _num(res.t[idx])
    data = [
        _line(t, _num(res.u[idx]), "input u", _BLUE, xaxis="x", yaxis="y"),
        _line(t, _num(res.y[idx]), "model output y", _ORANGE, xaxis="x", yaxis="y2"),
    ]
    if res.y_measured is not None:
        data.append(_line(t, _num(res.y_measured[idx]), "measured y", _GREY, xaxis="x",
                          yaxis="y2", line={"color": _GREY, "width": 1, "dash": "dot"}))
    lay = _layout(
        "Input and output in time",
        xaxis={"title": {"text": "t [s]"}, "anchor": "y"},
        yaxis={"title": {"text": "u"}, "domain": [0.55, 1.0]},
        yaxis2={"title": {"text": "y"}, "domain": [0.0, 0.45], "anchor": "x"},
    )
    return FigureJSON(data, lay)


def loop_figure(res: Result) -> FigureJSON:
    """The hysteresis loop ``y`` against ``u`` with the initial loading curve."""
    idx = decimate_index(res.u)
    data = [_line(_num(res.u[idx]), _num(res.y[idx]), "loop y(u)", _ORANGE)]
    if res.y_measured is not None:
        data.append(_line(_num(res.u[idx]), _num(res.y_measured[idx]), "measured", _GREY,
                          line={"color": _GREY, "width": 1, "dash": "dot"}))
    m = res.model
    pi = pi_part(m)
    if pi is not None and pi is m:
        umax = float(np.max(np.abs(res.u))) or 1.0
        r = np.linspace(-umax, umax, 201)
        data.append(_line(_num(r), _num(pi.loading_curve(r)), "initial loading curve", _GREEN,
                          line={"color": _GREEN, "width": 1, "dash": "dash"}))
    title = f"Hysteresis loop ({type(m).__name__}, n = {getattr(m, 'n', '?')})"
    lay = _layout(title, xaxis={"title": {"text": "input u"}},
                  yaxis={"title": {"text": "output y"}})
    return FigureJSON(data, lay)


def operators_figure(res: Result) -> FigureJSON:
    """Stacked contributions ``p0 u`` and ``p_i Γ_{r_i}[u]``; their sum is ``y``."""
    m = pi_part(res.model)
    if res.contributions is None or m is None:
        return message_figure("Operator outputs", "Only available for classical PI models")
    idx = decimate_index(res.u, MAX_POINTS_STACKED)
    t = _num(res.t[idx])
    data = [_line(t, _num(m.p0 * res.u[idx]), "p0·u", _GREY, stackgroup="c",
                  line={"width": 0.5})]
    for i in range(m.n):
        data.append({"type": "scatter", "mode": "lines", "x": t,
                     "y": _num(res.contributions[idx, i]), "stackgroup": "c",
                     "name": f"p{i + 1}·Γ(r={m.thresholds[i]:.3g})", "line": {"width": 0.5}})
    data.append(_line(t, _num(res.y[idx]), "y (sum)", "#000000",
                      line={"color": "#000000", "width": 1.5, "dash": "dot"}))
    lay = _layout("Operator contributions (stacked)", xaxis={"title": {"text": "t [s]"}},
                  yaxis={"title": {"text": "contribution to y"}}, showlegend=m.n <= 12)
    return FigureJSON(data, lay)


def loading_figure(model: Model, u_max: float | None = None) -> FigureJSON:
    """Initial loading curve φ(r) with each segment's slope and the maximum loop width."""
    pi = pi_part(model)
    if pi is None:
        return message_figure("Initial loading curve", "Only available for classical PI models")
    model = pi
    rmax = float(u_max or 1.25 * model.thresholds[-1])
    knots = np.concatenate(([0.0], model.thresholds[model.thresholds < rmax], [rmax]))
    phi = model.loading_curve(knots)
    data = [_line(_num(knots), _num(phi), "φ(r)", _GREEN, mode="lines+markers")]
    slopes = model.slopes
    ann = []
    for i in range(knots.size - 1):
        xm, ym = 0.5 * (knots[i] + knots[i + 1]), 0.5 * (phi[i] + phi[i + 1])
        ann.append({"x": xm, "y": ym, "text": f"S{i + 1}={slopes[i]:.3g}", "showarrow": False,
                    "yshift": 12, "font": {"size": 10}})
    inv = "invertible" if model.is_invertible else "NOT invertible (a slope ≤ 0)"
    ann.append({"x": 0.02, "y": 0.98, "xref": "paper", "yref": "paper", "showarrow": False,
                "xanchor": "left", "align": "left",
                "text": f"max loop width σ = {model.max_loop_width:.4g}<br>{inv}"})
    lay = _layout("Initial loading curve", xaxis={"title": {"text": "r (input travel)"}},
                  yaxis={"title": {"text": "φ(r)"}}, annotations=ann)
    return FigureJSON(data, lay)


def inverse_figure(res: Result, mismatch: float = 0.0) -> FigureJSON:
    """Inverse loop, ``P∘P⁻¹`` against the identity and the tracking error."""
    if res.v is None or res.y_comp is None:
        return message_figure("Inverse compensation", res.inverse_error or "no inverse")
    idx = decimate_index(res.u)
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
    lay = _layout(
        f"Inverse compensation (mismatch {mismatch:+.0%}, RMS error {rms:.3g})",
        xaxis={"domain": [0, 0.3], "title": {"text": "desired y_d"}, "anchor": "y"},
        yaxis={"title": {"text": "plant input v"}, "anchor": "x"},
        xaxis2={"domain": [0.36, 0.64], "title": {"text": "desired y_d"}, "anchor": "y2"},
        yaxis2={"title": {"text": "achieved y"}, "anchor": "x2"},
        xaxis3={"domain": [0.72, 1.0], "title": {"text": "t [s]"}, "anchor": "y3"},
        yaxis3={"title": {"text": "y − y_d"}, "anchor": "x3"},
    )
    return FigureJSON(data, lay)


def fit_figure(rec: Recording, y_fit: np.ndarray, label: str = "fit") -> FigureJSON:
    """Measured vs fitted output over time and the residual, plus the loop overlay."""
    idx = decimate_index(rec.u)
    t = _num(rec.t[idx])
    res = rec.y - y_fit
    data = [
        _line(_num(rec.u[idx]), _num(rec.y[idx]), "measured", _GREY, xaxis="x", yaxis="y"),
        _line(_num(rec.u[idx]), _num(y_fit[idx]), label, _ORANGE, xaxis="x", yaxis="y"),
        _line(t, _num(res[idx]), "residual y − ŷ", _RED, xaxis="x2", yaxis="y2"),
    ]
    rms = float(np.sqrt(np.mean(res**2)))
    lay = _layout(
        f"Fit overlay and residual (RMS {rms:.3g})",
        xaxis={"domain": [0, 0.46], "title": {"text": "u"}, "anchor": "y"},
        yaxis={"title": {"text": "y"}, "anchor": "x"},
        xaxis2={"domain": [0.54, 1.0], "title": {"text": "t [s]"}, "anchor": "y2"},
        yaxis2={"title": {"text": "residual"}, "anchor": "x2"},
    )
    return FigureJSON(data, lay)


#: Names of the figures :func:`session_figures` can build.
FIGURES = ("time", "loop", "operators", "loading", "inverse")


def build(name: str, res: Result, mismatch: float = 0.0) -> FigureJSON:
    """Build the figure ``name`` (one of :data:`FIGURES`) from ``res``."""
    if name == "time":
        return time_figure(res)
    if name == "loop":
        return loop_figure(res)
    if name == "operators":
        return operators_figure(res)
    if name == "loading":
        return loading_figure(res.model, float(np.max(np.abs(res.u))) or None)
    if name == "inverse":
        return inverse_figure(res, mismatch)
    raise KeyError(name)
