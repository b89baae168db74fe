"""Base-model misspecification in an accepted effect's uncertainty (issue 16).

The noise-driven sigmas (profile curvature, block jackknife) and the recordings' spread
(:func:`core.diagnosis.crossfitting.recording_spread`) all assume that what the model leaves
in the residual is noise. When the base hysteresis is not the plant's (a PI, Preisach or
Bouc-Wen bank fitted to a Duhem or Maxwell-slip loop), part of its misfit is absorbed by the
effect's parameters (a delay shortened by a loop whose reversals come late, a resonance
damped by a branch that bends too early): a bias, the same in every recording and at every
noise level, which none of those sigmas can show.

Its size is measured by the sensitivity of the parameters to the choice of the base: the
accepted effect's nonlinear parameters are refitted (Newton steps on the training RSS from the
found values, every linear weight re-solved; a creep's weights by one solve) with the base
replaced by each of the other base families the diagnosis fits (:func:`alternative_bases`:
PI, Preisach, Bouc-Wen), every other effect of the final structure kept. None of them is known
to be the plant's, and how far the estimate moves between such admissible bases is the part
of it that the modelling choice, not the data, fixes (a specification-sensitivity term). The
systematic 1-sigma is the largest shift, as for the creep bank's placement
(:func:`core.diagnosis.effects.creep._bank_spread`): with two alternatives a root mean square
would understate it (the chosen base's own bias is as large as the alternatives' and is not
seen). It is added in quadrature to the statistical sigma; a parameter it takes beyond
:data:`~core.diagnosis.crossfitting.AMBIGUOUS_REL_SIGMA` is reported ambiguous. Only training
rows are used (the held-out rows stay unseen), and the found values are not changed.

Measured (benchmarks/diagnosis/results/*-sigma2.json, README "The base model's
misspecification in the sigmas"): on the non-PI families (110 recovered parameters) within
1-sigma or said ambiguous 64 -> 90; the Bouc-Wen alternative moves a PI-fitted delay or
resonance of a Bouc-Wen plant most of the way to the truth. On the real piezo the lag is
reported ambiguous (3.7 ms on the PI, 6.1 ms on a Preisach base). Cost: one fit and 3 (one
parameter) or 6 (two) training-RSS evaluations per Newton step and alternative: +1.5-3.4 % of
the diagnosis CPU on the benchmark plants, +6-7 % (0.3 s) on the piezo.

A misfit that differs between recordings is measured by :func:`recording_jackknife`: the
accepted effect refitted with each recording left out in turn (the recordings are the
independent units; the delete-one-group jackknife holds whatever the residual is). Unlike
fitting each recording alone it works where the parameter needs several recordings (a rate
needs several rates) or shows mostly in one (a mode in the fast sines). It runs with several
recordings and no explicit train/test windows (as the recordings' spread), so not on the
piezo's windowed diagnosis. Measured in benchmarks/diagnosis/README.md "Parameter honesty,
round 3".
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .bases import (
    BASE_KINDS,
    BW_MIN_GAIN,
    base_elements,
    bouc_wen_elements,
    elements_like,
    saturations,
)
from .context import FitContext
from .registry import EFFECTS
from .screening import ranking_span
from .shapes import apply_shape, loop_shape, shape_thresholds
from .structure import Fit, Structure, dynamics_stages, pack_dynamics

__all__ = ["alternative_bases", "base_sensitivity", "describe_alternative", "long_name",
           "recording_jackknife"]

#: (level segments, smoothness) of the Preisach base among the alternatives (the first of
#: the bases the base choice tries, :data:`core.diagnosis.basechoice.PREISACH_GRID`).
PREISACH_ALTERNATIVE = (3, 0.1)
#: Half-width (log units) of the local search of each parameter on an alternative base.
SEARCH_HALF_WIDTH = 0.5
#: Central-difference step (log units) and number of the Newton steps of that search.
NEWTON_H = 0.05
NEWTON_STEPS = 2
#: Largest training MSE of an alternative base (the effect refitted), relative to the chosen
#: one's, for its shift to count: the margin by which the base choice replaces a base
#: (:data:`core.diagnosis.bases.BW_MIN_GAIN` = 0.35: MSE ratio 1 / 0.65 = 1.54), so a base
#: the data reject by the base choice's own standard is left out (on a Preisach plant the PI
#: fits 5-50 times worse and its creep or delay moves to absorb the misfit).
ADMISSIBLE_MSE_RATIO = 1.0 / (1.0 - BW_MIN_GAIN)
#: Most play operators of the PI and Preisach alternatives (those the base choice
#: cross-validates: :func:`core.diagnosis.basechoice.choose_base`).
MAX_ALTERNATIVE_OPERATORS = 25


#: Name of the alternative that is the chosen base with its grid shifted half a step.
SHIFTED = "shifted"


def alternative_bases(ctx: FitContext, s: Structure) -> list[tuple[str, Structure]]:
    """``s`` with its base replaced by each other base family, and by itself on a grid
    shifted half a step, ``[(kind, structure)]`` (kind :data:`SHIFTED` for the latter).

    PI: as many plays as ``s`` has operators (at least 8) on the baseline's uniform grid;
    Preisach: those plays split into :data:`PREISACH_ALTERNATIVE` level segments; Bouc-Wen:
    the generic element grid (:func:`core.diagnosis.bases.bouc_wen_elements`) over the
    training input range (not with rate-dependent plays, which it does not model). The
    chosen base's own discretisation is arbitrary too: its play thresholds (and a Preisach
    base's level knots) moved down by half their spacing, or its Bouc-Wen saturations (a
    Menegotto-Pinto base's yield levels) by a factor sqrt(2) (half the grid's factor 2), as
    the creep bank is shifted half a decade.
    Every other part of ``s`` (loop shape, effects, histories) is kept.
    """
    recs, tr = ctx.records, ctx.train
    n = min(MAX_ALTERNATIVE_OPERATORS, max(8, len(s.thresholds)))
    # (a stop base's gap is its own input map: the other families run on the loop shape
    # alone, with weights of either sign as the PI baseline of clockwise loops has them)
    ls, free = loop_shape(s.shape), s.free_weights or s.stop
    thr = tuple(float(x) for x in shape_thresholds(ls, recs, tr, n))
    pi = s.with_(thresholds=thr, levels=(), level_smooth=0.0, bouc_wen=(), shape=ls,
                 free_weights=free)
    w = [apply_shape(ls, r.u)[m] for r, m in zip(recs, tr, strict=True) if m.any()]
    lo, hi = min(float(x.min()) for x in w), max(float(x.max()) for x in w)
    m, smooth = PREISACH_ALTERNATIVE
    knots = tuple(float(x) for x in lo + (hi - lo) * np.arange(1, m) / m)
    out = [("pi", pi)]
    if not free:  # (the base choice fits no Preisach with weights of either sign)
        out.append(("preisach", pi.with_(levels=knots, level_smooth=smooth)))
    if s.beta_s is None and hi > lo:
        el = bouc_wen_elements(hi - lo)
        out.append(("bouc-wen", s.with_(bouc_wen=el, thresholds=saturations(el), levels=(),
                                        level_smooth=0.0, shape=ls, free_weights=free)))
    out = [(k, a) for k, a in out if k != s.base_kind]
    # the chosen base's own grid, shifted by half a step
    if s.bouc_wen:
        el = elements_like(s.bouc_wen, np.sqrt(2.0) * (hi - lo))
        out.append((SHIFTED, s.with_(bouc_wen=el, thresholds=base_elements(el))))
    elif s.thresholds:
        r = np.asarray(s.thresholds, dtype=float)
        kn = np.asarray(s.levels, dtype=float)  # a Preisach base's level knots too
        out.append((SHIFTED, s.with_(
            thresholds=tuple(float(x) for x in r - 0.5 * np.diff(np.r_[0.0, r])),
            levels=tuple(float(x) for x in kn - 0.5 * np.diff(np.r_[lo, kn])))))
    return out


def _newton_steps(obj, x0: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                  steps: int = NEWTON_STEPS) -> np.ndarray:
    """Minimiser of ``obj`` near ``x0`` by ``steps`` Newton steps on a quadratic
    through central differences (step :data:`NEWTON_H`, ``1 + 2 d + d (d - 1) / 2``
    evaluations each), clipped to the box ``[lo, hi]``. Where the quadratic has no minimum
    (the profile is flat or concave: this base does not fix the parameter) the step goes
    to the box edge downhill."""
    x = np.asarray(x0, dtype=float)
    d, h = x.size, NEWTON_H
    for _ in range(steps):
        f0 = obj(x)
        fp = np.array([obj(x + h * np.eye(d)[i]) for i in range(d)])
        fm = np.array([obj(x - h * np.eye(d)[i]) for i in range(d)])
        if not (np.isfinite(f0) and np.all(np.isfinite(fp)) and np.all(np.isfinite(fm))):
            break
        g = (fp - fm) / (2 * h)
        H = np.diag((fp - 2 * f0 + fm) / h**2)
        for i in range(d):
            for j in range(i + 1, d):
                fij = obj(x + h * (np.eye(d)[i] + np.eye(d)[j]))
                H[i, j] = H[j, i] = (fij - fp[i] - fp[j] + f0) / h**2
        try:
            pd = bool(np.all(np.linalg.eigvalsh(H) > 0))
        except np.linalg.LinAlgError:
            pd = False
        step = -np.linalg.solve(H, g) if pd else np.where(g > 0, lo - x, hi - x)
        x_new = np.clip(x + step, lo, hi)
        if not pd or np.max(np.abs(x_new - x)) < 0.1 * h:
            return x_new
        x = x_new
    return x


def _parameter_path(ctx: FitContext, name: str, a: Structure, params: dict[str, Any]
                    ) -> tuple[tuple[str, ...], np.ndarray, Any] | None:
    """Effect ``name``'s nonlinear parameters on structure ``a`` (which holds it):
    ``(keys, log of the found values, make)`` where ``make(log values)`` is ``a`` with the
    effect at those values (``None`` where they are not valid), or ``None`` for an effect
    without nonlinear parameters here (also a stage of a pair in series, whose sigmas come
    from the pair's own curvature)."""
    e = EFFECTS[name]
    if e.dynamics is not None and len(dynamics_stages(a.dynamics)) > 1:
        return None  # (a stage of two in series: refitting it alone would drop the other)
    if e.dynamics is not None:
        spec = e.dynamics
        dt = min(r.dt for r in ctx.records)

        def make(lx: np.ndarray) -> Structure | None:
            v = tuple(float(x) for x in np.exp(lx))
            return a.with_(dynamics=(name, *v)) if spec.valid(v, dt) else None

        keys = spec.params
    elif e.structure_field == "beta_s" and a.beta_s is not None:
        keys = ("beta_s",)

        def make(lx: np.ndarray) -> Structure | None:
            return a.with_(beta_s=float(np.exp(lx[0])))
    else:
        return None
    return keys, np.log([float(params[k]) for k in keys]), make


def _stages_path(ctx: FitContext, name: str, a: Structure
                 ) -> tuple[list[tuple[int, str]], np.ndarray, Any] | None:
    """All output stages of ``a`` in series (where ``name`` is one of two or more), jointly:
    ``(positions of name's parameters in the joint vector with their keys, log of every
    stage's values, make)``, as the pair was fitted (the stages trade off against each
    other, so one is never refitted alone); ``None`` otherwise."""
    stages = dynamics_stages(a.dynamics)
    if len(stages) < 2 or name not in [n for n, _ in stages]:
        return None
    names = [n for n, _ in stages]
    dt = min(r.dt for r in ctx.records)
    own, o = [], 0
    for n, vals in stages:
        spec = EFFECTS[n].dynamics
        assert spec is not None
        if n == name:
            own = [(o + i, k) for i, k in enumerate(spec.params)]
        o += len(vals)

    def make(lx: np.ndarray) -> Structure | None:
        d = pack_dynamics(names, np.exp(lx), dt)
        return None if d is None else a.with_(dynamics=d)

    return own, np.log([v for _, vals in stages for v in vals]), make


def _refit(ctx: FitContext, name: str, a: Structure, params: dict[str, Any], cur: Fit
           ) -> tuple[dict[str, float], float] | None:
    """Effect ``name``'s parameters refitted on structure ``a`` (which holds it at the
    found ``params``): the linear weights re-solved; the nonlinear parameters (log space)
    by :func:`_newton_steps` from the found values, within :data:`SEARCH_HALF_WIDTH`.
    Returns the estimates and the training RSS of the structure fitted there, or ``None``
    for an effect without parameters to refit here (:func:`_parameter_path`)."""
    e = EFFECTS[name]
    warm = ctx.fit(a, cur)
    if e.term is not None and e.term.refit_parameters is not None and a.term(name) != e.term.off:
        # linear: the weights re-solved on the other base (the settings unchanged)
        return e.term.refit_parameters(a.term(name), warm.terms[name]), warm.train_rss
    path = _parameter_path(ctx, name, a, params)
    if path is None:
        return None
    keys, x0, make = path

    def obj(lx: np.ndarray) -> float:
        st = make(lx)
        return np.inf if st is None else ctx.rss(st, warm)

    x = _newton_steps(obj, x0, x0 - SEARCH_HALF_WIDTH, x0 + SEARCH_HALF_WIDTH)
    st = make(x)
    rss = ctx.fit(st, warm).train_rss if st is not None else np.inf
    return dict(zip(keys, (float(v) for v in np.exp(x)), strict=True)), rss


def _on_prefix(ctx: FitContext, cur: Fit) -> tuple[FitContext, Fit]:
    """``ctx`` and ``cur``; or, where a recording is longer than the searches read
    (:func:`~core.diagnosis.screening.ranking_span`), a context of the recordings cut to
    those prefixes and ``cur``'s structure fitted there: every alternative base is then
    fitted on the prefixes (its banks and simulations bounded by them, not by the record)
    and compared with ``cur``'s structure on the same rows."""
    spans = [ranking_span(r, m) for r, m in zip(ctx.records, ctx.train, strict=True)]
    if all(k >= r.n_samples for k, r in zip(spans, ctx.records, strict=True)):
        return ctx, cur
    recs = [r if k >= r.n_samples else r.window(None, float(r.t[k]))
            for k, r in zip(spans, ctx.records, strict=True)]
    sub = FitContext(recs, [m[: r.n_samples] for m, r in zip(ctx.train, recs, strict=True)],
                     [m[: r.n_samples] for m, r in zip(ctx.test, recs, strict=True)])
    return sub, sub.fit(cur.structure)


def base_sensitivity(ctx: FitContext, name: str, cur: Fit, params: dict[str, Any]
                     ) -> dict[str, Any] | None:
    """How much effect ``name``'s parameters move when the base of the final fit ``cur`` is
    replaced by each admissible one of :func:`alternative_bases` (module docstring): those
    whose training MSE, the effect refitted, is within :data:`ADMISSIBLE_MSE_RATIO` of
    ``cur``'s (a base the data reject does not say how uncertain the estimate is).

    Returns
    -------
    dict or None
        ``per_base`` ``{kind: {parameter: estimate}}`` and ``mse_ratio`` ``{kind: training
        MSE / cur's}`` of the admissible alternatives, ``rejected`` ``{kind: ratio}``,
        ``sigma`` ``{parameter: largest shift}`` (parameter units; 0 without an admissible
        alternative); ``None`` for effects without parameters to refit.
    """
    per: dict[str, dict[str, float]] = {}
    ratio: dict[str, float] = {}
    rejected: dict[str, float] = {}
    keys: tuple[str, ...] = ()
    ctx, cur = _on_prefix(ctx, cur)
    for kind, a in alternative_bases(ctx, cur.structure):
        got = _refit(ctx, name, a, params, cur)
        if got is None:
            return None
        est, rss = got
        keys = tuple(est)
        q = float(rss / max(cur.train_rss, 1e-300))
        if q <= ADMISSIBLE_MSE_RATIO:
            per[kind], ratio[kind] = est, q
        else:
            rejected[kind] = q
    if not keys:
        return None
    sigma = {k: max((abs(p[k] - float(params[k])) for p in per.values()), default=0.0)
             for k in keys}
    return {"per_base": per, "mse_ratio": ratio, "rejected": rejected, "sigma": sigma}


#: Fewest recordings with training rows for :func:`recording_jackknife` (deleting one of two
#: leaves a single recording, which need not fix the parameter at all).
JACKKNIFE_MIN_RECORDINGS = 3
#: Newton steps of each delete-one-recording refit: one from the found values (every fold
#: evaluates the same parameter points, so the play banks are computed once and shared).
JACKKNIFE_NEWTON_STEPS = 1


def recording_jackknife(ctx: FitContext, name: str, cur: Fit, params: dict[str, Any]
                        ) -> dict[str, Any] | None:
    """Delete-one-recording jackknife of effect ``name``'s nonlinear parameters.

    The recordings are the independent units of the data (separate excitations, each with
    its own share of the base model's misfit). The effect's parameters are refitted on the
    final structure ``cur`` with each recording's training rows left out in turn (every
    other effect kept, the linear weights re-solved, :data:`JACKKNIFE_NEWTON_STEPS` Newton
    step from the found ``params`` within :data:`SEARCH_HALF_WIDTH`), and
    ``sd = sqrt((K - 1) / K * sum_j (theta_-j - mean)**2)``: the cluster-robust 1-sigma,
    which holds whatever the residual is (noise or misfit), unlike the profile curvature
    and the block jackknife, which read the residual as noise. Unlike
    :func:`~core.diagnosis.crossfitting.recording_spread` (each recording fitted alone) it
    needs no recording to fix the parameter by itself: a rate-dependent loop needs
    recordings at several rates, a mode may show in the fast recording only.

    A recording without which the others do not fix the parameter (the step reaches the
    edge of the search: no minimum within it) is kept in every refit instead: its deletion
    gives no estimate, and the jackknife runs over the ``K`` other recordings (at least two;
    the spread is then that of the estimate given that recording). A stage of two in series
    (a lag and a mode) is refitted jointly with the other (:func:`_stages_path`), as the pair
    was fitted. Training rows only.

    Returns
    -------
    dict or None
        ``recordings`` (names of the recordings left out in turn), ``per_recording`` (the
        estimate without each), ``essential`` (the recordings whose deletion leaves the
        parameters unfixed, kept in every refit), ``sigma`` ``{parameter: jackknife
        1-sigma}``; ``None`` with fewer than :data:`JACKKNIFE_MIN_RECORDINGS` recordings
        that have training rows or fewer than two usable deletions, or for an effect
        without nonlinear parameters here.
    """
    recs, tr = ctx.records, ctx.train
    used = [j for j, m in enumerate(tr) if m.any()]
    if len(used) < JACKKNIFE_MIN_RECORDINGS:
        return None
    pair = _stages_path(ctx, name, cur.structure)
    if pair is not None:  # a stage of two in series: the stages refitted jointly
        own, x0, make = pair
    else:
        path = _parameter_path(ctx, name, cur.structure, params)
        if path is None:
            return None
        x0, make = path[1], path[2]
        own = list(enumerate(path[0]))
    keys = [k for _, k in own]
    none = [np.zeros(r.n_samples, dtype=bool) for r in recs]
    est: dict[int, np.ndarray] = {}
    for j in used:
        fc = FitContext(recs, [none[k] if k == j else m for k, m in enumerate(tr)], none,
                        parent=ctx)

        def obj(lx: np.ndarray, fc: FitContext = fc) -> float:
            st = make(lx)
            return np.inf if st is None else fc.rss(st, cur)

        est[j] = _newton_steps(obj, x0, x0 - SEARCH_HALF_WIDTH, x0 + SEARCH_HALF_WIDTH,
                               JACKKNIFE_NEWTON_STEPS)
    # (the step is clipped to the box: at its edge the others have no minimum within it)
    essential = [j for j in used
                 if np.any(np.abs(est[j] - x0) >= SEARCH_HALF_WIDTH * (1.0 - 1e-9))]
    kept = [j for j in used if j not in essential]
    if len(kept) < 2:
        return None
    a = np.exp(np.asarray([[est[j][i] for i, _ in own] for j in kept]))
    k = a.shape[0]
    sd = np.sqrt((k - 1) / k * np.sum((a - a.mean(axis=0)) ** 2, axis=0))
    return {"recordings": [recs[j].name for j in kept],
            "per_recording": [dict(zip(keys, (float(v) for v in row), strict=True))
                              for row in a],
            "essential": [recs[j].name for j in essential],
            "sigma": dict(zip(keys, (float(v) for v in sd), strict=True))}


def describe_alternative(kind: str, chosen: str) -> str:
    """``kind`` of :func:`alternative_bases` in words (``chosen``: the chosen base's kind)."""
    if kind == SHIFTED:
        return f"the {long_name(chosen)} with its grid shifted half a step"
    return f"a {long_name(kind)} base"


def long_name(kind: str) -> str:
    """How the report names base kind ``kind`` (:attr:`BaseKind.long
    <core.diagnosis.bases.BaseKind.long>`; an unknown kind by itself)."""
    k = BASE_KINDS.get(kind)
    return kind if k is None else k.long
