"""Logarithmic creep: a bank of slow lags, one per decade of time."""

from __future__ import annotations

import numpy as np

from ...effects import Creep
from ..candidates import Candidate
from ..context import FitContext
from ..registry import DiagnosableEffect, register
from ..structure import Fit


def _untestable(ctx: FitContext) -> str | None:
    """Creep needs a hold (>= 0.5 s) after an input change (a step or a ramp: the creep /
    relaxation test) inside the train or test rows."""
    if any((tr | te)[h0 : h0 + n].any()
           for c, tr, te in zip(ctx.coords, ctx.train, ctx.test, strict=True)
           for h0, n, _ in c.holds):
        return None
    return "no hold of >= 0.5 s after an input change (a step or a ramp) inside the train/test rows"


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
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


register(DiagnosableEffect(
    "creep",
    family="slow",
    explanation=(
        'Logarithmic creep: after each input change the output keeps moving in the '
        'direction of that change, about linearly in log(time), modelled by a bank of '
        'slow lags.'
    ),
    equation="y = x + sum_j c_j (L_tau_j[x] - x),  tau_j L' + L = x",
    experiment='an up-then-down staircase with holds of 3-30 s (>= 2 decades of hold time)',
    time_dependent=True,
    build=_build,
    model_type=Creep,
    structure_field="creep_taus",
    untestable=_untestable,
    linear=True,
    stage_order=3,
    sign_locked=True,
    mimicked_by=(frozenset({"lag", "delay"}), "without holds, the fast end of a creep relaxation "
                 "spectrum acts as a lag at the excitation frequency; creep itself was "
                 "untestable"),
))
