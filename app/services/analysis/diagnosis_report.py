"""Self-contained HTML report of a missing-physics diagnosis (plotly.js inlined, no CDN).

Sections: summary table (baseline → final held-out RMSE), one card per accepted effect (name,
where, why, the equation added, parameters with uncertainty, held-out RMSE before/after),
loops and residuals before/after, the residual maps (input level × branch, time since
reversal), and the untestable / ambiguous lists.
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

import numpy as np
import plotly.graph_objects as go
import plotly.io as pio
from plotly.subplots import make_subplots

from app.services.explore.figures import PLOT_CONFIG
from core.diagnosis.results import DiagnosisResult, suggestive_rows

__all__ = ["figures", "write_report"]


def _dec(n: int, limit: int = 6000) -> slice:
    return slice(None, None, max(1, n // limit))


def _axis(units: dict[str, str] | None, role: str, text: str) -> str:
    u = (units or {}).get(role) or ("s" if role == "time" else "a.u.")
    return f"{text} [{u}]"


def figures(res: Any, units: dict[str, str] | None = None) -> dict[str, go.Figure]:
    """Plotly figures of a :class:`~core.diagnosis.DiagnosisResult`, axes in ``units``
    (``time``, ``input``, ``output``; the records' own when not given, else s / a.u.).

    Returns
    -------
    dict
        ``loops``, ``residuals``, ``maps`` figures.
    """
    recs = res.records
    units = {**(recs[0].units if recs else {}), **{k: v for k, v in (units or {}).items() if v}}
    n = len(recs)
    # run ids come from uploaded files: plotly reads a title's tags (its <a>, <b>, ...), so
    # they are given as text (entities plotly shows as the characters)
    titles = [html.escape(r.name) for r in recs]
    loops = make_subplots(rows=1, cols=n, subplot_titles=titles)
    resid = make_subplots(rows=n, cols=1, subplot_titles=titles,
                          shared_xaxes=False)
    for k, r in enumerate(recs):
        s = _dec(r.n_samples)
        eb = r.y - res.baseline.pred[k]
        ef = r.y - res.final.pred[k]
        show = k == 0
        loops.add_trace(go.Scattergl(x=r.u[s], y=r.y[s], mode="lines", name="measured",
                                     line={"color": "black", "width": 1}, showlegend=show),
                        row=1, col=k + 1)
        loops.add_trace(go.Scattergl(x=r.u[s], y=res.baseline.pred[k][s], mode="lines",
                                     name="baseline PI", line={"color": "#d62728", "width": 1},
                                     showlegend=show), row=1, col=k + 1)
        loops.add_trace(go.Scattergl(x=r.u[s], y=res.final.pred[k][s], mode="lines",
                                     name="PI + effects", line={"color": "#1f77b4", "width": 1},
                                     showlegend=show), row=1, col=k + 1)
        resid.add_trace(go.Scattergl(x=r.t[s], y=eb[s], mode="lines", name="residual, baseline",
                                     line={"color": "#d62728", "width": 1}, showlegend=show),
                        row=k + 1, col=1)
        resid.add_trace(go.Scattergl(x=r.t[s], y=ef[s], mode="lines", name="residual, final",
                                     line={"color": "#1f77b4", "width": 1}, showlegend=show),
                        row=k + 1, col=1)
        for m, color, label in ((res.test[k], "rgba(44,160,44,0.12)", "held-out"),):
            idx = np.flatnonzero(m)
            if idx.size:
                resid.add_vrect(x0=float(r.t[idx[0]]), x1=float(r.t[idx[-1]]), fillcolor=color,
                                line_width=0, annotation_text=label, row=k + 1, col=1)
    loops.update_layout(title="Loops: measured, baseline PI and PI + accepted effects",
                        height=420)
    loops.update_xaxes(title_text=_axis(units, "input", "input u"))
    loops.update_yaxes(title_text=_axis(units, "output", "output y"), col=1)
    resid.update_layout(title="Residual (measured - simulated) in time; green = held-out rows",
                        height=260 * n + 80)
    resid.update_xaxes(title_text=_axis(units, "time", "time t"))
    resid.update_yaxes(title_text=_axis(units, "output", "residual"))
    maps = make_subplots(rows=1, cols=2, subplot_titles=[
        "mean residual vs input level and branch", "mean residual vs time since reversal"])
    for label, mp, dash in (("baseline", res.maps_before, "solid"),
                            ("final", res.maps_after, "dot")):
        for br, color in (("ascending", "#ff7f0e"), ("descending", "#9467bd")):
            rows = mp.get("input_branch", {}).get(br, [])
            if rows:
                maps.add_trace(go.Scatter(
                    x=[0.5 * (b["lo"] + b["hi"]) for b in rows], y=[b["mean"] for b in rows],
                    mode="lines+markers", name=f"{label}, {br}",
                    line={"color": color, "dash": dash}), row=1, col=1)
        rows = mp.get("since_reversal", [])
        if rows:
            maps.add_trace(go.Scatter(
                x=[np.sqrt(b["lo"] * b["hi"]) for b in rows], y=[b["rms"] for b in rows],
                mode="lines+markers", name=f"{label}, RMS", line={"color": "#2ca02c",
                                                                  "dash": dash}), row=1, col=2)
    maps.update_xaxes(title_text=_axis(units, "input", "input u"), row=1, col=1)
    maps.update_xaxes(title_text="time since reversal [s]", type="log", row=1, col=2)
    maps.update_yaxes(title_text=_axis(units, "output", "mean residual"), row=1, col=1)
    maps.update_yaxes(title_text=_axis(units, "output", "RMS residual"), row=1, col=2)
    maps.update_layout(title="LOCATE: residual maps before (solid) and after (dotted)",
                       height=420)
    return {"loops": loops, "residuals": resid, "maps": maps}


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return html.escape(str(v))


def write_report(res: DiagnosisResult, path: str | Path,
                 units: dict[str, str] | None = None) -> Path:
    """Write the HTML report of ``res`` to ``path`` (axes in ``units``, see
    :func:`figures`) and return the path."""
    d = res.to_dict()
    yr = res.y_range
    figs = figures(res, units)
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>Hysteresis Explorer - "
        "diagnosis</title><style>body{font-family:sans-serif;max-width:1200px;margin:auto;"
        "padding:1em}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:4px 8px}"
        ".card{border:1px solid #999;border-radius:6px;padding:0.6em 1em;margin:0.8em 0}"
        "code{background:#f4f4f4;padding:1px 4px}</style></head><body>",
        "<h1>Missing-physics diagnosis</h1>",
        f"<p>Recordings: {', '.join(html.escape(r['name']) for r in d['recordings'])}. "
        f"Split: {html.escape(d['split'])}.</p>",
        "<table><tr><th></th><th>held-out RMSE</th><th>% of output range</th></tr>",
        f"<tr><td>baseline PI ({d['baseline']['n_operators']} operators)</td>"
        f"<td>{d['baseline']['heldout_rmse']:.4g}</td>"
        f"<td>{d['baseline']['heldout_rmse_pct']:.3f}</td></tr>",
        f"<tr><td>PI + {html.escape(', '.join(d['final']['effects']) or 'nothing')}</td>"
        f"<td>{d['final']['heldout_rmse']:.4g}</td><td>{d['final']['heldout_rmse_pct']:.3f}"
        "</td></tr></table>",
    ]
    lb, lf = d["baseline"].get("leave_one_recording_out"), d["final"].get(
        "leave_one_recording_out")
    if lb and lf:
        parts.append(
            "<h2>Leave-one-recording-out</h2><p>" + html.escape(lb["rule"]) + ".</p>"
            "<table><tr><th>held-out recording</th><th>baseline RMSE</th><th>final RMSE</th>"
            "</tr>" + "".join(
                f"<tr><td>{html.escape(a['recording'])}</td><td>{a['rmse']:.4g}</td>"
                f"<td>{b['rmse']:.4g}</td></tr>"
                for a, b in zip(lb["per_recording"], lf["per_recording"], strict=True))
            + f"<tr><td><b>all</b></td><td>{lb['rmse']:.4g}</td><td>{lf['rmse']:.4g} "
            f"(MSE {-100 * lf['mse_reduction'] + 0.0:+.1f} %)</td></tr></table>"
        )
    ad = res.adequacy
    if not res.effects and ad is not None and ad.adequate:
        parts.append("<p><b>No missing physics detected</b>: no effect improved the held-out "
                     "fit significantly, and the residual is at the noise floor.</p>")
    elif not res.effects:
        parts.append("<p><b>No effect of the list</b> improved the held-out fit "
                     "significantly.</p>")
    if ad is not None and not ad.adequate:
        parts.append(f"<p><b>Not explained:</b> {html.escape(ad.text)}</p>")
    for i, e in enumerate(res.effects, 1):
        rows = "".join(
            f"<tr><td>{html.escape(k)}</td><td>{_fmt(v)}</td><td>"
            f"{_fmt(e.uncertainty.get(k)) if e.uncertainty.get(k) is not None else ''}</td></tr>"
            for k, v in e.parameters.items()
        )
        amb = (f"<p>Ambiguous with: {html.escape(', '.join(e.ambiguous_with))}</p>"
               if e.ambiguous_with else "")
        amb = "".join(f"<p><b>Caveat:</b> {html.escape(c)}</p>" for c in e.caveats) + amb
        cf = e.crossfit
        if cf:
            amb = (f"<p>Significance with the cross-fitted training blocks (test rows + "
                   f"{cf['folds']} blocks, each predicted by a fit without it): DM z = "
                   f"{cf['dm_z_pooled']:.2f}, signed-rank p = {cf['signed_rank_p_pooled']:.2g}; "
                   "MSE reduction per block " + ", ".join(
                       f"{100 * g:+.0f} %" for g in cf["fold_mse_reductions"]) + "</p>" + amb)
        parts.append(
            f"<div class='card'><h2>{i}. {html.escape(e.name)}</h2>"
            f"<p><b>Why:</b> {html.escape(e.explanation)}</p>"
            f"<p><b>Where:</b> {html.escape(e.where.get('summary', ''))}</p>"
            f"<p><b>Added:</b> <code>{html.escape(e.equation)}</code></p>"
            f"<table><tr><th>parameter</th><th>value</th><th>± 1σ</th></tr>{rows}</table>"
            f"<p>Held-out RMSE {e.heldout_rmse_before:.4g} → {e.heldout_rmse_after:.4g} "
            f"({100 * e.heldout_rmse_before / yr:.3f} % → {100 * e.heldout_rmse_after / yr:.3f} "
            f"%); MSE reduction {100 * e.heldout.gain:.1f} %, DM z = {e.heldout.z:.2f}, "
            f"signed-rank p = {e.heldout.sign_p:.2g}.</p>{amb}</div>"
        )
    suggestive = suggestive_rows(res.rounds)
    if suggestive:
        parts.append("<h2>Suggestive, not claimed</h2><p>These improved the held-out fit by at "
                     "least 5 % but failed the significance rule; a targeted recording would "
                     "decide.</p><ul>" + "".join(
                         f"<li>{html.escape(g.effect)}: held-out MSE "
                         f"-{100 * g.heldout_mse_reduction:.0f} %, DM z = {g.dm_z:.2f}, "
                         f"signed-rank p = {g.signed_rank_p:.2g}"
                         + (f"; with the cross-fitted training blocks DM z = "
                            f"{g.detail('dm_z_pooled'):.2f}" if "dm_z_pooled" in dict(g.extra)
                            else "") + "</li>"
                         for g in suggestive) + "</ul>")
    if res.after_steps is not None:
        parts.append("<h2>Seen after too few input steps, not claimed</h2><p>"
                     + html.escape(res.after_steps.text) + ".</p>")
    if d["ambiguous"]:
        parts.append("<h2>Ambiguous</h2><ul>" + "".join(
            f"<li>{html.escape(' vs '.join(a['effects']))}: {html.escape(a['reason'])}. "
            f"To decide: {html.escape(a['experiment'])}.</li>" for a in d["ambiguous"]) + "</ul>")
    if res.untestable:
        parts.append("<h2>Untestable with these recordings</h2><ul>" + "".join(
            f"<li><b>{html.escape(u.name)}</b>: {html.escape(u.reason)}. Would need: "
            f"{html.escape(u.experiment)}.</li>" for u in res.untestable) + "</ul>")
    first = True
    for key in ("loops", "residuals", "maps"):
        parts.append(pio.to_html(figs[key], full_html=False,
                                 include_plotlyjs=True if first else False,
                                 config=PLOT_CONFIG))
        first = False
    parts.append("</body></html>")
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    # plotly.js carries a default CDN URL for topojson maps (unused here): neutralise it so
    # the report makes no network reference at all
    text = "\n".join(parts).replace('"https://cdn.plot.ly/un/"', '"topojson/"')
    p.write_text(text, encoding="utf-8")
    return p
