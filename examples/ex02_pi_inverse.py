"""Paper 001 Example 2: the analytical inverse of Example 1 and inverse compensation.

Prints the inverse thresholds z_i and weights q_i (eq. 36-37; they match the paper), the
approximate inverse built from the estimated r̂, p̂ (the paper's ẑ4..ẑ6 are printed one unit
low in the 4th decimal), and the tracking errors for ``u = 10 sin 2πt`` with the exact
inverse (Fig. 12, to rounding) and the approximate one (Fig. 13).

Figures: ``ex02_pi_inverse.html`` (u and v, inverse play outputs, inverse loop with φ⁻¹,
compensated characteristics y(u) for exact and approximate inverse).

Run: ``python examples/ex02_pi_inverse.py [--out DIR]`` (``HYST_QUICK=1`` for short signals).
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
    P = get_preset("paper001-example1")
    inv = P.inverse()
    inv_hat = get_preset("paper001-example2-approx").inverse()
    np.set_printoptions(precision=4, suppress=True)
    print(f"exact inverse: q0 = {inv.p0:.4f}, z = {inv.thresholds}, q = {inv.weights}")
    print(f"approx. inverse: q0 = {inv_hat.p0:.4f}, z = {inv_hat.thresholds}, "
          f"q = {inv_hat.weights}")

    t, u = sine(10.0, 1.0, 0.0, 2.0, fs)
    v = inv(u)
    y = P(v)
    v_hat = inv_hat(u)
    y_hat = P(v_hat)
    print(f"u = 10 sin 2πt: max |v| = {np.max(np.abs(v)):.4f}")
    print(f"exact inverse:   max |P[P⁻¹[u]] - u| = {np.max(np.abs(y - u)):.2e}")
    e_hat = y_hat - u
    print(f"approx. inverse: max |P[P̂⁻¹[u]] - u| = {np.max(np.abs(e_hat)):.4f}, "
          f"RMS = {np.sqrt(np.mean(e_hat ** 2)):.4f} ({100 * np.max(np.abs(e_hat)) / 10:.2f} % "
          "of the amplitude)")

    fig = make_subplots(rows=2, cols=3, subplot_titles=(
        "(a) u(t) and v = P⁻¹[u](t)", "(b) inverse play outputs Γ_zi[u]",
        "(c) inverse loop v(u) and φ⁻¹", "(12a) exact: u and y(t)", "(12b) exact: y(u)",
        "(13b) approximate: y(u)"))
    fig.add_trace(go.Scatter(x=t, y=u, name="u"), 1, 1)
    fig.add_trace(go.Scatter(x=t, y=v, name="v"), 1, 1)
    Y = inv.operator_outputs(u)
    for i, z in enumerate(inv.thresholds):
        fig.add_trace(go.Scatter(x=t, y=Y[:, i], name=f"Γ z={z:.3f}"), 1, 2)
    fig.add_trace(go.Scatter(x=u, y=v, name="v(u)"), 1, 3)
    uu = np.linspace(0.0, 10.0, 201)
    fig.add_trace(go.Scatter(x=uu, y=inv.loading_curve(uu), name="φ⁻¹",
                             line={"dash": "dash"}), 1, 3)
    fig.add_trace(go.Scatter(x=t, y=u, name="u"), 2, 1)
    fig.add_trace(go.Scatter(x=t, y=y, name="y exact", line={"dash": "dot"}), 2, 1)
    fig.add_trace(go.Scatter(x=u, y=y, name="y(u) exact"), 2, 2)
    fig.add_trace(go.Scatter(x=u, y=y_hat, name="y(u) approximate"), 2, 3)
    fig.update_layout(title="Paper 001 Example 2: inverse PI model and compensation",
                      height=800)
    save(fig, out, "ex02_pi_inverse")


if __name__ == "__main__":
    main()
