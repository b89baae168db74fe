"""A threshold or dead band: the plays driven through a piecewise-linear map (the dead-zone GPI)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ...deadzone import DeadZoneMap
from ...gpi import DeadZoneGPI
from ..candidates import (
    Candidate,
    nelder_mead,
    placed_on,
    search_context,
    shape_input_range,
    with_shape_stage,
    worth_refining,
)
from ..context import FitContext
from ..registry import DiagnosableEffect, register
from ..shapes import DEAD_BAND_SLOPE, dead_zone_stage, describe_shape
from ..structure import Fit
from .saturation import one_branch, tanh_search


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Threshold / dead band: the plays driven by ``w = γ(u)``, a dead-zone superposition
    that is flat-ish (slope in :data:`DEAD_BAND_SLOPES` of the rest) on one stretch of the
    input: below a threshold, above one (one-sided), or between two (a central dead band).

    A map whose two ends both flatten is a saturation, not a dead band: that is the
    ``saturation`` candidate's, so the two name different physics (look-alikes only where a
    single end flattens). VarPro over the band's edges and log-slope: a grid per kind, then
    Nelder-Mead on the best kind.
    """
    if any(st[0] == "deadzone" for st in cur.structure.shape) or cur.structure.stop:
        return None  # (a stop base's plateau and backlash gap are its saturation and dead band)
    # a saturation found earlier may have bent its tail to mimic the dead band: search the
    # band without it, then the saturation again on top of the band
    tanh_before = any(st[0] == "tanh" for st in cur.structure.shape)
    s = cur.structure.with_(shape=tuple(st for st in cur.structure.shape if st[0] != "tanh"))
    lo, hi = shape_input_range(ctx, ())  # the dead zone acts on the input itself
    sctx, cur_s = search_context(ctx, cur)
    span = hi - lo
    if not span > 0:
        return None
    ls_lo, ls_hi = np.log(DEAD_BAND_SLOPES)
    memo: dict[tuple, float] = {}

    def f(kind: str, x) -> float:
        key: tuple[Any, ...] = (kind, *(round(float(v), 6) for v in x))
        if not (all(0.0 < v < 1.0 for v in key[1:-1]) and ls_lo <= key[-1] <= ls_hi):
            return np.inf
        if key not in memo:
            g = _dead_band_map(kind, key[1:-1], key[-1], lo, span)
            memo[key] = sctx.rss(with_shape_stage(sctx, s, dead_zone_stage(g)), cur_s)
        return memo[key]

    ls = np.log([0.03, 0.2])
    grid = ([("low", (q, v)) for q in (0.15, 0.3, 0.45) for v in ls]
            + [("high", (q, v)) for q in (0.55, 0.7, 0.85) for v in ls]
            + [("middle", (a, b, v)) for a, b in ((0.35, 0.65), (0.2, 0.5), (0.5, 0.8))
               for v in ls])
    kind, x0 = min(grid, key=lambda c: f(*c))
    x = np.asarray(x0)
    if worth_refining(sctx, f(kind, x0), s, cur_s):
        x1, _ = nelder_mead(lambda v: f(kind, v), x, DEAD_BAND_STEP,
                            DEAD_BAND_MAXFEV_PER_PARAM * len(x0))
        x = x1 if f(kind, x1) <= f(kind, x0) else x
    g = _dead_band_map(kind, x[:-1], x[-1], lo, span)
    st = with_shape_stage(sctx, s, dead_zone_stage(g))
    params: dict = {}
    if tanh_before:
        got = tanh_search(sctx, st, cur_s, refine=True)
        if got is None:
            return None
        st = got[0]
        params = {"saturation_refitted": {"a1": st.shape[-1][1], "a2": st.shape[-1][2]}}
    # the play grid placed on all training rows
    st = placed_on(st, ctx.records, ctx.train)
    fit = ctx.fit(st, cur)
    return fit, {"side": kind, "thresholds": g.thresholds.tolist(),
                 "weights": g.weights.tolist(), **describe_shape(st.shape[0], lo, hi),
                 **params}, {}



