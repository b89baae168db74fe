"""Lines cut to the samples a plot's pixels draw (``figures.pixel_index``,
``figures.fit_to_pixels``; issue 33: a viser tab's plotly laid out 670 samples per trace
for a 470 px plot on every lesson move)."""

from __future__ import annotations

import numpy as np
import plotly.graph_objects as go

from app.services.explore import config as S
from app.services.explore import figures as F
from app.services.explore import simulation as C


def _drawn_error(x: np.ndarray, y: np.ndarray, keep: np.ndarray) -> float:
    """Largest distance of any sample from the polyline through ``keep`` (brute force:
    every sample against every drawn segment)."""
    ax, ay, bx, by = x[keep[:-1]], y[keep[:-1]], x[keep[1:]], y[keep[1:]]
    px, py = x[:, None] - ax, y[:, None] - ay
    dx, dy = bx - ax, by - ay
    len2 = np.where(dx * dx + dy * dy > 0, dx * dx + dy * dy, 1.0)
    t = np.clip((px * dx + py * dy) / len2, 0, 1)
    return float(np.sqrt(((px - t * dx) ** 2 + (py - t * dy) ** 2).min(axis=1)).max())


def _turns(v: np.ndarray) -> set[int]:
    return set((np.flatnonzero(np.diff(np.sign(np.diff(v))) != 0) + 1).tolist())


def test_a_sine_in_time_keeps_its_peaks_within_a_quarter_pixel() -> None:
    t = np.linspace(0.0, 2.0, 670)
    y = np.sin(2 * np.pi * 1.5 * t)
    x_px, y_px = t * 800 / 2.0, y * 576 / 2.0  # an 800 x 576 px plot
    keep = F.pixel_index(x_px, y_px, 0.25)
    assert keep[0] == 0 and keep[-1] == t.size - 1
    assert _turns(y) <= set(keep.tolist())  # every peak and trough, exact
    assert _drawn_error(x_px, y_px, keep) <= 0.25
    assert keep.size < t.size / 4  # 670 -> 125 or fewer


def test_a_loop_keeps_every_input_reversal() -> None:
    res = C.compute(S.Config(), views=["loop"])
    u, y = res.u, res.y
    x_px = (u - u.min()) / np.ptp(u) * 780
    y_px = (y - y.min()) / np.ptp(y) * 560
    keep = F.pixel_index(x_px, y_px)
    assert _turns(u) <= set(keep.tolist())
    assert _drawn_error(x_px, y_px, keep) <= F.PIXEL_TOL
    assert keep.size < u.size / 5


def test_a_gap_stays_a_gap() -> None:
    x = np.linspace(0.0, 100.0, 400)
    y = 0.5 * x
    y[200] = np.nan
    keep = F.pixel_index(x, y)
    assert {0, 199, 200, 201, 399} <= set(keep.tolist())
    assert keep.size == 5  # two straight lines and the gap between them


def test_noise_is_kept_where_it_shows() -> None:
    rng = np.random.default_rng(3)
    x = np.linspace(0.0, 400.0, 800)
    y = 20.0 * rng.standard_normal(800)  # every sample a pixel-sized peak
    keep = F.pixel_index(x, y)
    assert _drawn_error(x, y, keep) <= F.PIXEL_TOL
    assert _turns(y) <= set(keep.tolist())


def _fig(**trace: object) -> F.FigureJSON:
    t = np.linspace(0.0, 1.0, 500)
    tr = {"type": "scatter", "mode": "lines", "x": F._num(t),
          "y": F._num(np.sin(2 * np.pi * t)), **trace}
    return F.FigureJSON([tr], F._layout("a sine"))


def test_fit_to_pixels_cuts_lines_only() -> None:
    cut = F.fit_to_pixels(_fig(), 780, 560)
    assert F.values(cut.data[0]["x"]).size < 100
    go.Figure(cut.to_dict())  # still a valid plotly figure
    for whole in (_fig(mode="lines+markers"), _fig(text=["a"] * 500),
                  _fig(line={"dash": "dash"}), _fig(x=["a"] * 500),
                  _fig(line={"shape": "hv"}), _fig(line={"shape": "spline"})):
        assert F.fit_to_pixels(whole, 780, 560) is whole  # each sample shown or named
    log = _fig()
    log.layout["yaxis"] = {"type": "log"}
    assert F.fit_to_pixels(log, 780, 560) is log


