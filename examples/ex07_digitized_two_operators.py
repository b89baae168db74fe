"""Digitized PI model with two operators (paper 000, Fig. 3): 2 digits, 4 states.

A classical PI model ``y = p0 u + p1 Γ_{r1}[u]`` (p0 = 0.5, r1 = 1, p1 = 1) over the input
range [-3, 3] becomes ``H = [Δx; Δy]`` with ``Δx = (2 r1, 2 (u_A - r1)) = (2, 4)``,
``grad = (p0, p0 + p1) = (0.5, 1.5)`` and ``Δy = grad Δx = (1, 6)``. The script prints H and
its inverse (Δx and Δy swapped, eq. 22), the state table, the state sequence of a sweep,
and the difference to the classical model for an input with reversals inside segments,
with its bound and how it shrinks when the segments are refined.

Figures (self-contained HTML): the loop (digitized vs classical, state points marked),
the state graph drawn at the state points, the digit rows over time, and the error; and
the four states drawn as a square (``..._states.html``).

Run: ``python examples/ex07_digitized_two_operators.py [--out DIR]`` (``HYST_QUICK=1`` for a
short signal).
"""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
from _common import parse_out, quick, save
from plotly.subplots import make_subplots

from core.digitized import DigitizedPI
from core.pi import PIModel