def _piecewise_map(breaks: Sequence[float] | np.ndarray, slopes: Sequence[float]
                   ) -> DeadZoneMap:
    """Continuous piecewise-linear map with ``slopes[j]`` on the j-th segment between the
    sorted ``breaks`` (one more slope than breaks), as a dead-zone superposition (``w(0) = 0``,
    the slope of the segment holding 0 is its linear weight)."""
    b = np.asarray(breaks, dtype=float)
    sl = np.asarray(slopes, dtype=float)
    j0 = int(np.searchsorted(b, 0.0, side="right"))  # segment holding 0
    rho, eta = [0.0], [float(sl[j0])]
    for j, bj in enumerate(b):
        if bj > 0:
            rho.append(float(bj))
            eta.append(float(sl[j + 1] - sl[j]))
        elif bj < 0:
            rho.append(float(bj))
            eta.append(float(sl[j] - sl[j + 1]))
    order = np.argsort(rho)
    return DeadZoneMap(np.asarray(rho)[order], np.asarray(eta)[order])



#: Slope range of a dead band relative to the rest of the input map (a flat dead band is
#: slope 0; the lower bound keeps the map strictly increasing, so the model inverts).
DEAD_BAND_SLOPES = (0.01, DEAD_BAND_SLOPE)
#: Initial simplex step and evaluations per parameter of the Nelder-Mead polish of the best
#: dead band's kind (:func:`_build`).
DEAD_BAND_STEP = 0.08
DEAD_BAND_MAXFEV_PER_PARAM = 10



def _dead_band_map(kind: str, q: Sequence[float] | np.ndarray, log_s: float, lo: float, span: float
                   ) -> DeadZoneMap:
    """Input map with one dead band of slope ``e^log_s`` (the other segments slope 1):
    ``kind`` ``"low"`` (below ``lo + q0 span``), ``"high"`` (above it) or ``"middle"``
    (between ``lo + q0 span`` and ``lo + q1 span``)."""
    sd = float(np.exp(log_s))
    qs = np.clip(np.asarray(q, dtype=float), 0.02, 0.98)
    if kind == "middle":
        qs = np.sort(qs)
        qs[1] = max(qs[1], qs[0] + 0.02)
        d, slopes = lo + span * qs, [1.0, sd, 1.0]
    else:
        d, slopes = lo + span * qs[:1], ([sd, 1.0] if kind == "low" else [1.0, sd])
    d = np.where(np.abs(d) < 1e-9 * span, d + 1e-6 * span, d)  # 0 anchors the map itself
    return _piecewise_map(d, slopes)


register(DiagnosableEffect(
    "dead-zone",
    family="static",
    explanation=(
        'A threshold / dead band: over part of the input range (below a threshold, on one '
        'side, or around the centre) the output hardly responds, then follows the input '
        'again (a thresholded actuator, backlash-like play at the input, a one-sided '
        'drive). The dead-zone GPI drives the plays through a piecewise-linear input map '
        'whose flat segment is the dead band.'
    ),
    parameter_words=(
        ("thresholds", "thresholds of the map", "input"),
        ("weights", "slopes of the map's segments", ""),
        ("breakpoints", "breakpoints", "input"),
        ("relative_slopes", "slopes relative to the steepest", ""),
    ),
    equation=(
        'y = p0 w + sum_i p_i Play[r_i](w),  w = gamma(u) (dead-zone '
        'superposition, gpi-deadzone)'
    ),
    experiment=(
        'loops (or reversals) of several amplitudes, or a travel covering the input range '
        'back and forth'
    ),
    build=_build,
    model_type=DeadZoneGPI,
    structure_field=None,
    untestable=one_branch,
    deciding=(
        ("asymmetry", "loops of several amplitudes and offsets (a dead "
         "band stays at the same input level, an output map follows the output level)"),
    ),
))
