"""Identification on measured B-H loops: classical PI against generalized PI models.

Data: ``load_dataset("bh-...")`` (R. Szewczyk, JAmodel, MIT licence): quasi-static symmetric
B(H) loops of four soft magnetic materials, one loop per field amplitude (MnZn ferrite: 4,
MnZn high-permeability ferrite: 4, M130-27s grain-oriented steel: 3, amorphous alloy: 1);
u = field H (A/m), y = flux density B (T). There is **no time axis**: the samples are points
along the loop (``Recording.has_time`` is False), and only their order matters to a
rate-independent model.

Setup: every loop is its own run (the play operators restart at each loop). A measured
steady-state loop has no virgin start, so each loop is traversed twice: the first pass only
sets the operator memory, the second is scored (``train=`` masks). All loops of a material
share one model. Models (all with ``constraint="slopes"``, needed for saturating loops):

* classical PI (``PIRegressor``), whose loops all obey the Masing rules, so loops of several
  amplitudes cannot all fit;
* Kuhnen MPI ``B = c0 + S[P[H] + c1]`` (``ModifiedPIRegressor``),
* dead-zone GPI ``B = c + P[γ(H)]`` (``DeadZoneGPIRegressor``),
* tanh GPI ``B = c + P[κ(H)]`` (``TanhGPIRegressor``); the last two are skipped in quick mode.

A second table (full mode) holds one interior amplitude out (loop 2 of each multi-loop
material) and scores the model on it: interpolation to an unseen amplitude.

Figure: ``ex13_fit_bh_loops.html`` (measured loops vs models, one panel per material).

Run: ``python examples/ex13_fit_bh_loops.py [--out DIR]`` (``HYST_QUICK=1``: classical PI and
MPI only, no held-out-amplitude table).
"""

from __future__ import annotations

import warnings

import numpy as np
import plotly.graph_objects as go
from _common import parse_out, quick, save
from plotly.subplots import make_subplots

from core.datasets import load_dataset
from core.exceptions import FitWarning
from core.fitting import (
    DeadZoneGPIRegressor,
    ModifiedPIRegressor,
    PIRegressor,
    TanhGPIRegressor,
)

NAMES = ["bh-MnZn-ferrite", "bh-MnZn-HP-ferrite", "bh-M130-27s-GO-steel", "bh-amorphous-alloy"]
COLORS = {"PI": "#d62728", "MPI": "#2ca02c", "DZ-GPI": "#9467bd", "tanh-GPI": "#ff7f0e"}
HELD_OUT_LOOP = 1  # interior amplitude (second smallest)


def models() -> dict:
    out = {"PI": PIRegressor, "MPI": ModifiedPIRegressor}
    if not quick():
        out["DZ-GPI"] = DeadZoneGPIRegressor
        out["tanh-GPI"] = TanhGPIRegressor
    return out


def runs(loops) -> tuple[list, list, list, list]:
    """Each loop twice; masks of the second pass (scored) and of nothing."""
    us = [np.tile(lp.u, 2) for lp in loops]
    ys = [np.tile(lp.y, 2) for lp in loops]
    second = [np.r_[np.zeros(lp.n_samples, bool), np.ones(lp.n_samples, bool)] for lp in loops]
    none = [np.zeros(2 * lp.n_samples, bool) for lp in loops]
    return us, ys, second, none


def fit(cls, us, ys, train, test):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", FitWarning)
        est = cls(constraint="slopes").fit(us, ys, train=train, test=test)
    return est, [str(w.message).split(":")[0] for w in caught]


def print_table(results: dict) -> None:
    print(f"\n{'material':<22}{'loops':>5} {'model':<9}{'n':>3}{'par':>4}{'RMSE (T)':>10}"
          f"{'% range':>9}{'max (T)':>9}{'inv-H %':>9}{'M(M⁻¹B)-B':>11}")
    for mat, (loops, fits, _) in results.items():
        for name, (est, _) in fits.items():
            r = est.report_
            clipped = " clipped" if r.extra.get("inverse_clipped_chunks") else ""
            print(f"{mat:<22}{len(loops):>5} {name:<9}{est.n_operators_:>3}{r.n_parameters:>4}"
                  f"{r.train.rmse:>10.4f}{r.train.rmse_pct:>8.2f}%{r.train.max_abs:>9.4f}"
                  f"{r.train.inverse_input_rmse_pct:>8.2f}%{r.compensation_max_abs:>11.1e}"
                  f"{clipped}")
    print("  (scored: second pass of every loop; % range = RMSE / B range over all loops of "
          "the material; inv-H % = RMSE of M⁻¹(B) − H in % of the H range)")
    if any(est.report_.extra.get("inverse_clipped_chunks")
           for _, fits, _ in results.values() for est, _ in fits.values()):
        print("  (clipped: P⁻¹(B − c) leaves (−1, 1), the range of the tanh envelope κ, so κ⁻¹ "
              "clips there and M(M⁻¹B) ≠ B: not exactly invertible on these data)")


