"""A lightly damped mechanical mode after the hysteresis (second-order low-pass)."""

from __future__ import annotations

import numpy as np

from ...stages import Resonance
from ..candidates import Candidate, excitation_hz, sigma_from_curvature, walk_down
from ..context import FitContext
from ..registry import DiagnosableEffect, OutputDynamics, register
from ..structure import Fit


def _valid(v: tuple[float, ...], dt: float) -> bool:
    """Below 0.45 of the sampling rate, damping 0.005-2."""
    return v[0] <= 0.45 / dt and 0.005 <= v[1] <= 2.0


def _transfer(v: tuple[float, ...]) -> tuple[list[float], list[float]]:
    """``w_n^2 / (s^2 + 2 zeta w_n s + w_n^2)`` with ``w_n = 2 pi freq_hz``."""
    w = 2 * np.pi * v[0]
    return [w * w], [1.0, 2 * v[1] * w, w * w]


#: Largest damping ratio at which a fitted mode counts as a resonance: from zeta = 1/2 on,
#: the second-order term of its low-frequency expansion is no longer negative
#: (g2 / g1^2 = 1 - 1 / (4 zeta^2) >= 0, notes §4.1), so it does not ring; it delays the
#: output as a delay (g2 / g1^2 = 1/2) or a lag (1) does.
RINGING_MAX_DAMPING = 0.5


def _lacks_ringing(v: tuple[float, ...]) -> str | None:
    """Why a fitted mode is no resonance: damped too much to ring (``None`` when it rings)."""
    if v[1] < RINGING_MAX_DAMPING:
        return None
    return (f"its damping ({v[1]:.2f}, at least {RINGING_MAX_DAMPING:g}) is too high for it "
            "to ring: the fitted mode only delays the output")


#: Largest ratio between neighbouring frequencies of the grid the mode's search starts from.
#: A lightly damped mode lowers the residual only inside a basin about a factor 2 wide around
#: its frequency (the rest of the frequency axis is flat or worse, more so where the base
#: misses the loops): a coarser grid can step over the basin, and the local search from the
#: best grid point then ends at another minimum. With neighbours at most sqrt(2) apart every
#: frequency is within a factor 2^(1/4) of a grid point.
GRID_RATIO = 2.0**0.5


def grid_frequencies(fmin: float, fmax: float) -> np.ndarray:
    """Frequencies (Hz) of the search grid from ``fmin`` to ``fmax``, log-spaced with
    neighbours at most :data:`GRID_RATIO` apart (at least 7)."""
    n = max(7, int(np.ceil(np.log(fmax / fmin) / np.log(GRID_RATIO) - 1e-9)) + 1)
    return np.geomspace(fmin, fmax, n)


#: Structure evaluations of the Nelder-Mead refinement from the grid's best point.
SEARCH_MAXFEV = 32


def _simplex_steps(fs: np.ndarray, zs: np.ndarray) -> np.ndarray:
    """The initial simplex of the refinement, as steps from the grid's best point in
    ``(log f, log zeta)``: half a grid step in frequency and half a grid step (in the log)
    down in damping, so that the search spans the cell the grid left it in. Scipy's default
    simplex (5 % of each coordinate: a third of the frequency grid's step, a twentieth of
    the damping's) with 16 evaluations stopped the development Menegotto-Pinto steel's
    200 Hz, zeta 0.05 mode at zeta 0.16 from the grid's 0.2 (training RSS 256 times the
    truth's); from this simplex 32 evaluations end within 1 % of both."""
    hf = 0.5 * float(np.log(fs[1] / fs[0]))
    hz = 0.5 * float(np.min(np.diff(np.log(zs))))
    return np.array([[0.0, 0.0], [hf, 0.0], [0.0, -hz]])


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
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
    fs = grid_frequencies(fmin, fmax)
    zs = np.array([0.05, 0.2, 0.7])
    vals: dict[tuple[int, ...], float] = {}

    def at(ij: tuple[int, ...]) -> float:
        if ij not in vals:
            vals[ij] = ctx.rss(s.with_(dynamics=("resonance", float(fs[ij[0]]),
                                                  float(zs[ij[1]]))), cur)
        return vals[ij]

    st = ctx.start
    if st is not None and len(st.dynamics) == 3 and st.dynamics[0] == "resonance":
        # a cross-fitting fold: the grid walked from the point nearest the estimate on all
        # the training rows (the same minimum as the whole grid's where it has one local
        # minimum: core.diagnosis.candidates.walk_down)
        ij = walk_down(at, (fs.size, zs.size), tuple(
            int(np.argmin(np.abs(np.log(g) - np.log(float(v)))))
            for g, v in zip((fs, zs), st.dynamics[1:], strict=True)))
    else:
        ij = min(np.ndindex(fs.size, zs.size), key=at)  # (the first of equal values)
    best = (at(ij), fs[ij[0]], zs[ij[1]])

    def obj(p):
        f_, z_ = float(np.exp(p[0])), float(np.exp(p[1]))
        if not (fmin * 0.5 <= f_ <= 0.45 / dt and 0.005 <= z_ <= 2.0):
            return np.inf
        return ctx.rss(s.with_(dynamics=("resonance", f_, z_)), cur)

    x0 = np.array([np.log(best[1]), np.log(best[2])])
    r = so.minimize(obj, x0, method="Nelder-Mead",
                    options={"maxfev": SEARCH_MAXFEV, "xatol": 0.03, "fatol": 1e-9,
                             "initial_simplex": x0 + _simplex_steps(fs, zs)})
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
        unc[key] = sigma_from_curvature(ctx, fit, c, val)
    return fit, {"freq_hz": f_, "damping": z_}, unc


register(DiagnosableEffect(
    "resonance",
    family="dynamics",
    explanation=(
        'A lightly damped mechanical mode after the hysteresis (stack plus stage mass '
        'on the flexure stiffness): ringing after steps and sharp reversals.'
    ),
    parameter_words=(("freq_hz", "natural frequency", "Hz"),),
    equation="y'' + 2 zeta w_n y' + w_n^2 y = w_n^2 y_PI,  w_n = 2 pi f_n",
    time_dependent=True,
    between_recordings=True,
    build=_build,
    model_type=Resonance,
    structure_field="dynamics",
    stage_order=4,
    dynamics=OutputDynamics(("freq_hz", "damping"), model=lambda v: Resonance(v[0], v[1]),
                            transfer=_transfer, valid=_valid,
                            lacks_signature=_lacks_ringing),
    deciding=(
        ("lag", "a step or a broadband multisine up to the suspected mode "
         "(a resonance rings and overshoots, a lag does not)"),
        ("delay", "a step or a broadband multisine up to the suspected mode"),
        ("rate", "a step or a broadband multisine: a mode rings at f_d "
         "whatever the hysteresis state"),
    ),
))
