"""Candidate search: each effect fitted in full on top of the current structure.

Every effect's builder (in its module of :mod:`core.diagnosis.effects`, registered in
:data:`core.diagnosis.registry.EFFECTS`) searches the effect's few nonlinear parameters
(separable least squares: a grid and a bounded refinement, the linear weights re-solved
inside by the structure fit) and returns ``(fit, parameters, uncertainty)``. This module holds
what the builders share (the one-parameter and loop-shape searches, profile-curvature
sigmas) and :func:`build_candidate`, which dispatches on the registry.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..exceptions import ParameterError
from ..fitting.thresholds import reversal_indices
from ..recordings import Recording
from .bases import base_elements, elements_like
from .context import FitContext
from .registry import EFFECTS, dynamics_of
from .shapes import (
    apply_shape,
    shape_thresholds,
)
from .structure import Fit, Structure, dynamics_stages, pack_dynamics

__all__ = ["Candidate", "build_candidate", "excitation_hz", "nelder_mead", "one_time_constant",
           "placed_on", "scalar_search", "search_context", "shape_input_range",
           "sigma_from_curvature", "stage_pair", "walk_down", "with_shape_stage",
           "worth_refining"]

#: ``(fit, parameters, uncertainty)`` of one candidate effect.
Candidate = tuple[Fit, dict, dict]

#: Tolerance (in the log of the parameter) and iterations of :func:`scalar_search`'s bounded
#: refinement between the grid neighbours of its best point.
SCALAR_XATOL = 0.03
SCALAR_MAXITER = 9
#: Step (in the log of the parameter) of the profile-curvature difference of
#: :func:`scalar_search`.
CURVATURE_STEP = 0.1
#: Largest lag-1 autocorrelation of the residuals :func:`sigma_from_curvature` inflates a
#: sigma for (``(1 + rho) / (1 - rho)`` stays finite).
MAX_RESIDUAL_RHO = 0.999
#: Reversals :func:`excitation_hz` counts: larger than this share of the input range.
EXCITATION_REVERSAL_SHARE = 0.1
#: The time-constant grid of :func:`one_time_constant`: :data:`TAU_GRID_POINTS` geometric
#: points from :data:`TAU_GRID_MIN_DT` sample spacings to :data:`TAU_GRID_MAX_S` seconds or
#: a :data:`TAU_GRID_PER_DURATION`-th of the shortest recording, whichever is shorter.
TAU_GRID_MIN_DT = 1e-4
TAU_GRID_MAX_S = 0.05
TAU_GRID_PER_DURATION = 20
TAU_GRID_POINTS = 18
#: Stopping tolerances of :func:`nelder_mead` (parameters, in the optimiser's own units;
#: objective).
NM_XATOL = 1e-3
NM_FATOL = 1e-12


def walk_down(value, shape: tuple[int, ...], start: tuple[int, ...]) -> tuple[int, ...]:
    """A local minimum of ``value`` (a function of a grid index) over a grid of ``shape``:
    from ``start``, to the lowest of the neighbours (indices within one of the current in
    every axis) while it is lower. On a grid whose values have one local minimum that is
    their minimum (the argmin of the whole grid) with a fraction of the evaluations."""
    cur = tuple(int(i) for i in start)
    while True:
        nb = [n for n in np.ndindex(*(3,) * len(shape))
              if any(d != 1 for d in n)]
        cand = [tuple(c + d - 1 for c, d in zip(cur, n, strict=True)) for n in nb]
        cand = [c for c in cand if all(0 <= i < m for i, m in zip(c, shape, strict=True))]
        if not cand:
            return cur
        best = min(cand, key=value)
        if not value(best) < value(cur):
            return cur
        cur = best


def scalar_search(ctx: FitContext, make, grid: np.ndarray, cur: Fit,
                  near: float | None = None) -> tuple[float, Fit, dict]:
    """VarPro over one positive parameter: grid, then golden refinement in log space.

    With ``near`` (the estimate on all the training rows, when ``ctx`` is a cross-fitting
    fold: :attr:`FitContext.start`) the grid is not evaluated in full but walked downhill
    from its point nearest to ``near``, each point passed compared with its two neighbours.
    Where the fold's RSS over the grid has one local minimum that is its minimum, hence the
    same refinement and the same estimate as the full grid's, with 3-5 solves instead of
    the grid's 12-18 (a fold shares all but one block of rows with the full data, whose
    minimum is next to ``near``); a fold whose grid has a deeper minimum elsewhere, apart
    from a higher local one, would be refined at the local one.
    """
    import scipy.optimize as so

    vals: dict[int, float] = {}

    def at(j: int) -> float:
        if j not in vals:
            vals[j] = ctx.rss(make(float(grid[j])), cur)
        return vals[j]

    if near is None or not (np.isfinite(near) and near > 0):
        i = int(np.argmin([at(j) for j in range(grid.size)]))
    else:
        i = walk_down(lambda ij: at(ij[0]), (grid.size,),
                      (int(np.argmin(np.abs(np.log(grid) - np.log(near)))),))[0]
    lo = np.log(grid[max(i - 1, 0)])
    hi = np.log(grid[min(i + 1, grid.size - 1)])
    memo: dict[float, float] = {}

    def f(lx: float) -> float:
        if lx not in memo:
            memo[lx] = ctx.rss(make(float(np.exp(lx))), cur)
        return memo[lx]

    if hi > lo:
        r = so.minimize_scalar(f, bounds=(lo, hi), method="bounded",
                               options={"xatol": SCALAR_XATOL, "maxiter": SCALAR_MAXITER})
        best = float(np.exp(r.x)) if r.fun < at(i) else float(grid[i])
    else:
        best = float(grid[i])
    # profile curvature in log space -> 1-sigma (inflated for autocorrelation)
    curv = np.nan
    if ctx.uncertainty:
        lb = np.log(best)
        h = CURVATURE_STEP
        curv = (f(lb + h) - 2 * f(lb) + f(lb - h)) / h**2
    info = {"profile_curvature": curv}
    fit = ctx.fit(make(best), cur)
    return best, fit, info


def sigma_from_curvature(ctx: FitContext, fit: Fit, curv: float, value: float) -> float | None:
    if not np.isfinite(curv) or curv <= 0:
        return None
    e = np.concatenate([(r.y - p)[m] for r, p, m in zip(ctx.records, fit.pred, ctx.train,
                                                        strict=True)])
    n = e.size
    s2 = float(e @ e) / n
    rho = float(np.corrcoef(e[1:], e[:-1])[0, 1]) if n > 3 else 0.0
    rho = min(max(rho, 0.0), MAX_RESIDUAL_RHO)
    infl = (1 + rho) / (1 - rho)
    var_log = 2.0 * s2 / curv * infl
    return float(value * np.sqrt(var_log))


def excitation_hz(records: Sequence[Recording]) -> float:
    """Slowest fundamental over the recordings: half the number of input reversals per
    second (reversals larger than :data:`EXCITATION_REVERSAL_SHARE` of the input range)."""
    rates = []
    for r in records:
        dur = float(r.t[-1] - r.t[0])
        span = float(np.ptp(r.u))
        if dur > 0 and span > 0:
            rates.append(0.5 * (reversal_indices(r.u, EXCITATION_REVERSAL_SHARE * span).size
                                - 1) / dur)
    return min(rates) if rates else 0.0


def one_time_constant(ctx: FitContext, cur: Fit, kind: str, key: str) -> Candidate | None:
    """Delay or lag: a 1-D search over its time constant (s), profile-curvature sigma."""
    s = cur.structure
    if s.dynamics:
        return None
    dt = min(r.dt for r in ctx.records)
    dur = min(r.t[-1] - r.t[0] for r in ctx.records)
    grid = np.geomspace(TAU_GRID_MIN_DT * dt, min(TAU_GRID_MAX_S, dur / TAU_GRID_PER_DURATION),
                        TAU_GRID_POINTS)
    st = ctx.start
    near = (float(st.dynamics[1]) if st is not None and len(st.dynamics) == 2
            and st.dynamics[0] == kind else None)
    best, fit, info = scalar_search(ctx, lambda v: s.with_(dynamics=(kind, v)), grid, cur,
                                    near=near)
    return fit, {key: best}, {key: sigma_from_curvature(ctx, fit, info["profile_curvature"],
                                                         best)}


def shape_input_range(ctx: FitContext, shape: tuple) -> tuple[float, float]:
    """Range of the current play-bank input (the input through ``shape``) on the training
    rows."""
    vs = [apply_shape(shape, r.u)[m] for r, m in zip(ctx.records, ctx.train, strict=True)
          if m.any()]
    return min(float(v.min()) for v in vs), max(float(v.max()) for v in vs)


#: Recordings longer than this (samples, all pooled) are searched on a decimated copy.
SEARCH_SAMPLES = 12_000


def search_context(ctx: FitContext, cur: Fit) -> tuple[FitContext, Fit]:
    """Where a loop-shape search evaluates its trial maps: ``ctx`` itself, or an exact
    decimation of it for long recordings.

    Play operators are rate independent and the loop-shape maps strictly increasing, so
    the play outputs at the samples kept are exact when every input reversal is kept
    (between two kept samples the input is monotone). Every ``k``-th sample plus every
    reversal, the first and the last are kept, with their train/test rows; the search
    ranks its trial maps there, and the candidate is fitted on ``ctx`` itself. Structures
    whose other parts depend on the time axis (dynamics, creep, rate) are searched on
    ``ctx`` (a decimated time axis would change them).
    """
    s = cur.structure
    n = sum(r.n_samples for r in ctx.records)
    if n <= SEARCH_SAMPLES or s.dynamics or s.needs_sample_spacing or s.beta_s is not None:
        return ctx, cur
    step = int(np.ceil(n / SEARCH_SAMPLES))
    recs, tr, te = [], [], []
    for r, a, b in zip(ctx.records, ctx.train, ctx.test, strict=True):
        keep = np.zeros(r.n_samples, dtype=bool)
        keep[::step] = True
        keep[[0, -1]] = True
        keep[reversal_indices(r.u, 0.0)] = True
        recs.append(Recording(r.t[keep], r.u[keep], r.y[keep], name=r.name,
                              has_time=r.has_time))
        tr.append(a[keep])
        te.append(b[keep])
    sub = FitContext(recs, tr, te)
    return sub, sub.fit(s)


def with_shape_stage(ctx: FitContext, s: Structure, stage: tuple) -> Structure:
    """``s`` with ``stage`` added to its loop shape and the play grid re-placed (same number
    of operators) on the mapped input. A dead zone acts on the input itself, first; a
    saturation last (a thresholded, saturating drive: ``w = tanh(a1 γ(u) + a2)``)."""
    shape = (stage, *s.shape) if stage[0] == "deadzone" else (*s.shape, stage)
    return placed_on(s.with_(shape=shape), ctx.records, ctx.train)


def placed_on(s: Structure, records, train) -> Structure:
    """``s`` with its play grid (same number of operators), or the elements of its Bouc-Wen
    base, re-placed on the input mapped through its loop shape."""
    if s.bouc_wen:
        span = max(float(np.ptp(apply_shape(s.shape, r.u[m])))
                   for r, m in zip(records, train, strict=True) if m.any())
        el = elements_like(s.bouc_wen, span)
        return s.with_(bouc_wen=el, thresholds=base_elements(el))
    r = shape_thresholds(s.shape, records, train, len(s.thresholds))
    return s.with_(thresholds=tuple(float(x) for x in r))


def nelder_mead(f, x0: np.ndarray, step: float, maxfev: int) -> tuple[np.ndarray, float]:
    import scipy.optimize as so

    x0 = np.asarray(x0, dtype=float)
    simplex = np.vstack([x0] + [x0 + step * np.eye(x0.size)[i] for i in range(x0.size)])
    r = so.minimize(f, x0, method="Nelder-Mead",
                    options={"maxfev": maxfev, "initial_simplex": simplex, "xatol": NM_XATOL,
                             "fatol": NM_FATOL})
    return np.asarray(r.x), float(r.fun)


#: Factors on each parameter of the single-stage fits from which a pair of output stages
#: in series starts (:func:`stage_pair`): a single stage standing in for two fits a larger
#: time constant or damping than either has in the pair.
PAIR_START_FACTORS = (0.1, 0.4, 1.0)
#: Structure evaluations of the Nelder-Mead refinement of a pair.
PAIR_MAXFEV = 40
#: Initial simplex step (in the log of each parameter) of the Nelder-Mead refinement of a
#: pair, and of a single output stage polished with the pair's budget.
PAIR_STEP = 0.2


def stage_pair(ctx: FitContext, base: Fit, first: tuple[str, dict], second: tuple[str, dict]
               ) -> Candidate | None:
    """Two output dynamics stages in series (``first`` then ``second``, each ``(name,
    parameters)`` of its single-stage fit on ``base``) fitted jointly on top of ``base``
    (which holds no dynamics): a grid of :data:`PAIR_START_FACTORS` on every parameter of
    the single fits, then Nelder-Mead in log space on the training RSS.

    Returns ``(fit, parameters, {})`` with the parameters keyed ``"name.parameter"``, or
    ``None`` when ``base`` already holds dynamics.
    """
    if base.structure.dynamics:
        return None
    dt = min(r.dt for r in ctx.records)
    names = (first[0], second[0])
    x_single = np.log(np.asarray([float(p[k]) for n, p in (first, second)
                                  for k in dynamics_of(n).params]))

    def obj(lx: np.ndarray) -> float:
        dyn = pack_dynamics(names, np.exp(lx), dt)
        return np.inf if dyn is None else ctx.rss(base.structure.with_(dynamics=dyn), base)

    grid = np.array(np.meshgrid(*[np.log(PAIR_START_FACTORS)] * x_single.size)
                    ).reshape(x_single.size, -1).T
    vals = [obj(x_single + g) for g in grid]
    x0 = x_single + grid[int(np.argmin(vals))]
    x, fx = nelder_mead(obj, x0, PAIR_STEP, PAIR_MAXFEV)
    if not fx <= min(vals):
        x = x0
    dyn = pack_dynamics(names, np.exp(x), dt)
    if dyn is None:
        return None
    fit = ctx.fit(base.structure.with_(dynamics=dyn), base)
    params = {f"{n}.{k}": v for n, vs in dynamics_stages(dyn)
              for k, v in zip(dynamics_of(n).params, vs, strict=True)}
    return fit, params, {}


def worth_refining(ctx: FitContext, rss_grid: float, ref: Structure, cur: Fit) -> bool:
    """Whether the best grid point of a shape search already lowers the training RSS of
    ``ref`` (the search's own fast path) by the smallest effect size of the acceptance
    rules: otherwise the candidate cannot pass, and it is reported at the grid point
    without a refinement."""
    from .acceptance import RULE

    return rss_grid < (1.0 - RULE.min_gain) * ctx.rss(ref, cur)


def _its_rows_explained(ctx: FitContext, name: str, cur: Fit) -> bool:
    """Whether ``cur`` already holds an effect of the same family judged on the same rows of
    its signature as ``name`` (a drift and a creep from cycle to cycle of one repeated input:
    the one slow change those rows show was named when the first was accepted, and the two
    compared there; :func:`~core.diagnosis.finding.lookalikes_of`)."""
    e = EFFECTS[name]
    rows = e.signature(ctx) if e.signature is not None else None
    if rows is None:
        return False
    for other, _ in cur.structure.terms:
        o = EFFECTS[other]
        if other == name or o.family != e.family or o.signature is None:
            continue
        o_rows = o.signature(ctx)
        if o_rows is not None and o_rows.words == rows.words:
            return True
    return False


def build_candidate(ctx: FitContext, name: str, cur: Fit) -> Candidate | None:
    """Fit effect ``name`` on top of ``cur``: ``(fit, parameters, uncertainty)``, or ``None``
    when the effect is already in the structure, does not apply, or an effect of its family
    already explains the rows its signature lives in (:func:`_its_rows_explained`)."""
    try:
        e = EFFECTS[name]
    except KeyError:
        raise ParameterError(f"unknown effect {name!r}; known: {', '.join(EFFECTS)}") from None
    if _its_rows_explained(ctx, name, cur):
        return None
    if cur.structure.bouc_wen and e.family == "static" and e.structure_field is None:
        # a Bouc-Wen base was chosen over the PI with static maps' loops in reach (the
        # benchmark's static-map plants keep the PI: bases.BW_MIN_GAIN); a loop-shape search
        # would integrate its elements anew for every trial map
        return None
    return e.build(ctx, cur)
