"""The projector's text (issue 33, item 1, viser): with 16 px text a legend below the plot
would sit on the x-axis title, so it moves above the plot, with a top margin for it."""

from __future__ import annotations

from app.services.explore import figures as F
from app.services.explore.config import Config
from app.services.explore.simulation import compute


def test_a_legend_below_the_plot_moves_above_it_in_large_text() -> None:
    res = compute(Config(), views=["loop"])
    fig = F.build("loop", res)
    assert fig.layout["legend"]["y"] < 0  # the screen layout: under the x axis
    big = F.large_text(fig, 16)
    leg = big.layout["legend"]
    assert leg["y"] >= 1 and leg["yanchor"] == "bottom" and leg["font"]["size"] == 16
    assert big.layout["margin"]["t"] >= 4 * 16 + 50
    assert fig.layout["legend"]["y"] < 0  # the figure itself is not changed


def test_a_legend_inside_the_plot_stays() -> None:
    fig = F.FigureJSON([], {"legend": {"x": 0.56, "y": 0.15}, "title": {"text": "t"}})
    assert F.large_text(fig).layout["legend"]["y"] == 0.15


def test_a_long_title_is_broken_into_lines_for_the_plot_width() -> None:
    title = ("Closed loop (paper 001 Fig. 15-16, mismatch +0%): no compensation: RMS 0.0613; "
             "inverse feedforward: RMS 0.0951; inverse + reference feedforward: RMS 0.000104")
    fig = F.FigureJSON([], {"title": {"text": title}, "margin": {"t": 60}})
    big = F.large_text(fig, 16, width=1200).layout
    lines = big["title"]["text"].split("<br>")
    room = int((1200 - 40) / (0.56 * 20))
    assert len(lines) == 2 and all(len(x) <= room for x in lines)
    assert " ".join(lines) == title  # nothing lost
    assert big["margin"]["t"] == 60 + int(1.3 * 20)
    assert F.large_text(fig, 16).layout["title"]["text"] == title  # no width: as it was


def test_the_inverse_views_clipping_note_still_draws_beside_the_title_wrapping() -> None:
    """The clipping note's own line wrapping (figures._wrap) is not the title's: a tanh GPI
    bounded at +-2 clips its inverse, and the inverse view says so (both in screen and
    projector text)."""
    from app.services.explore.simulation import preset_doc

    model = preset_doc("paper001-example6")["model"]
    model["envelope"]["a"] = model["envelope"]["b"] = [2.0, 0.4, 0.0, 0.0]
    res = compute(Config().with_model(model), views=["inverse"])
    assert res.inverse_warning
    fig = F.build("inverse", res)
    assert "clipped" in " ".join(fig.layout["meta"]["notes"])
    assert F.large_text(fig, 16, width=1200).layout["meta"] == fig.layout["meta"]


def test_below_toolbar_puts_the_title_under_the_toolbar_row() -> None:
    """viser's floating panel (470 px): the title starts under plotly's toolbar row and
    the top margin holds its lines; a title the width cannot hold is broken at spaces."""
    long = "Closed loop: PI controller around the hysteretic plant, with inverse feedforward"
    fig = F.FigureJSON([], {"title": {"text": long}, "margin": {"t": 40}})
    out = F.below_toolbar(fig, 470)
    t = out.layout["title"]
    lines = t["text"].split("<br>")
    assert len(lines) >= 2 and " ".join(lines) == long
    assert (t["yref"], t["yanchor"], t["pad"]["t"]) == ("container", "top", F.TOOLBAR_PX)
    assert out.layout["margin"]["t"] >= F.TOOLBAR_PX + len(lines) * 17
    assert fig.layout["title"] == {"text": long}  # the figure given is not changed
    untitled = F.FigureJSON([], {"margin": {"t": 40}})
    assert F.below_toolbar(untitled, 470) is untitled