def held_out_table() -> None:
    print(f"\nheld-out amplitude: loop {HELD_OUT_LOOP + 1} of each material scored, the other "
          "loops trained")
    print(f"{'material':<22}{'H_pk (A/m)':>11}" + "".join(f"{m:>10}" for m in models()))
    for mat in NAMES:
        loops = load_dataset(mat)
        if len(loops) < 3:
            continue
        us, ys, second, none = runs(loops)
        k = HELD_OUT_LOOP
        tr = [none[j] if j == k else second[j] for j in range(len(loops))]
        te = [second[j] if j == k else none[j] for j in range(len(loops))]
        row = f"{mat:<22}{np.max(loops[k].u):>11.1f}"
        for cls in models().values():
            est, _ = fit(cls, us, ys, tr, te)
            row += f"{est.report_.test.rmse_pct:>9.1f}%"
        print(row.rstrip())
    print("  (held-out RMSE in % of that loop's B range)")


def figure(results: dict) -> go.Figure:
    mats = list(results)
    fig = make_subplots(rows=2, cols=2, subplot_titles=mats, horizontal_spacing=0.08,
                        vertical_spacing=0.1)
    shown = set()
    for k, mat in enumerate(mats):
        loops, fits, _ = results[mat]
        row, col = k // 2 + 1, k % 2 + 1
        preds = {name: est.predict([np.tile(lp.u, 2) for lp in loops])
                 for name, (est, _) in fits.items()}
        for j, lp in enumerate(loops):
            n = lp.n_samples
            close = np.r_[np.arange(n), 0]  # close the loop for drawing
            fig.add_trace(go.Scatter(x=lp.u[close], y=lp.y[close], name="measured",
                                     legendgroup="measured", showlegend="measured" not in shown,
                                     mode="lines+markers", marker={"size": 3},
                                     line={"color": "black", "width": 2}), row, col)
            shown.add("measured")
            for name, yh in preds.items():
                y2 = yh[j][n:]
                fig.add_trace(go.Scatter(x=lp.u[close], y=y2[close], name=name,
                                         legendgroup=name, showlegend=name not in shown,
                                         line={"color": COLORS[name], "width": 1.3,
                                               "dash": "dot"}), row, col)
                shown.add(name)
        fig.update_xaxes(title_text="H (A/m)", row=row, col=col)
        fig.update_yaxes(title_text="B (T)", row=row, col=col)
    fig.update_layout(title="B-H loops: measured vs classical PI and generalized PI models "
                      "(one model per material, second pass of every loop)",
                      height=950, width=1200)
    return fig


def main() -> None:
    out = parse_out(__doc__.splitlines()[0])
    results = {}
    for mat in NAMES:
        loops = load_dataset(mat)
        amps = ", ".join(f"{np.max(lp.u):g}" for lp in loops)
        print(f"{mat}: {len(loops)} loop(s), {sum(lp.n_samples for lp in loops)} points, "
              f"H_pk = {amps} A/m, B_pk up to {max(np.max(lp.y) for lp in loops):.3f} T "
              f"(has_time={loops[0].has_time})")
        us, ys, second, none = runs(loops)
        fits = {name: fit(cls, us, ys, second, none) for name, cls in models().items()}
        for name, (_, notes) in fits.items():
            for note in notes:
                print(f"  FitWarning, {name}: {note}")
        results[mat] = (loops, fits, None)
    print_table(results)
    print(f"\n{'RMSE % of B range':<22}{'classical PI':>13}{'best generalized':>24}"
          f"{'best, exact inverse':>26}")
    for mat, (_, fits, _) in results.items():
        pi = fits["PI"][0].report_.train.rmse_pct
        gen = [f for f in fits if f != "PI"]
        exact = [f for f in gen if not fits[f][0].report_.extra.get("inverse_clipped_chunks")]
        row = f"{mat:<22}{pi:>12.2f}%"
        for cands in (gen, exact):
            best = min(cands, key=lambda f: fits[f][0].report_.train.rmse)
            row += f"{fits[best][0].report_.train.rmse_pct:>14.2f}% " + f"({best})".ljust(11)
        print(row.rstrip())
    if not quick():
        held_out_table()
    save(figure(results), out, "ex13_fit_bh_loops")


if __name__ == "__main__":
    main()
