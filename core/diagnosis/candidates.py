"""Candidate search: each effect fitted in full on top of the current structure.

Every builder searches the effect's few nonlinear parameters (separable least squares: a grid
and a bounded refinement, the linear weights re-solved inside by the structure fit) and
returns ``(fit, parameters, uncertainty)``; :data:`BUILDERS` maps effect names to builders.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..exceptions import ParameterError
from ..fitting.thresholds import reversal_indices, wipeout_index
from ..recordings import Recording
from .context import FitContext
from .structure import Fit

__all__ = ["BUILDERS", "Candidate", "build_candidate", "excitation_hz"]

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
        hist[k] = best[1]
    if not any(hist):
        return None
    fit = ctx.fit(s.with_(history=tuple(hist)), cur)
    return fit, {"history": [list(h) for h in hist]}, {}


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
    if s.beta_s is not None:
        return None
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
}


def build_candidate(ctx: FitContext, name: str, cur: Fit) -> Candidate | None:
    """Fit effect ``name`` on top of ``cur``: ``(fit, parameters, uncertainty)``, or ``None``
    when the effect is already in the structure or does not apply."""
    try:
        builder = BUILDERS[name]
    except KeyError:
        raise ParameterError(f"unknown effect {name!r}; known: {', '.join(BUILDERS)}") from None
    return builder(ctx, cur)
