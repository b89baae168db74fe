"""Paper 001 Example 1: the classical PI model with six play operators (Fig. 8-10).

``r_i = 0.45 i`` (i = 1..6), ``p0 = 0.72``, ``p = {0.6, 0.48, 0.36, 0.24, 0.12, 0.012}``, input
``v(t) = 4 sin 2πt``. Prints the slopes S_i (eq. 33; the paper's 0.71, 1.33, 2.51 are
rounding misprints of 0.72, 1.32, 2.52), the maximum loop width (eq. 32 with p0 in the
denominator: 1.518; the printed formula gives 2.12) and the Fig. 9 initial-state check.

Figures: ``ex01_pi_model.html`` (y(t), play outputs, loop, loading curve with slopes) and
``ex01_initial_states.html`` (Fig. 9: M0 = 0, 1, -1).

Run: ``python examples/ex01_pi_model.py [--out DIR]`` (``HYST_QUICK=1`` for short signals).
"""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
from _common import parse_out, quick, save
from plotly.subplots import make_subplots

from core.presets import get_preset
from core.signals import sine


def main() -> None:
    out = parse_out(__doc__.splitlines()[0])
    fs = 500.0 if quick() else 5000.0
    m = get_preset("paper001-example1")
    t, v = sine(4.0, 1.0, 0.0, 2.0, fs)
    y = m(v)
    Y = m.operator_outputs(v)

    print("Example 1: p0 =", m.p0, " r =", m.thresholds.tolist(), " p =", m.weights.tolist())
    print("slopes S1..S7 (eq. 33):", np.round(m.slopes, 4).tolist(),
          " (printed 0.71, 1.33, 2.51 for S1, S2, S6 are rounding misprints)")
    sw = 2 * float(np.dot(m.weights, m.thresholds))
    print(f"max loop width sigma = 2 sum p_i r_i / (p0 + sum p_i) = {m.max_loop_width:.4f}"
          f"  (paper: 1.5; printed formula without p0: {sw / m.weights.sum():.4f})")
    print(f"peak output y(v = 4) = phi(4) = {m.loading_curve([4.0])[0]:.4f}; "
          f"bound eq. (31) = {m.output_bound(4.0):.4f}")

    fig = make_subplots(rows=2, cols=2, subplot_titles=(
        "(a) input v(t) and output y(t)", "(b) play outputs Γ_ri[v](t)",
        "(c) hysteresis loop y(v)", "(d) initial loading curve φ(r) and slopes"))
    fig.add_trace(go.Scatter(x=t, y=v, name="v(t)"), 1, 1)
    fig.add_trace(go.Scatter(x=t, y=y, name="y(t)"), 1, 1)
    for i, r in enumerate(m.thresholds):
        fig.add_trace(go.Scatter(x=t, y=Y[:, i], name=f"Γ r={r:.2f}", showlegend=True), 1, 2)
    fig.add_trace(go.Scatter(x=v, y=y, name="loop", line={"color": "black"}), 2, 1)
    rr = np.linspace(0.0, 4.0, 401)
    fig.add_trace(go.Scatter(x=rr, y=m.loading_curve(rr), name="φ(r)"), 2, 2)
    edges = np.r_[0.0, m.thresholds, 4.0]
    for i, s in enumerate(m.slopes):
        mid = 0.5 * (edges[i] + edges[i + 1])
        fig.add_annotation(x=mid, y=float(m.loading_curve([mid])[0]), text=f"S{i + 1}={s:.3g}",
                           showarrow=True, ax=-30, ay=-25, row=2, col=2)
    fig.add_annotation(text=f"σ = {m.max_loop_width:.3f}", x=0, y=0, showarrow=False,
                       row=2, col=1)
    fig.update_layout(title="Paper 001 Example 1: classical PI model", height=800)
    save(fig, out, "ex01_pi_model")

    # Fig. 9: initial states M0 = 0, 1, -1 for every play operator
    fig9 = make_subplots(rows=1, cols=2, subplot_titles=(
        "(a) Γ_r5[v] for different M0", "(b) loops for different M0"))
    y0 = y
    for name in ("paper001-example1", "paper001-example1-m0=1", "paper001-example1-m0=-1"):
        mm = get_preset(name)
        m0 = float(mm.state0[0])
        ym = mm(v)
        differ = np.flatnonzero(ym != y0)
        k = int(differ[-1]) + 1 if differ.size else 0  # identical from sample k on
        print(f"M0 = {m0:+.0f}: y(0) = {ym[0]:+.4f}; identical to M0 = 0 from t = {t[k]:.3f} s "
              f"(v = {v[k]:.3f})")
        fig9.add_trace(go.Scatter(x=t, y=mm.operator_outputs(v)[:, 4], name=f"M0={m0:g}"), 1, 1)
        fig9.add_trace(go.Scatter(x=v, y=ym, name=f"loop M0={m0:g}"), 1, 2)
    print(f"initial state erased: total variation 8 > 2 r_max = {2 * m.thresholds[-1]:.1f}")
    fig9.update_layout(title="Paper 001 Fig. 9: initial states", height=450)
    save(fig9, out, "ex01_initial_states")


if __name__ == "__main__":
    main()
