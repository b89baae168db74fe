"""Identification on the four friction-damper recordings (displacement → force).

Data: ``load_dataset("friction-<f>-<T>")`` (Coble et al. 2022, CC BY-SA 4.0): a banded rotary
friction damper driven by an amplitude-tapered sine (7 cycles, nested reversals) at
0.25, 1 and 2 Hz with 30 lb band tension, and at 1 Hz with 36 lb; u = displacement (in),
y = force (kip), 1024 Hz. Each record is fitted on its first 80 % and scored on the last
20 % (the regressors' default ``validation=0.2``); the number of operators is chosen by
blocked cross-validation on the training part.

Friction saturates: once the damper slips the force stays at the slip force whatever the
displacement, so the loading curve is concave and the loops run clockwise. Play operators with
``p_i >= 0`` (only hardening loops) cannot represent it; the non-negative rule
``constraint="nonnegative"`` is therefore applied to stop operators on clockwise data
(``p0 = k + Σ w_i``, ``p_i = -w_i``, ``k >= ε``, ``w_i >= 0``: Maxwell-slip elements; the
report's orientation line says so), and the exact invertibility condition
``constraint="slopes"`` (every loop-segment slope ``p0 + p_1 + ... + p_j >= ε``, weights of
either sign) also lets a branch flatten and rise again. Models compared per record:

* classical PI, ``constraint="nonnegative"`` (stop operators here);
* classical PI, ``constraint="slopes"``;
* Kuhnen MPI and dead-zone GPI with ``constraint="slopes"`` (skipped in quick mode).

The inverse (force → displacement) is printed too, and it is honestly poor: on the sliding
branches the fitted slope sits at its floor ε, so the exact inverse amplifies force noise by
``1/ε``. A saturating friction force does not determine the displacement.

Figures: ``ex12_fit_friction_damper_loops.html`` (force-displacement loops per record,
measured vs models, training and held-out parts) and ``ex12_fit_friction_damper_time.html``
(force over time per record with the held-out part shaded).

Run: ``python examples/ex12_fit_friction_damper.py [--out DIR]`` (``HYST_QUICK=1``: the two
classical fits only).
"""

from __future__ import annotations

import warnings

import numpy as np
import plotly.graph_objects as go
from _common import parse_out, quick, save
from plotly.subplots import make_subplots

from core.datasets import load_dataset
from core.exceptions import FitWarning
from core.fitting import DeadZoneGPIRegressor, ModifiedPIRegressor, PIRegressor

NAMES = ["friction-0.25Hz-30lb", "friction-1Hz-30lb", "friction-1Hz-36lb", "friction-2Hz-30lb"]
VALIDATION = 0.2
COLORS = {"PI nonneg": "#1f77b4", "PI slopes": "#d62728", "MPI slopes": "#2ca02c",
          "DZ-GPI slopes": "#9467bd"}


def models() -> dict:
    """Model name -> estimator factory (fresh estimator per record)."""
    out = {
        "PI nonneg": lambda: PIRegressor(constraint="nonnegative", validation=VALIDATION),
        "PI slopes": lambda: PIRegressor(constraint="slopes", validation=VALIDATION),
    }
    if not quick():
        out["MPI slopes"] = lambda: ModifiedPIRegressor(constraint="slopes",
                                                        validation=VALIDATION)
        out["DZ-GPI slopes"] = lambda: DeadZoneGPIRegressor(constraint="slopes",
                                                            validation=VALIDATION)
    return out


def fit_record(rec) -> tuple[dict, list[str]]:
    fits, notes = {}, []
    for name, make in models().items():
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", FitWarning)
            fits[name] = make().fit(rec)
        for w in caught:
            if issubclass(w.category, FitWarning):
                notes.append(f"{name}: {str(w.message).split(':')[0]}")
    return fits, notes


def print_table(results: dict) -> None:
    print(f"\n{'record':<22}{'model':<15}{'n':>3}{'train %':>9}{'test RMSE':>10}{'test %':>8}"
          f"{'test max':>9}{'inv-u RMSE':>12}{'M(M⁻¹y)-y':>11}")
    for rec_name, (_, fits, _) in results.items():
        for name, est in fits.items():
            r = est.report_
            print(f"{rec_name:<22}{name:<15}{est.n_operators_:>3}{r.train.rmse_pct:>8.2f}%"
                  f"{r.test.rmse:>10.4f}{r.test.rmse_pct:>7.2f}%{r.test.max_abs:>9.3f}"
                  f"{r.test.inverse_input_rmse:>9.3g} in{r.compensation_max_abs:>11.1e}")
    print("  (force in kip; % = RMSE / measured force range of that part; test = last 20 %; "
          "inv-u RMSE = RMSE of M⁻¹(force) − displacement on the held-out part, input range "
          "≈ 1 in)")