def test_signal(u_min: float, u_max: float, n: int) -> np.ndarray:
    """One major cycle (reversals at the extremes), then a decaying sine with a fast ripple.

    The second part reverses inside segments, where digitized and classical differ.
    """
    c, a = 0.5 * (u_min + u_max), 0.5 * (u_max - u_min)
    t1 = np.linspace(0.0, 1.0, 2 * (n // 6) + 1)  # odd: t = 0.5 hits u_max exactly
    major = c - a * np.cos(2 * np.pi * t1)
    t = np.linspace(0.0, 1.0, n - major.size)
    env = 0.95 * (1.0 - 0.6 * t)
    minor = c - a * env * np.cos(2 * np.pi * 3 * t) + 0.05 * a * np.sin(2 * np.pi * 23 * t)
    return np.clip(np.concatenate((major, minor)), u_min, u_max)




def classical_from_lower_extreme(pi: PIModel, u_min: float) -> PIModel:
    """The classical model started at the lower extreme of the major loop (plays at u_min + r)."""
    return PIModel(pi.p0, pi.thresholds, pi.weights, u_min + pi.thresholds)


def print_tables(d: DigitizedPI) -> None:
    """Print H, H⁻¹ and the state table (X_B, Y_B) with up/down neighbours."""
    np.set_printoptions(precision=4, suppress=True)
    print(f"n = {d.n} digits, origin (X0, Y0) = ({d.x0:g}, {d.y0:g})")
    print("H = [dx; dy] =\n", d.H)
    print("slopes grad_k =", d.slopes)
    if d.is_invertible:
        inv = d.inverse()
        print("H^-1 = [dy; dx] =\n", inv.H)
        print("inverse slopes 1/grad_k =", inv.slopes)
    g = d.state_graph()
    up = {int(a): int(b) for a, b, _ in g.up}
    down = {int(a): int(b) for a, b, _ in g.down}
    print(" state   code        X_B        Y_B   up    down")
    for c, s, x, y in zip(g.codes, g.strings, g.x, g.y, strict=True):
        u_s = g.strings[up[c]] if c in up else "-"
        d_s = g.strings[down[c]] if c in down else "-"
        print(f" {s:>5} {c:6d} {x:10.4f} {y:10.4f}  {u_s:>5} {d_s:>5}")


def compress(strings: list[str]) -> str:
    return " -> ".join(strings)


def state_rows(d: DigitizedPI, u: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Digit rows at the end of every sample, shape (N, n), and the visited sequence."""
    tr = d.trace(u)
    row = np.searchsorted(tr.sample, np.arange(u.size), side="right") - 1
    return tr.digits[row], tr.strings


def build_figure(d: DigitizedPI, classical: PIModel, u: np.ndarray, title: str) -> go.Figure:
    """Loop, state graph, digit rows over time and digitized-vs-classical error."""
    y_d = d(u)
    y_c = classical(u) + d.classical_offset
    g = d.state_graph()
    rows, _ = state_rows(d, u)
    fig = make_subplots(
        rows=2,
        cols=2,
        subplot_titles=(
            "loop: digitized vs classical",
            "state graph at the state points (X_B, Y_B)",
            "digit rows over time (black = 1, b_1 at the bottom)",
            "digitized − classical",
        ),
        vertical_spacing=0.12,
    )
    fig.add_trace(go.Scatter(x=u, y=y_c, name="classical PI", line={"width": 1}), 1, 1)
    fig.add_trace(
        go.Scatter(x=u, y=y_d, name="digitized", line={"width": 1, "dash": "dot"}), 1, 1
    )
    fig.add_trace(
        go.Scatter(x=g.x, y=g.y, mode="markers", name="state points", marker={"size": 7}),
        1,
        1,
    )
    for rows_e, name, dash in ((g.up, "up (set lowest 0)", "solid"),
                               (g.down, "down (clear lowest 1)", "dash")):
        xs: list[float | None] = []
        ys: list[float | None] = []
        for a, b, _ in rows_e:
            xs += [float(g.x[a]), float(g.x[b]), None]
            ys += [float(g.y[a]), float(g.y[b]), None]
        fig.add_trace(go.Scatter(x=xs, y=ys, mode="lines", name=name,
                                 line={"dash": dash}), 1, 2)
    fig.add_trace(
        go.Scatter(x=g.x, y=g.y, mode="markers+text", text=g.strings,
                   textposition="top left", name="states", marker={"size": 9}),
        1,
        2,
    )
    fig.add_trace(
        go.Heatmap(z=rows.T, y=[f"b{k + 1}" for k in range(d.n)], zmin=0, zmax=1,
                   colorscale=[[0.0, "white"], [1.0, "black"]], showscale=False,
                   name="digits (black = 1)"),
        2,
        1,
    )
    fig.add_trace(go.Scatter(y=y_d - y_c, name="error", line={"width": 1}), 2, 2)
    b = d.reversal_error_bound()
    fig.add_trace(go.Scatter(x=[0, u.size - 1], y=[-b, -b], name="bound",
                             line={"dash": "dash", "color": "gray"}), 2, 2)
    fig.update_layout(title=title, height=850, width=1150)
    fig.update_xaxes(title_text="input u", row=1, col=1)
    fig.update_xaxes(title_text="X_B", row=1, col=2)
    fig.update_xaxes(title_text="sample", row=2, col=1)
    fig.update_xaxes(title_text="sample", row=2, col=2)
    return fig


def hypercube_figure(d: DigitizedPI, title: str) -> go.Figure:
    """The 2**n states as the vertices of an n-cube drawn in 2-D (one direction per digit).

    Gray: all single-digit flips; solid: up moves (set the lowest 0); dashed: down moves
    (clear the lowest 1). Only these two moves exist, so most cube edges are used in one
    direction only and some not at all.
    """
    g = d.state_graph()
    xy = g.hypercube_xy()
    fig = go.Figure()
    for edges, name, style in (
        (g.hypercube_edges(), "single-digit flip", {"color": "lightgray", "width": 1}),
        (g.up, "up (set lowest 0)", {"color": "royalblue", "width": 2}),
        (g.down, "down (clear lowest 1)", {"color": "darkorange", "width": 2, "dash": "dash"}),
    ):
        xs: list[float | None] = []
        ys: list[float | None] = []
        for a, b, _ in edges:
            xs += [float(xy[a, 0]), float(xy[b, 0]), None]
            ys += [float(xy[a, 1]), float(xy[b, 1]), None]
        fig.add_trace(go.Scatter(x=xs, y=ys, mode="lines", name=name, line=style))
    fig.add_trace(go.Scatter(x=xy[:, 0], y=xy[:, 1], mode="markers+text", text=g.strings,
                             textposition="top center", name="states", marker={"size": 10}))
    fig.update_layout(title=title, height=600, width=700, yaxis={"scaleanchor": "x"})
    return fig


def report_errors(pi: PIModel, u_range: tuple[float, float], u: np.ndarray) -> None:
    """Max |digitized − classical| and its bound for refined digitizations of the same model."""
    classical = classical_from_lower_extreme(pi, u_range[0])
    y_c = classical(u)
    print(" refine  digits  max|error|  bound Σ|p_i| max_{k>i} Δx_k  max_k (grad_k-p0)Δx_k")
    for s in (1, 2, 4, 8):
        d = DigitizedPI.from_pi(pi, u_range, refine=s)
        e = float(np.max(np.abs(d(u) - y_c)))
        print(f" {s:6d} {d.n:7d} {e:11.5f} {d.reversal_error_bound():30.5f}"
              f" {d.single_reversal_bound().max():22.5f}")


def main() -> None:
    out = parse_out(__doc__.splitlines()[0])
    pi = PIModel(0.5, [1.0], [1.0])
    u_range = (-3.0, 3.0)
    d = DigitizedPI.from_pi(pi, u_range)
    print_tables(d)
    sweep = np.concatenate((np.linspace(-3, 3, 13), np.linspace(3, -3, 13)[1:]))
    print("state sequence, up then down sweep:", compress(d.trace(sweep).strings))
    u = test_signal(*u_range, 400 if quick() else 4000)
    classical = classical_from_lower_extreme(pi, u_range[0])
    e = d(u) - classical(u)
    print(f"signal with interior reversals: max |digitized - classical| = {np.max(abs(e)):.4f}"
          f" (bound {d.reversal_error_bound():.4f})")
    grid = np.concatenate([np.linspace(a, b, 11)[:-1] for a, b in
                           ((-3, 3), (3, 1), (1, 3), (3, -3))] + [np.array([-3.0])])
    print("reversals only at state points: max |difference| = "
          f"{np.max(abs(d(grid) - classical(grid))):.2e}")
    inv = d.inverse()
    print(f"inverse round trip max |H^-1(H(u)) - u| = {np.max(abs(inv(d(u)) - u)):.2e}")
    report_errors(pi, u_range, u)
    save(build_figure(d, classical, u, "Digitized PI, two operators (paper 000 Fig. 3)"),
                 out, "ex07_digitized_two_operators")
    save(hypercube_figure(d, "Two digits: the 4 states as a square"), out,
                 "ex07_digitized_two_operators_states")


if __name__ == "__main__":
    main()
