"""Rate-dependent hysteresis: play thresholds that widen with the input rate."""

from __future__ import annotations

import numpy as np

from ...stages import RateDependentPI
from ..between import recording_rates
from ..candidates import Candidate, scalar_search, sigma_from_curvature
from ..context import FitContext
from ..registry import DiagnosableEffect, register
from ..structure import Fit


def _untestable(ctx: FitContext) -> str | None:
    """Rate-dependent hysteresis needs travels whose mean rates |du/dt| (large travels
    only) span at least a factor 5."""
    rates = recording_rates(ctx)
    peaks = [p for ps in rates for p in ps]
    if len(peaks) < 2 or max(peaks) / max(min(peaks), 1e-300) < 5.0:
        what = "the recording excites" if len(rates) == 1 else "the recordings excite"
        return (f"{what} a single rate (mean rates of the travels within a "
                "factor 5), so rate-dependent hysteresis cannot be told from rate-independent "
                "loop width")
    return None


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Rate-dependent play thresholds r_i + beta |du/dt| (of the PI, or of the plays whose
    level segments make a Preisach base): a 1-D search over beta."""
    s = cur.structure
    if s.beta_s is not None or s.bouc_wen or s.stop:
        return None  # rate-dependent plays on a Bouc-Wen or stop base are not modelled
    span = max(float(np.ptp(r.u)) for r in ctx.records)
    rmax = max(float(np.max(np.abs(c.rate))) for c in ctx.coords) or 1.0
    grid = np.geomspace(1e-5, 0.3, 12) * span / rmax
    best, fit, info = scalar_search(ctx, lambda v: s.with_(beta_s=v), grid, cur,
                                    near=None if ctx.start is None else ctx.start.beta_s)
    return fit, {"beta_s": best}, {"beta_s": sigma_from_curvature(
        ctx, fit, info["profile_curvature"], best)}


register(DiagnosableEffect(
    "rate",
    family="dynamics",
    explanation=(
        'The hysteresis itself depends on the input rate: the play thresholds widen '
        'with |du/dt| (rate-dependent PI; on a Preisach base, the relay thresholds), '
        'widening the loops at higher rates while the reversible part is unaffected.'
    ),
    equation='y = p0 u + sum_i p_i Play[r_i + beta |du/dt|](u)',
    experiment='full-stroke sines (or triangles) at >= 2 rates a decade apart, same amplitude',
    time_dependent=True,
    between_recordings=True,
    build=_build,
    model_type=RateDependentPI,
    structure_field="beta_s",
    untestable=_untestable,
    rate_dependent_hysteresis=True,
    stage_order=1,
    mimicked_by=(frozenset({"delay", "lag", "resonance"}), "at a single excitation rate, "
                 "rate-dependent hysteresis widens the loop as a {best} does; rate itself "
                 "was untestable"),
    history_experiment="the same loop at several rates",
))
