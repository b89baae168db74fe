"""Candidate search: each effect fitted in full on top of the current structure.

Every builder searches the effect's few nonlinear parameters (separable least squares: a grid
and a bounded refinement, the linear weights re-solved inside by the structure fit) and
returns ``(fit, parameters, uncertainty)``; :data:`BUILDERS` maps effect names to builders.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..deadzone import DeadZoneMap
from ..exceptions import ParameterError
from ..fitting.thresholds import reversal_indices, wipeout_index
from ..recordings import Recording
from .context import FitContext
from .shapes import (
    DEAD_BAND_SLOPE,
    apply_shape,
    dead_zone_stage,
    describe_shape,
    shape_thresholds,
    tanh_stage,
)
from .structure import Fit, Structure

__all__ = ["BUILDERS", "Candidate", "build_candidate", "excitation_hz", "search_context"]

#: ``(fit, parameters, uncertainty)`` of one candidate effect.
Candidate = tuple[Fit, dict, dict]


def _scalar_search(ctx: FitContext, make, grid: np.ndarray, cur: Fit) -> tuple[float, Fit, dict]:
    """VarPro over one positive parameter: grid, then golden refinement in log space."""
    import scipy.optimize as so

    rss = []
    for g in grid:
        rss.append(ctx.rss(make(float(g)), cur))
    i = int(np.argmin(rss))
    lo = np.log(grid[max(i - 1, 0)])
    hi = np.log(grid[min(i + 1, grid.size - 1)])
    memo: dict[float, float] = {}

    def f(lx: float) -> float:
        if lx not in memo:
            memo[lx] = ctx.rss(make(float(np.exp(lx))), cur)
        return memo[lx]

    if hi > lo:
        r = so.minimize_scalar(f, bounds=(lo, hi), method="bounded",
                               options={"xatol": 0.03, "maxiter": 9})
        best = float(np.exp(r.x)) if r.fun < rss[i] else float(grid[i])
    else:
        best = float(grid[i])
    # profile curvature in log space -> 1-sigma (inflated for autocorrelation)
    curv = np.nan
    if ctx.uncertainty:
        lb = np.log(best)
        h = 0.1
        curv = (f(lb + h) - 2 * f(lb) + f(lb - h)) / h**2
    info = {"profile_curvature": curv}
    fit = ctx.fit(make(best), cur)
    return best, fit, info


def _sigma_from_curvature(ctx: FitContext, fit: Fit, curv: float, value: float) -> float | None:
    if not np.isfinite(curv) or curv <= 0:
        return None
    e = np.concatenate([(r.y - p)[m] for r, p, m in zip(ctx.records, fit.pred, ctx.train,
                                                        strict=True)])
    n = e.size
    s2 = float(e @ e) / n
    rho = float(np.corrcoef(e[1:], e[:-1])[0, 1]) if n > 3 else 0.0
    rho = min(max(rho, 0.0), 0.999)
    infl = (1 + rho) / (1 - rho)
    var_log = 2.0 * s2 / curv * infl
    return float(value * np.sqrt(var_log))


# ----------------------------------------------------------------------------- candidates
def excitation_hz(records: Sequence[Recording]) -> float:
    """Slowest fundamental over the recordings: half the number of input reversals per
    second (reversals larger than 10 % of the input range)."""
    rates = []
    for r in records:
        dur = float(r.t[-1] - r.t[0])
        span = float(np.ptp(r.u))
        if dur > 0 and span > 0:
            rates.append(0.5 * (reversal_indices(r.u, 0.1 * span).size - 1) / dur)
    return min(rates) if rates else 0.0


def initial_memory_search(ctx: FitContext, cur: Fit) -> tuple[Fit, dict, dict] | None:
    s = cur.structure
    hist = list(s.history)
    best_fit = cur
    # the virtual extrema found are kept inside the input range of the recordings: an
    # excursion beyond every recorded input cannot be checked against anything the actuator
    # was seen to do (on a Bouc-Wen plant a history below the whole range imitated its
    # virgin curve: initial memory claimed on a plant that had none)
    u_lo = min(float(r.u.min()) for r in ctx.records)
    u_hi = max(float(r.u.max()) for r in ctx.records)
    for k, rec in enumerate(ctx.records):
        tw = wipeout_index(rec.u)
        if not (ctx.train[k][:tw].any() or (ctx.test[k][:tw].any() and not ctx.strict)):
            continue
        lo, hi = float(rec.u.min()), float(rec.u.max())
        span = hi - lo
        levels = lo + span * np.linspace(-0.25, 1.25, 7)
        cands: list[tuple[float, ...]] = [(float(v),) for v in levels]
        for a in (lo - 0.25 * span, lo, hi, hi + 0.25 * span):
            for b in levels[1:-1]:
                if abs(b - a) > 0.2 * span:
                    cands.append((float(a), float(b)))
        best = (ctx.rss(s.with_(history=tuple(hist)), best_fit), tuple(hist[k]))
        for c in cands:
            h2 = list(hist)
            h2[k] = c
            v = ctx.rss(s.with_(history=tuple(h2)), best_fit)
            if v < best[0]:
                best = (v, c)
        if best[1]:
            import scipy.optimize as so

            def obj(x, k=k):
                h2 = list(hist)
                h2[k] = tuple(float(v) for v in x)
                return ctx.rss(s.with_(history=tuple(h2)), best_fit)

            x0 = np.asarray(best[1], dtype=float)
            rr = so.minimize(obj, x0, method="Nelder-Mead",
                             options={"maxfev": 8 * x0.size, "initial_simplex": np.vstack(
                                 [x0] + [x0 + 0.08 * span * np.eye(x0.size)[i]
                                         for i in range(x0.size)])})
            best = (rr.fun, tuple(float(v) for v in rr.x)) if rr.fun < best[0] else best
        hist[k] = _inside(best[1], u_lo, u_hi)
    if not any(hist):
        return None
    fit = ctx.fit(s.with_(history=tuple(hist)), cur)
    return fit, {"history": [list(h) for h in hist]}, {}


def _inside(history: tuple[float, ...], lo: float, hi: float) -> tuple[float, ...]:
    """``history`` clipped to ``[lo, hi]``, without the repeated values clipping makes."""
    out: list[float] = []
    for v in history:
        c = float(min(max(v, lo), hi))
        if not out or c != out[-1]:
            out.append(c)
    return tuple(out)


def _one_time_constant(ctx: FitContext, cur: Fit, kind: str, key: str) -> Candidate | None:
    """Delay or lag: a 1-D search over its time constant (s), profile-curvature sigma."""
    s = cur.structure
    if s.dynamics:
        return None
    dt = min(r.dt for r in ctx.records)
    dur = min(r.t[-1] - r.t[0] for r in ctx.records)
    grid = np.geomspace(1e-4 * dt, min(0.05, dur / 20), 18)
    best, fit, info = _scalar_search(ctx, lambda v: s.with_(dynamics=(kind, v)), grid, cur)
    return fit, {key: best}, {key: _sigma_from_curvature(ctx, fit, info["profile_curvature"],
                                                         best)}


def _build_delay(ctx: FitContext, cur: Fit) -> Candidate | None:
    """A pure transport delay ``tau_d``."""
    return _one_time_constant(ctx, cur, "delay", "delay_s")


def _build_lag(ctx: FitContext, cur: Fit) -> Candidate | None:
    """A first-order output lag ``tau``."""
    return _one_time_constant(ctx, cur, "lag", "tau_s")


def _build_resonance(ctx: FitContext, cur: Fit) -> Candidate | None:
    """A second-order mode after the PI: grid over (f_n, zeta), then Nelder-Mead."""
    s = cur.structure
    dt = min(r.dt for r in ctx.records)
    dur = min(r.t[-1] - r.t[0] for r in ctx.records)
    if s.dynamics:
        return None
    import scipy.optimize as so

    fmax = 0.35 / dt
    # a mode at or near the excitation frequency is a phase/gain fudge of the loop
    # itself, not a resonance (it fits the training rows and wrecks the held-out ones)
    fmin = max(5.0 / dur, 2.0, 3.0 * excitation_hz(ctx.records))
    fs = np.geomspace(fmin, fmax, 7)
    zs = np.array([0.05, 0.2, 0.7])
    best = (np.inf, fs[0], zs[0])
    for f_ in fs:
        for z_ in zs:
            v = ctx.rss(s.with_(dynamics=("resonance", float(f_), float(z_))), cur)
            if v < best[0]:
                best = (v, f_, z_)

    def obj(p):
        f_, z_ = float(np.exp(p[0])), float(np.exp(p[1]))
        if not (fmin * 0.5 <= f_ <= 0.45 / dt and 0.005 <= z_ <= 2.0):
            return np.inf
        return ctx.rss(s.with_(dynamics=("resonance", f_, z_)), cur)

    r = so.minimize(obj, [np.log(best[1]), np.log(best[2])], method="Nelder-Mead",
                    options={"maxfev": 16, "xatol": 0.03, "fatol": 1e-9})
    f_, z_ = (float(np.exp(r.x[0])), float(np.exp(r.x[1]))) if r.fun < best[0] else (
        float(best[1]), float(best[2]))
    fit = ctx.fit(s.with_(dynamics=("resonance", f_, z_)), cur)
    # 1-D curvatures for rough sigmas
    unc: dict = {}
    for j, key, val in ((0, "freq_hz", f_), (1, "damping", z_)) if ctx.uncertainty else ():
        h = 0.05
        p = np.array([np.log(f_), np.log(z_)])
        pp, pm = p.copy(), p.copy()
        pp[j] += h
        pm[j] -= h
        c = (obj(pp) - 2 * obj(p) + obj(pm)) / h**2
        unc[key] = _sigma_from_curvature(ctx, fit, c, val)
    return fit, {"freq_hz": f_, "damping": z_}, unc


def _build_rate(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Rate-dependent PI thresholds r_i + beta |du/dt|: a 1-D search over beta."""
    s = cur.structure
    if s.beta_s is not None or s.levels:
        return None  # rate-dependent plays on a Preisach base are not modelled
    span = max(float(np.ptp(r.u)) for r in ctx.records)
    rmax = max(float(np.max(np.abs(c.rate))) for c in ctx.coords) or 1.0
    grid = np.geomspace(1e-5, 0.3, 12) * span / rmax
    best, fit, info = _scalar_search(ctx, lambda v: s.with_(beta_s=v), grid, cur)
    return fit, {"beta_s": best}, {"beta_s": _sigma_from_curvature(
        ctx, fit, info["profile_curvature"], best)}


