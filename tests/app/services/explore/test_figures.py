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
