"""Pure figure builders (``app.services.explore.figures``):
decimation keeps reversals, figures validate."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
import pytest

from app.services.explore import config as S
from app.services.explore import figures as F
from app.services.explore import simulation as C


def test_decimate_keeps_reversals() -> None:
    t = np.linspace(0, 1, 20_000)
    u = np.sin(2 * np.pi * 7 * t)
    idx = F.decimate_index(u, 500)
    assert idx[0] == 0 and idx[-1] == u.size - 1 and idx.size < 700
    turns = np.flatnonzero(np.diff(np.sign(np.diff(u))) != 0) + 1
    assert set(turns) <= set(idx)


def test_typed_arrays_round_trip_and_figures_validate() -> None:
    res = C.compute(S.Config(signal=S.SignalSpec(samples=3000)))
    for name in F.FIGURES:
        fig = F.build(name, res)
        go.Figure(fig.to_dict())
    loop = F.loop_figure(res).to_dict()["data"][0]
    np.testing.assert_allclose(F.values(loop["x"]), res.u[F.decimate_index(res.u)], rtol=1e-6)
    ops = F.operators_figure(res).to_dict()
    assert len(ops["data"]) == 6 + 2  # p0 u, six operators, the sum
    with pytest.raises(KeyError):
        F.build("nope", res)


def test_the_time_views_shared_axis_is_under_the_lower_plot() -> None:
    """Issue 33: the time axis hung under the upper plot (anchored to it), so its title
    "time t [s]" was drawn inside the lower plot in a short panel."""
    res = C.compute(S.Config(), views=["time"])
    lay = F.time_figure(res).layout
    under = lay["xaxis"]["anchor"]  # the y axis the time axis is drawn along
    lowest = min((k for k in lay if k.startswith("yaxis")),
                 key=lambda k: lay[k].get("domain", [0.0, 1.0])[0])
    assert "yaxis" + under[1:] == lowest
    assert lay["xaxis"]["title"]["text"] == "time t [s]"
    # both plots still share the one time axis
    assert {tr.get("xaxis", "x") for tr in F.time_figure(res).data} == {"x"}


def test_the_time_views_legend_goes_above_in_projector_mode() -> None:
    """The time view's legend sits at the figure's foot (container coordinates); a projector's
    larger axis title would reach it there, so ``large_text`` puts it above the plot."""
    res = C.compute(S.Config(), views=["time"])
    fig = F.time_figure(res)
    assert fig.layout["legend"]["yref"] == "container" and fig.layout["legend"]["y"] == 0
    leg = F.large_text(fig).layout["legend"]
    assert leg["yref"] == "paper" and leg["y"] >= 1 and leg["yanchor"] == "bottom"


def test_a_fit_of_several_loops_draws_each_loop_apart_on_sample_numbers() -> None:
    """Two closed loops of one file kept together (each row marked by its run, as an upload
    of every run keeps them): the overlay and the residual break between the loops (NaN
    gaps: no line from the end of one loop to the start of the next), every measured point
    is drawn once, and a file without a time column gets a sample axis, not 'time'."""
    from dataclasses import replace

    from app.services.analysis.loops import RUN_POSITION, on_samples
    from core.recordings import Recording

    k = np.arange(200)
    u = np.concatenate([np.cos(2 * np.pi * k / 200), 3.0 * np.cos(2 * np.pi * k / 200)])
    y = np.tanh(u)
    rec = Recording(np.arange(400) * 1e-3, u, y, "loops.csv", units={"input": "A/m",
                                                                   "output": "T"})
    rec = replace(rec, extra={RUN_POSITION: np.repeat([0.0, 1.0], 200)},
                  columns={**rec.columns, "time": ""})
    fig = F.fit_figure(on_samples(rec), 0.9 * y, "fit").to_dict()
    measured, fitted, residual = fig["data"]
    for trace in (measured, fitted, residual):
        x, yy = F.values(trace["x"]), F.values(trace["y"])
        gaps = np.flatnonzero(np.isnan(yy))
        assert gaps.size == 1 and np.isnan(x[gaps[0]])  # one gap, between the two loops
        assert x[gaps[0] - 1] == pytest.approx(u[199] if trace is not residual else 199)
    np.testing.assert_allclose(np.sort(F.values(measured["y"])[~np.isnan(
        F.values(measured["y"]))]), np.sort(y[F.decimate_index(u)]), rtol=1e-6)
    assert fig["layout"]["xaxis2"]["title"]["text"].startswith("sample number")
    # one run, with a time column: no gap, and the time axis in seconds
    one = F.fit_figure(Recording(rec.t[:200], u[:200], y[:200], "one"), y[:200]).to_dict()
    assert not np.isnan(F.values(one["data"][0]["y"])).any()
    assert one["layout"]["xaxis2"]["title"]["text"] == "time t [s]"
