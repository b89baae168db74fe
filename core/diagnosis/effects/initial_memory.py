"""An unknown initial memory state: virtual prior input extrema per recording."""

from __future__ import annotations

import numpy as np

from ...fitting.steadystate import steady_state_history
from ...fitting.thresholds import wipeout_index
from ...stages import InitialMemory
from ..candidates import Candidate
from ..context import FitContext
from ..registry import DiagnosableEffect, register
from ..structure import Fit


def _untestable(ctx: FitContext) -> str | tuple[str, str] | None:
    """The initial memory shows only before the wipe-out time, and not at all in a periodic
    steady state (which the model starts from)."""
    recs = ctx.records
    steady = [r.name for r in recs if steady_state_history(r)]
    if len(steady) == len(recs):
        return (f"{', '.join(steady)} {'is' if len(steady) == 1 else 'are'} in periodic "
                "steady state (one cycle repeated, the output already periodic, or a single "
                "closed loop): the memory at the first sample is the one the cycle leaves, and "
                "the model starts from it",
                "a recording that starts before the first full sweep, from a known (e.g. "
                "demagnetised) state")
    if not any((tr[: wipeout_index(r.u)].any() or te[: wipeout_index(r.u)].any())
               for r, tr, te in zip(recs, ctx.train, ctx.test, strict=True)):
        return ("every train/test row comes after the input swept its full range, which wipes "
                "out the initial memory")
    return None


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Virtual prior input extrema per recording (grid, then Nelder-Mead)."""
    s = cur.structure
    if any(s.history):
        return None
    return initial_memory_search(ctx, cur)



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


register(DiagnosableEffect(
    "initial-memory",
    family="memory",
    explanation=(
        'The actuator did not start from the assumed memory state: its history before '
        'the record (a virtual prior excursion) sets the play states, and the error '
        'lives before the input has swept its full range (the wipe-out time).'
    ),
    equation='play states at t=0 = Play[r_i](virtual history U_1, U_2, ...)',
    experiment='data before the input first sweeps its full range (the wipe-out time)',
    build=_build,
    model_type=InitialMemory,
    structure_field="history",
    untestable=_untestable,
    before_wipeout=True,
    history_experiment="several recordings that start from rest the same way",
))
