"""Saturating loops: the plays driven through a tanh envelope (the tanh GPI)."""

from __future__ import annotations

import numpy as np

from ...gpi import TanhGPI
from ..candidates import (
    Candidate,
    nelder_mead,
    search_context,
    shape_input_range,
    with_shape_stage,
    worth_refining,
)
from ..context import FitContext
from ..registry import DiagnosableEffect, register
from ..shapes import describe_shape, tanh_stage
from ..structure import Fit, Structure


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Saturation: the plays driven by ``w = tanh(a1 v + a2)`` (single-branch tanh envelope
    of the tanh GPI; ``v`` = the input, or the output of a dead zone already found).

    VarPro over the envelope's scale and centre in normalised input coordinates
    ``a1 v + a2 = e^phi0 (v - v_c) / v_s + phi1`` (the parametrisation of
    :class:`core.fitting.TanhGPIRegressor`): a 5 x 5 grid, then Nelder-Mead.
    """
    s = cur.structure
    if any(st[0] == "tanh" for st in s.shape) or s.stop:
        return None  # (a stop base's plateau and backlash gap are its saturation and dead band)
    sctx, scur = search_context(ctx, cur)
    got = tanh_search(sctx, s, scur)
    if got is None:
        return None
    st, lo, hi = got
    st = with_shape_stage(ctx, s, st.shape[-1])  # the play grid placed on all training rows
    fit = ctx.fit(st, cur)
    stage = st.shape[-1]
    return fit, {"a1": stage[1], "a2": stage[2], **describe_shape(stage, lo, hi)}, {}


#: Initial simplex step (log gain, offset) and evaluations of the Nelder-Mead polish of the
#: tanh stage's best grid point (:func:`tanh_search`).
TANH_STEP = 0.2
TANH_MAXFEV = 24


def tanh_search(ctx: FitContext, s: Structure, cur: Fit, refine: bool | None = None
                 ) -> tuple[Structure, float, float] | None:
    """``s`` with the best tanh stage appended (see :func:`_build_saturation`), and the
    range of the tanh's input on the training rows. ``refine``: polish the grid point
    (``None``: only when it is worth it, :func:`worth_refining`)."""
    lo, hi = shape_input_range(ctx, s.shape)
    if not hi > lo:
        return None
    vc, vs = 0.5 * (lo + hi), 0.5 * (hi - lo)

    def make(phi) -> Structure:
        a1 = float(np.exp(phi[0])) / vs
        return with_shape_stage(ctx, s, tanh_stage(a1, float(phi[1]) - a1 * vc))

    memo: dict[tuple[float, float], float] = {}

    def f(phi) -> float:
        key = (round(float(phi[0]), 6), round(float(phi[1]), 6))
        if not (np.log(0.05) <= key[0] <= np.log(8.0) and -2.5 <= key[1] <= 2.5):
            return np.inf
        if key not in memo:
            memo[key] = ctx.rss(make(key), cur)
        return memo[key]

    grid = [(p0, p1) for p0 in np.log([0.3, 0.7, 1.2, 2.0, 3.5])
            for p1 in (-1.0, -0.5, 0.0, 0.5, 1.0)]
    start = min(grid, key=f)
    phi = np.asarray(start)
    if refine or (refine is None and worth_refining(ctx, f(start), s, cur)):
        x, _ = nelder_mead(f, phi, TANH_STEP, TANH_MAXFEV)
        phi = x if f(x) <= f(start) else phi
    return make(phi), lo, hi



def one_branch(ctx: FitContext) -> str | None:
    """Loop shapes need a loop: at least one travel up and one down, each over half of the
    input range, inside the training rows (on a single branch any monotone curve is a PI's
    first branch, so saturation or a dead band cannot be told from the PI itself)."""
    from ...fitting.thresholds import reversal_indices

    span = max((float(np.ptp(r.u[m])) for r, m in zip(ctx.records, ctx.train, strict=True)
                if m.any()), default=0.0)
    n = 0
    for r, m in zip(ctx.records, ctx.train, strict=True):
        rev = np.unique(np.r_[0, reversal_indices(r.u, 0.1 * span), r.n_samples - 1])
        for a, b in zip(rev[:-1], rev[1:], strict=True):
            if abs(r.u[b] - r.u[a]) >= 0.5 * span and m[a : b + 1].any():
                n += 1
    if n >= 2:
        return None
    return ("the training rows hold no loop (fewer than two travels over half of the input "
            "range, one up and one down): on a single branch any monotone curve is a PI "
            "branch, so the loop shape cannot be told from the PI itself")


register(DiagnosableEffect(
    "saturation",
    family="static",
    explanation=(
        'The loop saturates: towards the input extremes both branches flatten, at every '
        'amplitude (magnetic saturation, a stroke limit, a saturating drive). A PI is '
        'built from straight plays and obeys the Masing rules, so it cannot saturate '
        'loops of several amplitudes at once; the tanh-envelope GPI drives the plays '
        'through a saturating input map.'
    ),
    parameter_words=(
        ("a1", "steepness of the envelope", "1/input"),
        ("a2", "shift of the envelope (0: centred on zero input)", ""),
        ("center", "centre of the envelope", "input"),
        ("half_slope_below", "slope halved below", "input"),
        ("half_slope_above", "slope halved above", "input"),
        ("slope_at_input_min", "slope at the lowest input (1: the centre's)", ""),
        ("slope_at_input_max", "slope at the highest input (1: the centre's)", ""),
    ),
    equation='y = p0 w + sum_i p_i Play[r_i](w),  w = tanh(a1 u + a2)  (gpi-tanh)',
    experiment=(
        'loops (or reversals) of several amplitudes, or a travel covering the input range '
        'back and forth'
    ),
    build=_build,
    model_type=TanhGPI,
    structure_field=None,
    untestable=one_branch,
    deciding=(
        ("dead-zone", "loops of a larger amplitude (a saturation keeps "
         "flattening towards the extremes, a dead band has a fixed width after which the slope "
         "recovers)"),
        ("asymmetry", "symmetric loops of several amplitudes (saturation "
         "flattens both ends of every loop alike, an asymmetric map bends one side more)"),
    ),
))
