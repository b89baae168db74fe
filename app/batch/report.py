"""``report.html`` of a batch: a self-contained fleet report (plotly.js inlined, no CDN).

Sections: counts and options; distributions of the errors and main parameters; robust
outliers (median / MAD) linked to their recordings; the effects found across the fleet
(diagnose); failed recordings with their errors; every recording with a link to its
parameter set. Every string from a file name, an error or a model is HTML-escaped, in the
tables and inside the figures.
"""

from __future__ import annotations

import html
import math
from collections import Counter
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path
from urllib.parse import quote

import plotly.graph_objects as go
import plotly.io as pio
from plotly.subplots import make_subplots

from app.services.explore.figures import PLOT_CONFIG

from .options import DiagnoseOptions, FitOptions
from .results import RecordingResult
from .summary import MIN_FOR_OUTLIERS, OUTLIER_Z, fleet_metrics, robust_outliers

__all__ = ["write_report"]

#: Most outlier rows listed (largest |z| first).
MAX_OUTLIER_ROWS = 40
#: Most distributions drawn (errors first, then the parameters most recordings have).
MAX_PANELS = 12

_CSS = """body{font-family:system-ui,sans-serif;margin:1.5em auto;max-width:1200px;color:#222}
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:2px 8px;
font-size:13px;text-align:left}th{background:#f3f3f3}.bad{color:#b00}.num{text-align:right}
.note{color:#555}code{background:#f6f6f6;padding:0 3px}"""


def _e(x: object) -> str:
    return html.escape(str(x), quote=True)


def _g(x: float | None) -> str:
    return "" if x is None or not math.isfinite(x) else f"{x:.4g}"


def _link(name: str, label: str | None = None) -> str:
    return f"<a href='#rec-{_e(quote(name))}'>{_e(label or name)}</a>"


