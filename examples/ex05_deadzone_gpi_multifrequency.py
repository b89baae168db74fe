"""Dead-zone GPI under a two-frequency input (paper 001 Example 5, Fig. 23).

Same model as Example 4 (``y_D = P[γ[v]]``). The reference
``u = 8.25 sin 2πt + 6.75 sin 10πt`` (1 Hz and 5 Hz) goes through the inverse
``Π⁻¹ = γ⁻¹ ∘ P⁻¹``; the resulting control input ``v`` drives the model. The minor loops
of the 5 Hz component show in both the inverse loop (u → v) and the model loop (v → y_D),
and the compensated characteristic (u → y_D) is the identity line. The script prints the
number of reversals and the compensation error.

Figure: ``ex05_deadzone_gpi_multifrequency.html`` ((a) inverse loop, (b) model loop,
(c) compensated characteristic, (d) signals over time).

Run: ``python examples/ex05_deadzone_gpi_multifrequency.py [--out DIR]`` (``HYST_QUICK=1``).
"""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
from _common import parse_out, quick, save
from plotly.subplots import make_subplots

from core.gpi import paper001_example4


def main() -> None:
    out = parse_out(__doc__.splitlines()[0])
    m = paper001_example4()
    n = 1001 if quick() else 10001
    t = np.linspace(0.0, 1.0, n)
    u = 8.25 * np.sin(2 * np.pi * t) + 6.75 * np.sin(10 * np.pi * t)
    inv = m.inverse()
    v = inv(u)
    y = m(v)
    err = float(np.max(np.abs(y - u)))
    turns = int(np.count_nonzero(np.diff(np.sign(np.diff(u)))))
    print(f"u = 8.25 sin 2πt + 6.75 sin 10πt: {turns} reversals, u in [{u.min():.3f}, "
          f"{u.max():.3f}]")
    print(f"control input v = γ⁻¹[P⁻¹[u]] in [{v.min():.4f}, {v.max():.4f}]")
    print(f"model output y_D = P[γ[v]] in [{y.min():.4f}, {y.max():.4f}]")
    print(f"compensation error max |y_D - u| = {err:.3e} (relative {err / np.abs(u).max():.1e})")

    fig = make_subplots(rows=2, cols=2, subplot_titles=(
        "(a) inverse GPI loop u → v", "(b) GPI loop v → y_D",
        "(c) compensated characteristic u → y_D", "(d) signals"))
    fig.add_trace(go.Scatter(x=u, y=v, name="Π⁻¹: u → v", line={"width": 1.2}), 1, 1)
    fig.add_trace(go.Scatter(x=v, y=y, name="Π: v → y_D", line={"width": 1.2}), 1, 2)
    fig.add_trace(go.Scatter(x=u, y=y, name="y_D vs u", line={"width": 1.2}), 2, 1)
    for name, s in (("u", u), ("v", v), ("y_D", y)):
        fig.add_trace(go.Scatter(x=t, y=s, name=name, line={"width": 1.2}), 2, 2)
    fig.update_xaxes(title_text="u", row=1, col=1)
    fig.update_xaxes(title_text="v", row=1, col=2)
    fig.update_xaxes(title_text="u", row=2, col=1)
    fig.update_xaxes(title_text="t (s)", row=2, col=2)
    fig.update_layout(title=f"Dead-zone GPI, two-frequency input (paper 001 Example 5, Fig. 23);"
                      f" max |y_D − u| = {err:.1e}", height=800, width=1150)
    save(fig, out, "ex05_deadzone_gpi_multifrequency")


if __name__ == "__main__":
    main()
