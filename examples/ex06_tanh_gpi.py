"""Tanh-envelope GPI model and its inverse (paper 001 Example 6, Figs. 24-25).

``y_H = P[κ[v]]`` with Example 4's PI and ``κ_R = κ_L = 6 tanh(0.4 v)`` (eq. 44-47), driven
by ``v = 5 sin 2πt``. The inverse ``Π⁻¹ = κ⁻¹ ∘ P⁻¹`` uses ``κ⁻¹(x) = 2.5 atanh(x / 6)``
(eq. 58), defined only for ``|x| < 6``; it is applied to ``u = 10 sin 2πt``. The script
prints the check of κ⁻¹ against the printed formula and the compensation error, shows
what happens to a reference beyond the model's reach (clipping with a
``ClippedInputWarning``), and, for an envelope with κ_R ≠ κ_L, which inverse identities
still hold (see ``core/gpi.py``).

Figures: ``ex06_tanh_gpi_model.html`` (Fig. 24: signals and loop) and
``ex06_tanh_gpi_inverse.html`` (Fig. 25: inverse signals, inverse loop, tracking,
compensated characteristic).

Run: ``python examples/ex06_tanh_gpi.py [--out DIR]`` (``HYST_QUICK=1`` for a short signal).
"""

from __future__ import annotations

import warnings

import numpy as np
import plotly.graph_objects as go
from _common import parse_out, quick, save
from ex04_deadzone_gpi import inverse_figure
from plotly.subplots import make_subplots

from core.exceptions import ClippedInputWarning
from core.gpi import TanhEnvelope, TanhGPI, paper001_example6


def model_figure(m: TanhGPI, t: np.ndarray, v: np.ndarray) -> go.Figure:
    """Fig. 24: v, h = κ[v], y_H over time and the loop v → y_H."""
    h = m.envelope(v)
    y = m(v)
    fig = make_subplots(rows=1, cols=2, subplot_titles=(
        "(a) input v, envelope output h, GPI output y_H", "(b) GPI loop v → y_H"))
    for name, s in (("v", v), ("h = κ[v]", h), ("y_H = P[h]", y)):
        fig.add_trace(go.Scatter(x=t, y=s, name=name, line={"width": 1.5}), 1, 1)
    fig.add_trace(go.Scatter(x=v, y=y, name="loop", line={"width": 1.5}), 1, 2)
    fig.update_xaxes(title_text="t (s)", row=1, col=1)
    fig.update_xaxes(title_text="v", row=1, col=2)
    fig.update_yaxes(title_text="y_H", row=1, col=2)
    fig.update_layout(title="Tanh GPI y_H = P[κ[v]], κ = 6 tanh(0.4 v) (paper 001 Example 6, "
                      "Fig. 24)", height=500, width=1150)
    return fig


def asymmetric_envelope_demo(m: TanhGPI, t: np.ndarray) -> None:
    """κ_R = κ_L - 1 (counter-clockwise envelope): Π∘Π⁻¹ = id, Π⁻¹∘Π wrong at reversals."""
    env = TanhEnvelope((6.0, 0.4, 0.0, -0.5), (6.0, 0.4, 0.0, 0.5))
    ma = TanhGPI(m.pi, env)
    u = 10 * np.sin(2 * np.pi * t)
    err_comp = float(np.max(np.abs(ma(ma.inverse()(u)) - u)))
    v = 4 * np.sin(2 * np.pi * t)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always", ClippedInputWarning)
        back = ma.inverse()(ma(v))
    bad = np.flatnonzero(np.abs(back - v) > 1e-9)
    print("asymmetric envelope κ_R = 6 tanh(0.4 v) - 0.5, κ_L = 6 tanh(0.4 v) + 0.5:")
    print(f"  Π[Π⁻¹[u]] = u: max error {err_comp:.2e} (exact: the compensator works)")
    print(f"  Π⁻¹[Π[v]] = v fails at {bad.size} of {v.size} samples, the reversal samples "
          f"{bad.tolist()} (h jumps by 1 there while v moves by less)")
    if rec:
        print(f"  ({len(rec)} warning: κ_R⁻¹ is evaluated at κ_L(v) on a mismatched reversal, "
              "which can lie outside its domain and is clipped)")


def main() -> None:
    out = parse_out(__doc__.splitlines()[0])
    m = paper001_example6()
    n = 401 if quick() else 4001
    t = np.linspace(0.0, 1.0, n)

    x = np.linspace(-5.9, 5.9, 11)
    kinv = m.envelope.inverse()
    dev = float(np.max(np.abs(kinv(x) - 2.5 * np.arctanh(x / 6))))
    print(f"κ⁻¹(x) vs printed 2.5 atanh(x/6): max difference {dev:.1e}; domain of κ⁻¹: "
          f"{kinv.domain_r[0]:g} < x < {kinv.domain_r[1]:g}")

    v = 5 * np.sin(2 * np.pi * t)
    h = m.envelope(v)
    y = m(v)
    print(f"v = 5 sin 2πt: h in [{h.min():.4f}, {h.max():.4f}], y_H in [{y.min():.4f}, "
          f"{y.max():.4f}]")
    save(model_figure(m, t, v), out, "ex06_tanh_gpi_model")

    u = 10 * np.sin(2 * np.pi * t)
    fig, err = inverse_figure(m, t, u, x_name="d", stage="κ", out="y_H",
                              title="Inverse tanh GPI Π⁻¹ = κ⁻¹∘P⁻¹ (Fig. 25)")
    d = m.pi.inverse()(u)
    print(f"u = 10 sin 2πt: d = P⁻¹[u] in [{d.min():.4f}, {d.max():.4f}] (inside |d| < 6)")
    print(f"compensation error max |P[κ[κ⁻¹[P⁻¹[u]]]] - u| = {err:.3e}")
    save(fig, out, "ex06_tanh_gpi_inverse")

    big = 30 * np.sin(2 * np.pi * t)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always", ClippedInputWarning)
        y_big = m(m.inverse()(big))
    msgs = [str(w.message) for w in rec if issubclass(w.category, ClippedInputWarning)]
    print(f"u = 30 sin 2πt is beyond reach: κ saturates at ±6, so from rest |y_H| < P[6] = "
          f"{m.pi([6.0])[0]:.3f}:")
    print("  warning:", msgs[0] if msgs else "none")
    print(f"  compensated output saturates at [{y_big.min():.3f}, {y_big.max():.3f}]")

    asymmetric_envelope_demo(m, np.linspace(0.0, 1.0, 400, endpoint=False))


if __name__ == "__main__":
    main()