def _distributions(metrics: dict[str, dict[str, float]], flagged: set[tuple[str, str]]
                   ) -> go.Figure | None:
    errors = [k for k in metrics if "RMSE" in k]
    params = sorted((k for k in metrics if "RMSE" not in k), key=lambda k: -len(metrics[k]))
    n_max = max(len(v) for v in metrics.values()) if metrics else 0
    keys = [k for k in errors + params if len(metrics[k]) >= max(2, min(5, n_max))][:MAX_PANELS]
    if not keys:
        return None
    cols = 3
    rows = -(-len(keys) // cols)
    fig = make_subplots(rows=rows, cols=cols, subplot_titles=[_e(k) for k in keys],
                        vertical_spacing=0.5 / rows if rows > 1 else 0.2)
    for i, k in enumerate(keys):
        r, c = i // cols + 1, i % cols + 1
        names = list(metrics[k])
        vals = [metrics[k][n] for n in names]
        fig.add_trace(go.Histogram(x=vals, name=_e(k), marker_color="#4c78a8", showlegend=False,
                                   nbinsx=min(40, max(5, len(vals) // 3))), row=r, col=c)
        out = [(n, v) for n, v in zip(names, vals, strict=True) if (n, k) in flagged]
        if out:
            fig.add_trace(go.Scatter(
                x=[v for _, v in out], y=[0] * len(out), mode="markers", showlegend=i == 0,
                name="robust outlier", marker={"color": "#d62728", "symbol": "x", "size": 10},
                text=[_e(n) for n, _ in out], hovertemplate="%{text}: %{x:.4g}<extra></extra>"),
                row=r, col=c)
    fig.update_layout(height=260 * rows + 60, title="Distributions over the fleet "
                      "(red x: robust outlier)", bargap=0.05, margin={"t": 80})
    return fig


def _effects_figure(counts: Counter[str]) -> go.Figure:
    names = [n for n, _ in counts.most_common()]
    fig = go.Figure(go.Bar(x=[_e(n) for n in names], y=[counts[n] for n in names],
                           marker_color="#59a14f"))
    fig.update_layout(title="Accepted effects across the fleet (recordings)", height=300,
                      margin={"t": 50, "b": 40},
                      yaxis_title="recordings")
    return fig


def write_report(path: Path, kind: str, rows: Sequence[RecordingResult],
                 options: FitOptions | DiagnoseOptions, title: str | None = None) -> Path:
    """Write the fleet report of a batch.

    Parameters
    ----------
    path : Path
        Destination (overwritten).
    kind : {"fit", "diagnose"}
    rows : sequence of RecordingResult
        Every recording of the batch, in input order.
    options : FitOptions or DiagnoseOptions
        Shown as the command line the batch applied.
    title : str, optional
        Heading (default: ``Batch <kind>: N recordings``).
    """
    ok = [r for r in rows if r.ok]
    bad = [r for r in rows if not r.ok]
    metrics = fleet_metrics(rows)
    outliers = robust_outliers(metrics)
    flagged = {(o.name, o.metric) for o in outliers}
    heading = title or f"Batch {kind}: {len(rows)} recordings"
    cmd = options.command_line()
    plotly_js = [True]  # inline plotly.js with the first figure only

    def figure(fig: go.Figure) -> str:
        out = pio.to_html(fig, full_html=False, include_plotlyjs=plotly_js[0],
                          config=PLOT_CONFIG)
        plotly_js[0] = False
        return out

    parts = [
        "<!doctype html><html><head><meta charset='utf-8'>",
        f"<title>{_e(heading)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{_e(heading)}</h1>",
        f"<p>{len(ok)} succeeded ({sum(r.resumed for r in ok)} from an earlier run), "
        f"<span class='{'bad' if bad else ''}'>{len(bad)} failed</span>. Each recording: "
        f"<code>{_e(cmd)}</code>. Written {_e(datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC'))}"
        ".</p>",
    ]
    parts.append("<h2>Effects across the fleet</h2>")
    if kind == "diagnose":
        counts = Counter(e for r in ok for e in r.effects)
        if counts:
            parts.append("<table><tr><th>effect</th><th>recordings</th><th>share</th>"
                         "<th>recordings (first 10)</th></tr>" + "".join(
                             f"<tr><td>{_e(n)}</td><td class='num'>{c}</td>"
                             f"<td class='num'>{100 * c / len(ok):.0f} %</td><td>"
                             + ", ".join([_link(r.name) for r in ok if n in r.effects][:10])
                             + "</td></tr>" for n, c in counts.most_common()) + "</table>")
            parts.append(figure(_effects_figure(counts)))
        parts.append(f"<p>{sum(not r.effects for r in ok)} of {len(ok)} recordings: no effect "
                     "beyond the PI model.</p>")
    else:
        parts.append("<p class='note'>A fit batch does not look for missing physics; run "
                     "<code>hyst batch diagnose</code> for that.</p>")
    parts.append("<h2>Outliers</h2>")
    if outliers:
        parts.append(
            f"<p class='note'>Values with a modified z-score |0.6745 (x - median) / MAD| > "
            f"{OUTLIER_Z} among the successful recordings.</p><table><tr><th>recording</th>"
            "<th>metric</th><th>value</th><th>fleet median</th><th>MAD</th><th>z</th></tr>"
            + "".join(f"<tr class='outlier'><td>{_link(o.name)}</td><td>{_e(o.metric)}</td>"
                      f"<td class='num'>{_g(o.value)}</td><td class='num'>{_g(o.median)}</td>"
                      f"<td class='num'>{_g(o.mad)}</td><td class='num'>{o.z:+.1f}</td></tr>"
                      for o in outliers[:MAX_OUTLIER_ROWS]) + "</table>"
            + (f"<p class='note'>... and {len(outliers) - MAX_OUTLIER_ROWS} more.</p>"
               if len(outliers) > MAX_OUTLIER_ROWS else ""))
    else:
        parts.append(f"<p>No robust outliers (|z| > {OUTLIER_Z}; a metric needs at least "
                     f"{MIN_FOR_OUTLIERS} recordings and a non-zero spread).</p>")
    parts.append("<h2>Distributions</h2>")
    dist = _distributions(metrics, flagged)
    parts.append(figure(dist) if dist is not None
                 else "<p>Too few successful recordings for distributions.</p>")
    if bad:
        parts.append("<h2 class='bad'>Failed recordings</h2><table><tr><th>recording</th>"
                     "<th>file</th><th>error</th></tr>" + "".join(
                         f"<tr><td>{_link(r.name)}</td><td>{_e(r.file)}</td>"
                         f"<td class='bad'>{_e(r.error)}</td></tr>" for r in bad) + "</table>")
    parts.append("<h2>All recordings</h2><table><tr><th>recording</th><th>file</th>"
                 "<th>samples</th><th>model</th><th>n</th><th>train RMSE %</th>"
                 "<th>held-out RMSE %</th><th>effects</th><th>status</th></tr>")
    for r in rows:
        link = f"<a href='{_e(quote(r.name))}.json'>{_e(r.name)}</a>" if r.ok else _e(r.name)
        if r.fmu:  # --fmu: the recording's FMU next to its parameter set
            link += (f" · <a href='{_e(quote(r.fmu))}' title='{_e(r.fmu_note)}'>FMU "
                     f"({_e(r.fmu_note.split(' (')[0])})</a>")
        elif r.fmu_note:
            link += f"<br><span class='bad'>{_e(r.fmu_note)}</span>"
        parts.append(
            f"<tr id='rec-{_e(quote(r.name))}'><td>{link}</td><td>{_e(r.file)}</td>"
            f"<td class='num'>{r.samples if r.ok else ''}</td><td>{_e(r.model)}</td>"
            f"<td class='num'>{'' if r.n_operators is None else r.n_operators}</td>"
            f"<td class='num'>{_g(r.train_rmse_pct)}</td>"
            f"<td class='num'>{_g(r.heldout_rmse_pct)}</td><td>{_e(', '.join(r.effects))}</td>"
            f"<td class='{'' if r.ok else 'bad'}'>{_e(r.status)}</td></tr>")
    parts.append("</table></body></html>")
    # plotly.js carries a default CDN URL for topojson maps (unused here): neutralise it so
    # the report makes no network reference at all (as
    # app/services/analysis/diagnosis_report.py does)
    text = "\n".join(parts).replace('"https://cdn.plot.ly/un/"', '"topojson/"')
    p = Path(path)
    p.write_text(text, encoding="utf-8")
    return p
