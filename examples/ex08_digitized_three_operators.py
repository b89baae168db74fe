"""Digitized PI model with three operators (paper 000, Fig. 4): 3 digits, 8 states.

Classical PI with p0 = 0.4, r = (0.5, 1.5), p = (0.6, 1.0) over the input range [0, 10]
(u_A = 5, already in the positive quadrant): ``Δx = (1, 2, 7)``, ``grad = (0.4, 1.0, 2.0)``,
``Δy = (0.4, 2, 14)``. The script prints H and H⁻¹, the 8 states with their neighbours, the
state sequences of up/down sweeps and of a zigzag, and the digitized-vs-classical error
for an input with interior reversals (with refinement). It then appends dead-zone
operators on the output (paper 000's modified PI, Kuhnen order ``y = S[H[v]]``, section 2.3)
and checks the swapped inverse as a feedforward compensator.

Figures: ``ex08_digitized_three_operators.html`` (loop, state graph, digit rows, error),
``ex08_digitized_three_operators_states.html`` (the 8 states as a cube) and
``ex08_digitized_modified_pi.html`` (modified PI loop and compensation).

Run: ``python examples/ex08_digitized_three_operators.py [--out DIR]`` (``HYST_QUICK=1``).
"""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
from _common import parse_out, quick, save
from ex07_digitized_two_operators import (
    build_figure,
    classical_from_lower_extreme,
    compress,
    hypercube_figure,
    print_tables,
    report_errors,
    test_signal,
)
from plotly.subplots import make_subplots

from core.digitized import DigitizedPI
from core.digitized_deadzone import DigitizedModifiedPI, deadzone_output
from core.pi import PIModel


def modified_pi_figure(m: DigitizedModifiedPI, v: np.ndarray, x_d: np.ndarray) -> go.Figure:
    """Loop of the digitized modified PI and the compensation of a desired trajectory."""
    v_c = m.inverse()(x_d)
    fig = make_subplots(rows=1, cols=2, subplot_titles=(
        "digitized modified PI y = S[H[v]]", "compensation: y = S[H[H⁻¹[S⁻¹[x_d]]]]"))
    fig.add_trace(go.Scatter(x=v, y=m(v), name="S[H[v]]", line={"width": 1}), 1, 1)
    fig.add_trace(go.Scatter(x=v, y=m.pi(v), name="H[v] (before the dead zones)",
                             line={"width": 1, "dash": "dot"}), 1, 1)
    fig.add_trace(go.Scatter(y=x_d, name="desired x_d", line={"width": 1}), 1, 2)
    fig.add_trace(go.Scatter(y=m(v_c), name="compensated output",
                             line={"width": 1, "dash": "dot"}), 1, 2)
    fig.add_trace(go.Scatter(y=v_c, name="control input v", line={"width": 1}), 1, 2)
    fig.update_xaxes(title_text="input v", row=1, col=1)
    fig.update_xaxes(title_text="sample", row=1, col=2)
    fig.update_layout(title="Digitized modified PI (paper 000 section 2.3-2.4)", height=500,
                      width=1150)
    return fig


def main() -> None:
    out = parse_out(__doc__.splitlines()[0])
    pi = PIModel(0.4, [0.5, 1.5], [0.6, 1.0])
    u_range = (0.0, 10.0)
    d = DigitizedPI.from_pi(pi, u_range)
    print_tables(d)
    up = d.trace(np.linspace(0.0, 10.0, 41)).strings
    down = d.trace(np.linspace(10.0, 0.0, 41), state="111").strings
    print("up sweep:  ", compress(up))
    print("down sweep:", compress(down))
    zig = np.concatenate([np.linspace(a, b, 9)[:-1] for a, b in
                          ((0, 3), (3, 2), (2, 2.5), (2.5, 10), (10, 8), (8, 0))] + [[0.0]])
    print("zigzag 0 -> 3 -> 2 -> 2.5 -> 10 -> 8 -> 0:", compress(d.trace(zig).strings))

    n = 600 if quick() else 6000
    u = test_signal(*u_range, n)
    classical = classical_from_lower_extreme(pi, u_range[0])
    e = d(u) - classical(u)
    print(f"signal with interior reversals: max |digitized - classical| = {np.max(abs(e)):.4f}"
          f" (bound {d.reversal_error_bound():.4f})")
    report_errors(pi, u_range, u)
    save(build_figure(d, classical, u, "Digitized PI, three operators (paper 000 Fig. 4)"),
                 out, "ex08_digitized_three_operators")
    save(hypercube_figure(d, "Three digits: the 8 states as a cube"), out,
                 "ex08_digitized_three_operators_states")

    # Modified PI: dead zones on the output (Kuhnen order), thresholds ρ with ρ0 = 0.
    rho = np.array([-2.0, 0.0, 4.0, 10.0])
    eta = np.array([0.3, 1.0, 0.25, -0.5])
    m = DigitizedModifiedPI.from_classical(pi, u_range, rho, eta, refine=4)
    print(f"dead-zone part: m = {m.deadzone.m} segments, S =\n", m.deadzone.S)
    print("S^-1 = [dy; dx] =\n", m.deadzone.inverse().S)
    v = test_signal(*u_range, n)
    y_cl = deadzone_output(classical(v), rho, eta)
    print(f"modified PI, refine 4 ({m.pi.n} digits): max |digitized - classical| = "
          f"{np.max(abs(m(v) - y_cl)):.4f} (PI-part bound {m.pi.reversal_error_bound():.4f},"
          " scaled by the dead-zone slopes)")
    y_lo, y_hi = m(np.array(u_range))
    t = np.linspace(0.0, 1.0, n)
    amp = 0.45 * (y_hi - y_lo) * (0.4 + 0.6 * np.abs(np.sin(np.pi * t)))
    x_d = 0.5 * (y_lo + y_hi) - amp * np.cos(2 * np.pi * 3 * t)
    v_c = m.inverse()(x_d)
    rmse = float(np.sqrt(np.mean((m(v_c) - x_d) ** 2)))
    print(f"compensation of a changing-amplitude sine: RMSE {rmse:.2e} (exact inverse)")
    save(modified_pi_figure(m, v, x_d), out, "ex08_digitized_modified_pi")


if __name__ == "__main__":
    main()
