"""Dead-zone GPI model and its inverse (paper 001 Example 4, Figs. 21-22).

The GPI model of paper 001 puts the memoryless dead-zone superposition on the input:
``y_D = P[γ[v]]`` (eq. 40-41). Here P has ``r_i = 0.45 i`` and
``p_i = 0.65 exp(-7.75e-4 r_i)``, i = 0..6 (the printed exponent is positive, a misprint:
the printed inverse values need the negative sign), and γ has 23 mirrored dead zones
(m = 11). The script prints the inverse PI parameters (eq. 36-37) and the inverse dead-zone
parameters τ, μ (eq. 53-54) next to the printed ones, then drives the model with
``v = 5 sin 2πt`` and the inverse ``Π⁻¹ = γ⁻¹ ∘ P⁻¹`` with ``u = 15 sin 2πt`` and prints the
compensation error.

Figures: ``ex04_deadzone_gpi_model.html`` (Fig. 21: signals, dead-zone outputs, play outputs,
loop) and ``ex04_deadzone_gpi_inverse.html`` (Fig. 22: inverse signals, inverse loop,
tracking, compensated characteristic).

Run: ``python examples/ex04_deadzone_gpi.py [--out DIR]`` (``HYST_QUICK=1`` for a short signal).
"""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
from _common import parse_out, quick, save
from plotly.subplots import make_subplots

from core.base import Model
from core.gpi import PAPER001_EX4_ETA, DeadZoneGPI, paper001_example4

TAU_PRINTED = [1.906, 3.179, 3.809, 4.241, 4.524, 4.704, 4.816, 4.885, 4.928, 4.954, 4.97]
MU_PRINTED = [0.065, 0.122, 0.182, 0.305, 0.508, 0.84, 1.384, 2.248, 3.704, 6.179, 10.226]




def print_parameters(m: DeadZoneGPI) -> None:
    """Inverse PI and inverse dead-zone parameters, recomputed and printed side by side."""
    np.set_printoptions(precision=4, suppress=True, linewidth=110)
    inv_pi = m.pi.inverse()
    print("inverse PI (eq. 36-37):")
    print(f"  q0 = {inv_pi.p0:.4f}   (printed 1.5385)")
    print("  z  =", inv_pi.thresholds, "  (printed 0.293 0.877 1.755 2.924 4.386 6.139)")
    print("  q  =", inv_pi.weights, "  (printed -0.7691 -0.2564 -0.1282 -0.0769 -0.0513 -0.0366)")
    g = m.deadzone
    print("dead-zone map gamma: partial slopes (left to right) =")
    print("  ", g.slopes)
    print(f"  sum_(j=-11..-1) eta_j = {sum(PAPER001_EX4_ETA):.3f} < 0: printed eq. (43) is a "
          "misprint; every partial slope > 0 is the real condition ->",
          "invertible" if g.is_invertible else "NOT invertible")
    gi = g.inverse()
    k0 = gi.zero_index
    print("inverse dead-zone map (eq. 53-54), positive branch j = 1..11:")
    print("  tau recomputed =", gi.thresholds[k0 + 1 :])
    print("  tau printed    =", np.array(TAU_PRINTED))
    print(f"  mu0 = {gi.weights[k0]:.4f} (printed 0.210)")
    print("  mu  recomputed =", gi.weights[k0 + 1 :])
    print("  mu  printed    =", np.array(MU_PRINTED))
    print("  (the paper used unrounded eta; from the 3-decimal eta the tail drifts because the")
    print("   last partial slope is only 0.036 -- the identity gamma^-1(gamma(v)) = v is exact)")


