"""A slow additive drift in absolute time (Legendre polynomials per recording)."""

from __future__ import annotations

import numpy as np

from ...effects import Drift
from ..candidates import Candidate
from ..context import FitContext
from ..registry import DiagnosableEffect, register
from ..structure import Fit

#: A single recording shorter than this (s) cannot test a drift: a polynomial in time over
#: a short record is absorbed by the bias and slow noise.
SINGLE_DRIFT_S = 60.0


def _untestable(ctx: FitContext) -> str | None:
    """A drift must repeat across recordings or span minutes (:data:`SINGLE_DRIFT_S`)."""
    total = sum(float(r.t[-1] - r.t[0]) for r in ctx.records)
    if total < SINGLE_DRIFT_S and len(ctx.records) == 1:
        return (f"a single {total:.3g} s record cannot separate a slow drift from the model's "
                "bias and from slow sensor noise (a drift must repeat across recordings, or "
                "span minutes)")
    return None


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Legendre drift of degree 2 in absolute time per recording."""
    s = cur.structure
    if s.drift_degree:
        return None
    fit = ctx.fit(s.with_(drift_degree=2), cur)
    return fit, {"coefficients": [c.tolist() for c in fit.drift_coef],
                 "peak_to_peak": [float(np.ptp(m.stages[-1].drift(r.t - r.t[0])))
                                  for m, r in zip(fit.models, ctx.records, strict=True)]}, {}


register(DiagnosableEffect(
    "drift",
    family="slow",
    explanation=(
        'A slow additive drift in absolute time (thermal expansion, sensor zero drift), '
        'continuous across steps and independent of the step direction.'
    ),
    equation='y = x + sum_k a_k P_k(2 t / T - 1)  (Legendre polynomials)',
    experiment=(
        'a record of several minutes, or an identical 1 Hz reference cycle repeated '
        'every 60 s over >= 5 min'
    ),
    time_dependent=True,
    lookalikes=("offset",),
    build=_build,
    model_type=Drift,
    structure_field="drift_degree",
    untestable=_untestable,
    linear=True,
    stage_order=6,
))