def loop_figure(results: dict) -> go.Figure:
    names = list(results)
    fig = make_subplots(rows=2, cols=2, subplot_titles=names, horizontal_spacing=0.08,
                        vertical_spacing=0.1)
    for k, rec_name in enumerate(names):
        rec, fits, _ = results[rec_name]
        row, col = k // 2 + 1, k % 2 + 1
        n = rec.n_samples
        cut = n - int(round(VALIDATION * n))
        step = max(1, n // (1500 if quick() else 6000))
        first = k == 0
        fig.add_trace(go.Scatter(x=rec.u[:cut:step], y=rec.y[:cut:step], name="measured, train",
                                 showlegend=first, legendgroup="mt",
                                 line={"color": "#bbbbbb", "width": 1}), row, col)
        fig.add_trace(go.Scatter(x=rec.u[cut::step], y=rec.y[cut::step],
                                 name="measured, held-out", showlegend=first, legendgroup="mh",
                                 line={"color": "black", "width": 2}), row, col)
        for name, est in fits.items():
            yh = est.predict(rec.u)
            fig.add_trace(go.Scatter(x=rec.u[cut::step], y=yh[cut::step],
                                     name=f"{name} (held-out)", showlegend=first,
                                     legendgroup=name,
                                     line={"color": COLORS[name], "width": 1.3, "dash": "dot"}),
                          row, col)
        fig.update_xaxes(title_text="displacement (in)", row=row, col=col)
        fig.update_yaxes(title_text="force (kip)", row=row, col=col)
    fig.update_layout(title="Friction damper: force-displacement loops, measured vs models "
                      "(held-out = last 20 %)", height=900, width=1200)
    return fig


def time_figure(results: dict) -> go.Figure:
    names = list(results)
    fig = make_subplots(rows=len(names), cols=1, subplot_titles=names, vertical_spacing=0.06)
    for k, rec_name in enumerate(names):
        rec, fits, _ = results[rec_name]
        n = rec.n_samples
        cut = n - int(round(VALIDATION * n))
        step = max(1, n // (1500 if quick() else 6000))
        s = slice(None, None, step)
        fig.add_trace(go.Scatter(x=rec.t[s], y=rec.y[s], name="measured", showlegend=k == 0,
                                 legendgroup="m", line={"color": "black", "width": 1.5}),
                      k + 1, 1)
        for name, est in fits.items():
            fig.add_trace(go.Scatter(x=rec.t[s], y=est.predict(rec.u)[s], name=name,
                                     showlegend=k == 0, legendgroup=name,
                                     line={"color": COLORS[name], "width": 1, "dash": "dot"}),
                          k + 1, 1)
        fig.add_vrect(x0=rec.t[cut], x1=rec.t[-1], fillcolor="#ff7f0e", opacity=0.12,
                      line_width=0, row=k + 1, col=1)
        fig.update_yaxes(title_text="force (kip)", row=k + 1, col=1)
    fig.update_xaxes(title_text="t (s)", row=len(names), col=1)
    fig.update_layout(title="Friction damper: force over time (shaded: held-out last 20 %)",
                      height=300 * len(names), width=1150)
    return fig


def main() -> None:
    out = parse_out(__doc__.splitlines()[0])
    results = {}
    for rec_name in NAMES:
        rec = load_dataset(rec_name)
        print(f"{rec_name}: {rec.n_samples} samples, {rec.duration:g} s at {rec.fs:g} Hz, "
              f"displacement [{rec.u.min():.3f}, {rec.u.max():.3f}] in, force "
              f"[{rec.y.min():.3f}, {rec.y.max():.3f}] kip")
        fits, notes = fit_record(rec)
        results[rec_name] = (rec, fits, notes)
        for note in notes:
            print(f"  FitWarning, {note}")
    print_table(results)
    print("\nheld-out RMSE (% of force range), classical PI non-negative stop weights → "
          "slopes:")
    for rec_name, (_, fits, _) in results.items():
        a, b = fits["PI nonneg"].report_.test, fits["PI slopes"].report_.test
        print(f"  {rec_name:<22}{a.rmse_pct:6.2f} % → {b.rmse_pct:5.2f} %  "
              f"({a.rmse_pct / b.rmse_pct:.1f}× smaller)")
    ps = results[NAMES[1]][1]["PI slopes"]
    print(f"\n{NAMES[1]}, PI slopes: p0 = {ps.p0_:.3g} kip/in, weights "
          f"{np.array2string(ps.weights_, precision=2, max_line_width=200)} kip/in "
          f"(negative weights = saturation), smallest slope {ps.model_.slopes.min():.3g} "
          f"kip/in (floor ε = {ps.min_slope_:.3g}) → inverse slope up to "
          f"{1 / ps.model_.slopes.min():.3g} in/kip")
    save(loop_figure(results), out, "ex12_fit_friction_damper_loops")
    save(time_figure(results), out, "ex12_fit_friction_damper_time")


if __name__ == "__main__":
    main()