def model_figure(m: DeadZoneGPI, t: np.ndarray, v: np.ndarray) -> go.Figure:
    """Fig. 21: v, w, y_D over time; S_rho[v]; Gamma_r[w]; the loop v -> y_D."""
    w = m.deadzone(v)
    y = m(v)
    S = m.deadzone.operator_outputs(v)
    G = m.pi.operator_outputs(w)
    fig = make_subplots(rows=2, cols=2, subplot_titles=(
        "(a) input v, dead-zone output w, GPI output y_D", "(b) dead-zone operators S_ρ[v]",
        "(c) play operators Γ_r[w]", "(d) GPI loop v → y_D"))
    for name, s in (("v", v), ("w = γ[v]", w), ("y_D = P[w]", y)):
        fig.add_trace(go.Scatter(x=t, y=s, name=name, line={"width": 1.5}), 1, 1)
    for j, rho in enumerate(m.deadzone.thresholds):
        fig.add_trace(go.Scatter(x=v, y=S[:, j], name=f"S ρ={rho:g}", showlegend=False,
                                 line={"width": 1}), 1, 2)
    for i, r in enumerate(m.pi.thresholds):
        fig.add_trace(go.Scatter(x=t, y=G[:, i], name=f"Γ r={r:g}", showlegend=False,
                                 line={"width": 1}), 2, 1)
    fig.add_trace(go.Scatter(x=v, y=y, name="loop", line={"width": 1.5}), 2, 2)
    fig.update_xaxes(title_text="t (s)", row=1, col=1)
    fig.update_xaxes(title_text="v", row=1, col=2)
    fig.update_xaxes(title_text="t (s)", row=2, col=1)
    fig.update_xaxes(title_text="v", row=2, col=2)
    fig.update_yaxes(title_text="y_D", row=2, col=2)
    fig.update_layout(title="Dead-zone GPI y_D = P[γ[v]] (paper 001 Example 4, Fig. 21)",
                      height=800, width=1150)
    return fig


def inverse_figure(
    m: Model, t: np.ndarray, u: np.ndarray, *, x_name: str = "x", stage: str = "γ",
    out: str = "y_D", title: str = "Inverse dead-zone GPI Π⁻¹ = γ⁻¹∘P⁻¹ (Fig. 22)",
) -> tuple[go.Figure, float]:
    """Fig. 22 (and Fig. 25 for the tanh GPI): u, x = P⁻¹[u], v = stage⁻¹[x]; loop u → v;
    tracking; the output against u. ``m`` is a GPI whose ``pi`` runs after ``stage``."""
    x = m.pi.inverse()(u)  # type: ignore[attr-defined]
    v = m.inverse()(u)
    y = m(v)
    err = float(np.max(np.abs(y - u)))
    fig = make_subplots(rows=2, cols=2, subplot_titles=(
        f"(a) reference u, {x_name} = P⁻¹[u], control input v = {stage}⁻¹[{x_name}]",
        "(b) inverse loop u → v",
        f"(c) tracking: u and compensated {out}", f"(d) compensated characteristic u → {out}"))
    for name, s in (("u", u), (f"{x_name} = P⁻¹[u]", x), (f"v = {stage}⁻¹[{x_name}]", v)):
        fig.add_trace(go.Scatter(x=t, y=s, name=name, line={"width": 1.5}), 1, 1)
    fig.add_trace(go.Scatter(x=u, y=v, name="Π⁻¹ loop", line={"width": 1.5}), 1, 2)
    fig.add_trace(go.Scatter(x=t, y=u, name="reference u", line={"width": 1.5}), 2, 1)
    fig.add_trace(go.Scatter(x=t, y=y, name=f"compensated {out}",
                             line={"width": 1.5, "dash": "dot"}), 2, 1)
    fig.add_trace(go.Scatter(x=u, y=y, name=f"{out} vs u", line={"width": 1.5}), 2, 2)
    fig.update_xaxes(title_text="t (s)", row=1, col=1)
    fig.update_xaxes(title_text="u", row=1, col=2)
    fig.update_xaxes(title_text="t (s)", row=2, col=1)
    fig.update_xaxes(title_text="u", row=2, col=2)
    fig.update_layout(title=f"{title}; max |{out} − u| = {err:.2e}", height=800, width=1150)
    return fig, err


def main() -> None:
    out = parse_out(__doc__.splitlines()[0])
    m = paper001_example4()
    print_parameters(m)
    n = 401 if quick() else 4001
    t = np.linspace(0.0, 1.0, n)
    v = 5 * np.sin(2 * np.pi * t)
    y = m(v)
    w = m.deadzone(v)
    print(f"v = 5 sin 2πt: w in [{w.min():.4f}, {w.max():.4f}], y_D in [{y.min():.4f}, "
          f"{y.max():.4f}]")
    save(model_figure(m, t, v), out, "ex04_deadzone_gpi_model")
    u = 15 * np.sin(2 * np.pi * t)
    fig, err = inverse_figure(m, t, u)
    v_c = m.inverse()(u)
    print(f"u = 15 sin 2πt: control input v in [{v_c.min():.4f}, {v_c.max():.4f}]")
    print(f"compensation error max |P[γ[γ⁻¹[P⁻¹[u]]]] - u| = {err:.3e}")
    back = m.inverse()(y)
    print(f"other order max |Π⁻¹[Π[v]] - v| = {np.max(np.abs(back - v)):.3e}")
    save(fig, out, "ex04_deadzone_gpi_inverse")


if __name__ == "__main__":
    main()
