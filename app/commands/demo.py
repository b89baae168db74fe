"""``hyst demo``: paper 001 Example 1 in numbers and in a self-contained HTML plot."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ._common import add_json_flag, emit

__all__ = ["example1", "register", "run"]

DEFAULT_OUT = Path("out") / "demo"


def example1() -> Any:
    """Paper 001, Example 1: ``r_i = 0.45 i``, ``p0 = 0.72``, ``p = 0.6 ... 0.012``."""
    from core.pi import PIModel

    return PIModel(0.72, 0.45 * np.arange(1, 7), [0.6, 0.48, 0.36, 0.24, 0.12, 0.012])


def register(subparsers: Any) -> None:
    """Add the ``demo`` sub-command."""
    p = subparsers.add_parser(
        "demo",
        help="print paper 001 Example 1 and write an HTML plot of its loop and inverse",
        description=(
            "Paper 001 Example 1 (six play operators): prints the parameters, loop slopes, "
            "maximum loop width and the inverse model's parameters (Example 2), and writes a "
            "self-contained HTML page (plotly, works offline) with the hysteresis loop under "
            "v = 4 sin(2 pi t), the initial loading curve, the inverse under u = 10 sin(2 pi t) "
            "and the compensated response P[P^-1[u]] = u."
        ),
    )
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, metavar="DIR",
                   help=f"directory for demo.html (default: {DEFAULT_OUT})")
    p.add_argument("--no-open", action="store_true", help="do not open the page in a browser")
    add_json_flag(p)
    p.set_defaults(func=run)


def _vec(x: Any, digits: int = 4) -> str:
    return "{" + ", ".join(f"{v:.{digits}f}".rstrip("0").rstrip(".") for v in x) + "}"


def run(args: argparse.Namespace) -> int:
    """Print Example 1 and write ``demo.html``."""
    m = example1()
    inv = m.inverse()
    t = np.linspace(0.0, 2.0, 2001)
    v = 4.0 * np.sin(2 * np.pi * t)
    y = m(v)
    u = 10.0 * np.sin(2 * np.pi * t)
    vi = inv(u)
    yc = m(vi)
    comp_err = float(np.max(np.abs(yc - u)))
    text = "\n".join(
        [
            "Paper 001, Example 1: classical Prandtl-Ishlinskii model, n = 6",
            f"  thresholds r_i = {_vec(m.thresholds)}",
            f"  weights p0 = {m.p0:g}, p_i = {_vec(m.weights, 3)}",
            f"  loop slopes S_1..S_7 = {_vec(m.slopes, 3)}",
            "    (the paper prints S1 = 0.71, S2 = 1.33, S6 = 2.51: rounding misprints)",
            f"  maximum loop width sigma = 2 sum p_i r_i / (p0 + sum p_i) = {m.max_loop_width:.3f}",
            "    (the paper prints 1.5; its eq. 32 omits p0 in the denominator, giving 2.12)",
            "Example 2: inverse PI model (eq. 36-37)",
            f"  z_i = {_vec(inv.thresholds)}",
            f"  q0 = {inv.p0:.4f}, q_i = {_vec(inv.weights)}",
            f"Compensation under u = 10 sin(2 pi t): max |P[P^-1[u]] - u| = {comp_err:.2e}",
        ]
    )
    path = _write_html(args.out, m, t, v, y, u, vi, yc)
    text += f"\nwrote {path}"
    emit(
        args,
        text,
        {
            "model": m.to_dict(),
            "slopes": m.slopes.tolist(),
            "max_loop_width": m.max_loop_width,
            "inverse": inv.to_dict(),
            "compensation_max_abs_error": comp_err,
            "html": str(path),
        },
    )
    if not args.no_open:
        if _has_display():
            import webbrowser

            webbrowser.open(path.resolve().as_uri())
        else:
            print(f"no display: open {path.resolve().as_uri()} in a browser", file=sys.stderr)
    return 0


def _has_display() -> bool:
    """Whether a graphical browser can be opened (never start a console browser)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _write_html(
    out: Path, m: Any, t: np.ndarray, v: np.ndarray, y: np.ndarray,
    u: np.ndarray, vi: np.ndarray, yc: np.ndarray,
) -> Path:
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    r = np.linspace(0.0, 4.0, 401)
    fig = make_subplots(
        rows=1, cols=3, horizontal_spacing=0.07,
        subplot_titles=(
            "Loop and initial loading curve (Example 1)",
            "Inverse model P<sup>-1</sup> (Example 2)",
            "Compensation: P[P<sup>-1</sup>[u]]",
        ),
    )
    fig.add_trace(go.Scatter(x=v, y=y, name="y = P[v], v = 4 sin(2πt)",
                             line={"color": "#1f77b4"}), 1, 1)
    fig.add_trace(go.Scatter(x=r, y=m.loading_curve(r), name="initial loading curve φ(r)",
                             line={"color": "#d62728", "dash": "dash"}), 1, 1)
    fig.add_trace(go.Scatter(x=u, y=vi, name="v = P<sup>-1</sup>[u], u = 10 sin(2πt)",
                             line={"color": "#2ca02c"}), 1, 2)
    fig.add_trace(go.Scatter(x=u, y=m(u / m.slopes[-1]), name="uncompensated P[u / S<sub>7</sub>]",
                             line={"color": "#7f7f7f", "dash": "dot"}), 1, 3)
    fig.add_trace(go.Scatter(x=u, y=yc, name="compensated P[P<sup>-1</sup>[u]]",
                             line={"color": "#9467bd"}), 1, 3)
    fig.update_xaxes(title_text="input v", row=1, col=1)
    fig.update_yaxes(title_text="output y", row=1, col=1)
    fig.update_xaxes(title_text="desired output u", row=1, col=2)
    fig.update_yaxes(title_text="inverse output v", row=1, col=2)
    fig.update_xaxes(title_text="desired output u", row=1, col=3)
    fig.update_yaxes(title_text="achieved output y", row=1, col=3)
    fig.update_layout(
        title="Hysteresis Explorer demo: paper 001, Examples 1 and 2",
        height=520, width=1500, legend={"orientation": "h", "y": -0.18},
    )
    out.mkdir(parents=True, exist_ok=True)
    path = out / "demo.html"
    fig.write_html(path, include_plotlyjs=True, full_html=True)
    return path