def test_a_gap_in_a_plain_list_stays_a_gap() -> None:
    y: list[float | None] = [float(v) for v in np.sin(np.linspace(0.0, 6.0, 500))]
    y[250] = None  # plotly's gap in a plain list
    cut = F.fit_to_pixels(_fig(y=y), 780, 560)
    got_x, got_y = F.values(cut.data[0]["x"]), F.values(cut.data[0]["y"])
    assert got_y.size < 100
    gap = np.flatnonzero(np.isnan(got_y))
    assert gap.size == 1
    assert got_x[gap[0]] == np.float32(np.linspace(0.0, 1.0, 500)[250])


def test_fit_to_pixels_reads_a_fixed_range_narrower_than_the_data() -> None:
    """A zoomed axis (fixed range a tenth of the data's) draws ten times the pixels per
    unit: more samples are kept, the drawn error on that range still within tol."""
    whole = F.values(F.fit_to_pixels(_fig(), 780, 560).data[0]["x"]).size
    zoomed = _fig()
    zoomed.layout["yaxis"] = {"range": [-0.1, 0.1]}
    assert F.values(F.fit_to_pixels(zoomed, 780, 560).data[0]["x"]).size > whole


def _found(x: np.ndarray, y: np.ndarray, kx: np.ndarray, ky: np.ndarray) -> np.ndarray:
    """Where each kept point ``(kx, ky)`` is among the samples, searched in order."""
    out, at = [], 0
    for p, q in zip(kx, ky, strict=True):
        same = ((x[at:] == p) | (np.isnan(x[at:]) & np.isnan(p))) \
            & ((y[at:] == q) | (np.isnan(y[at:]) & np.isnan(q)))
        at += int(np.flatnonzero(same)[0])
        out.append(at)
    return np.array(out)


def _drawn(fig: F.FigureJSON) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each trace's line as plotly draws it: a stacked trace at its running sum."""
    sums: dict[str, np.ndarray] = {}
    out = []
    for t in fig.data:
        x, y = F.values(t["x"]).astype(float), F.values(t["y"]).astype(float)
        if t.get("stackgroup"):
            y = sums[t["stackgroup"]] = sums.get(t["stackgroup"], 0.0) + y
        out.append((x, y))
    return out


def test_the_lesson_figures_drawn_within_a_quarter_pixel_of_every_sample() -> None:
    """Each view of Example 1 on an 800 px plot: every sample of every drawn line (a
    stacked band at its running sum) lies within the tolerance of the line drawn through
    the kept ones, on the line's own span (the figure's plot area is smaller than 800 px:
    the error there is smaller still); the bands of a stack keep the same samples."""
    res = C.compute(S.Config())
    # (the loop's dashed loading curve, and the operators' stack with its dashed sum, are
    # left whole)
    share = {"loop": 0.3, "time": 0.2, "operators": 1.01, "inverse": 0.75,
             "closed-loop": 0.75}
    for name, most in share.items():
        fig = F.build(name, res)
        cut = F.fit_to_pixels(fig, 800, 576)
        sent = sum(F.values(t["x"]).size for t in fig.data if "x" in t)
        kept = sum(F.values(t["x"]).size for t in cut.data if "x" in t)
        assert kept < most * sent, (name, sent, kept)
        for a, b in zip(fig.data, cut.data, strict=True):
            if (a.get("line") or {}).get("dash", "solid") != "solid":
                assert b is a, name
        stacked = {F.values(t["x"]).size for t in cut.data if t.get("stackgroup")}
        assert len(stacked) <= 1, name
        for a, b, (x, y), (kx, _) in zip(fig.data, cut.data, _drawn(fig), _drawn(cut),
                                          strict=True):
            if a is b:
                continue
            ok = np.isfinite(x) & np.isfinite(y)
            sx, sy = 800 / np.ptp(x[ok]), 576 / np.ptp(y[ok])
            # the kept samples are samples, unchanged (float32 as sent), in order
            keep = _found(F.values(a["x"]), F.values(a["y"]), F.values(b["x"]),
                          F.values(b["y"]))
            np.testing.assert_array_equal(x[keep], kx)
            assert _drawn_error(x * sx, y * sy, keep) <= F.PIXEL_TOL + 1e-6, name
