"""Screen shapes: where the viser plot goes (phone or not, at any pixel ratio) and the
projector's large text."""

from __future__ import annotations

import plotly.graph_objects as go
import pytest

from app.gui.layout import is_narrow
from app.services.explore import figures as F
from app.services.explore.config import Config
from app.services.explore.simulation import compute


@pytest.mark.parametrize("css_w, css_h", [(390, 844), (360, 780), (430, 932)])
@pytest.mark.parametrize("ratio", [1, 2, 3])
@pytest.mark.parametrize("adaptive", [0.75, 1.0])
def test_a_phone_is_narrow_at_every_pixel_ratio(css_w: int, css_h: int, ratio: int,
                                                adaptive: float) -> None:
    # viser reports canvas.width: CSS px x devicePixelRatio x its adaptive factor
    s = ratio * adaptive
    assert is_narrow(css_w * s, css_h * s)


@pytest.mark.parametrize("w, h", [(1280, 800), (1920, 1080), (2560, 1600), (3840, 2160)])
def test_laptops_and_projectors_are_not(w: int, h: int) -> None:
    assert not is_narrow(w, h) and not is_narrow(0.75 * w, 0.75 * h)


def test_large_text_reaches_every_text_of_a_two_panel_figure() -> None:
    res = compute(Config(), views={"inverse"})
    fig = F.large_text(F.build("inverse", res), 16)
    lay = fig.layout
    go.Figure(fig.to_dict())  # still a valid figure
    axes = [k for k in lay if k.startswith(("xaxis", "yaxis"))]
    assert len(axes) >= 4
    assert all(lay[k]["tickfont"]["size"] >= 16 for k in axes)
    assert all(lay[k]["title"]["font"]["size"] >= 16 for k in axes if "title" in lay[k])
    assert lay["font"]["size"] == 16 and lay["title"]["font"]["size"] == 20