def _build_creep(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Creep lag bank, one time constant per decade from 10 dt (>= 10 ms) to the record length."""
    s = cur.structure
    dt = min(r.dt for r in ctx.records)
    if s.creep_taus:
        return None
    lo = max(10 * dt, 0.01)
    hi = max(r.t[-1] - r.t[0] for r in ctx.records)
    taus = tuple(float(x) for x in 10.0 ** np.arange(np.ceil(np.log10(lo)),
                                                     np.log10(hi) + 1e-9))
    if len(taus) < 1:
        return None
    fit = ctx.fit(s.with_(creep_taus=taus), cur)
    return fit, {"taus_s": list(taus), "weights": fit.creep_weights.tolist(),
                 "gamma_per_decade": float(fit.creep_weights.sum() / len(taus))}, {}


def _build_drift(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Legendre drift of degree 2 in absolute time per recording."""
    s = cur.structure
    if s.drift_degree:
        return None
    fit = ctx.fit(s.with_(drift_degree=2), cur)
    return fit, {"coefficients": [c.tolist() for c in fit.drift_coef],
                 "peak_to_peak": [float(np.ptp(m.stages[-1].drift(r.t - r.t[0])))
                                  for m, r in zip(fit.models, ctx.records, strict=True)]}, {}


def _build_asymmetry(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Quadratic + cubic output map."""
    s = cur.structure
    if s.asymmetry:
        return None
    fit = ctx.fit(s.with_(asymmetry=True), cur)
    return fit, {"a2": float(fit.asym_coef[0]), "a3": float(fit.asym_coef[1]),
                 "center": fit.asym_center, "scale": fit.asym_scale}, {}


def _build_offset(ctx: FitContext, cur: Fit) -> Candidate | None:
    """One offset per recording (needs >= 2 recordings)."""
    s = cur.structure
    if s.offsets or len(ctx.records) < 2:
        return None
    fit = ctx.fit(s.with_(offsets=True), cur)
    return fit, {"offsets": fit.bias.tolist()}, {}


def _build_initial_memory(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Virtual prior input extrema per recording (grid, then Nelder-Mead)."""
    s = cur.structure
    if any(s.history):
        return None
    return initial_memory_search(ctx, cur)


# ----------------------------------------------------------------------------- loop shapes
def _shape_input_range(ctx: FitContext, shape: tuple) -> tuple[float, float]:
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
    if n <= SEARCH_SAMPLES or s.dynamics or s.creep_taus or s.beta_s is not None:
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


def _with_stage(ctx: FitContext, s: Structure, stage: tuple) -> Structure:
    """``s`` with ``stage`` added to its loop shape and the play grid re-placed (same number
    of operators) on the mapped input. A dead zone acts on the input itself, first; a
    saturation last (a thresholded, saturating drive: ``w = tanh(a1 γ(u) + a2)``)."""
    shape = (stage, *s.shape) if stage[0] == "deadzone" else (*s.shape, stage)
    r = shape_thresholds(shape, ctx.records, ctx.train, len(s.thresholds))
    return s.with_(shape=shape, thresholds=tuple(float(x) for x in r))


def _nelder_mead(f, x0: np.ndarray, step: float, maxfev: int) -> tuple[np.ndarray, float]:
    import scipy.optimize as so

    x0 = np.asarray(x0, dtype=float)
    simplex = np.vstack([x0] + [x0 + step * np.eye(x0.size)[i] for i in range(x0.size)])
    r = so.minimize(f, x0, method="Nelder-Mead",
                    options={"maxfev": maxfev, "initial_simplex": simplex, "xatol": 1e-3,
                             "fatol": 1e-12})
    return np.asarray(r.x), float(r.fun)


def _build_saturation(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Saturation: the plays driven by ``w = tanh(a1 v + a2)`` (single-branch tanh envelope
    of the tanh GPI; ``v`` = the input, or the output of a dead zone already found).

    VarPro over the envelope's scale and centre in normalised input coordinates
    ``a1 v + a2 = e^phi0 (v - v_c) / v_s + phi1`` (the parametrisation of
    :class:`core.fitting.TanhGPIRegressor`): a 5 x 5 grid, then Nelder-Mead.
    """
    s = cur.structure
    if any(st[0] == "tanh" for st in s.shape):
        return None
    sctx, scur = search_context(ctx, cur)
    got = _tanh_search(sctx, s, scur)
    if got is None:
        return None
    st, lo, hi = got
    st = _with_stage(ctx, s, st.shape[-1])  # the play grid placed on all training rows
    fit = ctx.fit(st, cur)
    stage = st.shape[-1]
    return fit, {"a1": stage[1], "a2": stage[2], **describe_shape(stage, lo, hi)}, {}


def _tanh_search(ctx: FitContext, s: Structure, cur: Fit, refine: bool | None = None
                 ) -> tuple[Structure, float, float] | None:
    """``s`` with the best tanh stage appended (see :func:`_build_saturation`), and the
    range of the tanh's input on the training rows. ``refine``: polish the grid point
    (``None``: only when it is worth it, :func:`_worth_refining`)."""
    lo, hi = _shape_input_range(ctx, s.shape)
    if not hi > lo:
        return None
    vc, vs = 0.5 * (lo + hi), 0.5 * (hi - lo)

    def make(phi) -> Structure:
        a1 = float(np.exp(phi[0])) / vs
        return _with_stage(ctx, s, tanh_stage(a1, float(phi[1]) - a1 * vc))

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
    if refine or (refine is None and _worth_refining(ctx, f(start), s, cur)):
        x, _ = _nelder_mead(f, phi, 0.2, 24)
        phi = x if f(x) <= f(start) else phi
    return make(phi), lo, hi


def _worth_refining(ctx: FitContext, rss_grid: float, ref: Structure, cur: Fit) -> bool:
    """Whether the best grid point of a shape search already lowers the training RSS of
    ``ref`` (the search's own fast path) by the smallest effect size of the acceptance
    rules: otherwise the candidate cannot pass, and it is reported at the grid point
    without a refinement."""
    from .acceptance import RULE

    return rss_grid < (1.0 - RULE.min_gain) * ctx.rss(ref, cur)


def _piecewise_map(breaks: Sequence[float], slopes: Sequence[float]) -> DeadZoneMap:
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


def _dead_band_map(kind: str, q: Sequence[float], log_s: float, lo: float, span: float
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


def _build_dead_zone(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Threshold / dead band: the plays driven by ``w = γ(u)``, a dead-zone superposition
    that is flat-ish (slope in :data:`DEAD_BAND_SLOPES` of the rest) on one stretch of the
    input: below a threshold, above one (one-sided), or between two (a central dead band).

    A map whose two ends both flatten is a saturation, not a dead band: that is the
    ``saturation`` candidate's, so the two name different physics (look-alikes only where a
    single end flattens). VarPro over the band's edges and log-slope: a grid per kind, then
    Nelder-Mead on the best kind.
    """
    if any(st[0] == "deadzone" for st in cur.structure.shape):
        return None
    # a saturation found earlier may have bent its tail to mimic the dead band: search the
    # band without it, then the saturation again on top of the band
    tanh_before = any(st[0] == "tanh" for st in cur.structure.shape)
    s = cur.structure.with_(shape=tuple(st for st in cur.structure.shape if st[0] != "tanh"))
    lo, hi = _shape_input_range(ctx, ())  # the dead zone acts on the input itself
    sctx, cur_s = search_context(ctx, cur)
    span = hi - lo
    if not span > 0:
        return None
    ls_lo, ls_hi = np.log(DEAD_BAND_SLOPES)
    memo: dict[tuple, float] = {}

    def f(kind: str, x) -> float:
        key = (kind, *(round(float(v), 6) for v in x))
        if not (all(0.0 < v < 1.0 for v in key[1:-1]) and ls_lo <= key[-1] <= ls_hi):
            return np.inf
        if key not in memo:
            g = _dead_band_map(kind, key[1:-1], key[-1], lo, span)
            memo[key] = sctx.rss(_with_stage(sctx, s, dead_zone_stage(g)), cur_s)
        return memo[key]

    ls = np.log([0.03, 0.2])
    grid = ([("low", (q, v)) for q in (0.15, 0.3, 0.45) for v in ls]
            + [("high", (q, v)) for q in (0.55, 0.7, 0.85) for v in ls]
            + [("middle", (a, b, v)) for a, b in ((0.35, 0.65), (0.2, 0.5), (0.5, 0.8))
               for v in ls])
    kind, x0 = min(grid, key=lambda c: f(*c))
    x = np.asarray(x0)
    if _worth_refining(sctx, f(kind, x0), s, cur_s):
        x1, _ = _nelder_mead(lambda v: f(kind, v), x, 0.08, 10 * len(x0))
        x = x1 if f(kind, x1) <= f(kind, x0) else x
    g = _dead_band_map(kind, x[:-1], x[-1], lo, span)
    st = _with_stage(sctx, s, dead_zone_stage(g))
    params: dict = {}
    if tanh_before:
        got = _tanh_search(sctx, st, cur_s, refine=True)
        if got is None:
            return None
        st = got[0]
        params = {"saturation_refitted": {"a1": st.shape[-1][1], "a2": st.shape[-1][2]}}
    # the play grid placed on all training rows
    st = st.with_(thresholds=tuple(float(v) for v in shape_thresholds(
        st.shape, ctx.records, ctx.train, len(st.thresholds))))
    fit = ctx.fit(st, cur)
    return fit, {"side": kind, "thresholds": g.thresholds.tolist(),
                 "weights": g.weights.tolist(), **describe_shape(st.shape[0], lo, hi),
                 **params}, {}


#: Candidate builders by effect name (each fits its effect on top of ``cur``).
BUILDERS: dict[str, Callable[[FitContext, Fit], Candidate | None]] = {
    "delay": _build_delay,
    "lag": _build_lag,
    "resonance": _build_resonance,
    "rate": _build_rate,
    "creep": _build_creep,
    "drift": _build_drift,
    "asymmetry": _build_asymmetry,
    "offset": _build_offset,
    "initial-memory": _build_initial_memory,
    "saturation": _build_saturation,
    "dead-zone": _build_dead_zone,
}


def build_candidate(ctx: FitContext, name: str, cur: Fit) -> Candidate | None:
    """Fit effect ``name`` on top of ``cur``: ``(fit, parameters, uncertainty)``, or ``None``
    when the effect is already in the structure or does not apply."""
    try:
        builder = BUILDERS[name]
    except KeyError:
        raise ParameterError(f"unknown effect {name!r}; known: {', '.join(BUILDERS)}") from None
    return builder(ctx, cur)
