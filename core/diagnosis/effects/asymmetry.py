"""An asymmetric loop: a quadratic + cubic static output map."""

from __future__ import annotations

from ...effects import Asymmetry
from ..candidates import Candidate
from ..context import FitContext
from ..registry import DiagnosableEffect, register
from ..structure import Fit


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Quadratic + cubic output map."""
    s = cur.structure
    if s.asymmetry:
        return None
    fit = ctx.fit(s.with_(asymmetry=True), cur)
    return fit, {"a2": float(fit.asym_coef[0]), "a3": float(fit.asym_coef[1]),
                 "center": fit.asym_center, "scale": fit.asym_scale}, {}


register(DiagnosableEffect(
    "asymmetry",
    family="static",
    explanation=(
        'The loop is asymmetric: ascending and descending branches curve differently '
        '(field-dependent d33, an even-order nonlinearity); a static output map that '
        'classical (odd-symmetric) PI cannot represent. Actuator and sensor '
        'nonlinearity cannot be separated from (u, y) alone. (A loop that flattens '
        'at both ends at every amplitude is saturation, a flat stretch is a dead-zone; '
        'the three are look-alikes, told apart by the better held-out model.)'
    ),
    equation='y = x + a2 ((x - c)/s)^2 + a3 ((x - c)/s)^3',
    experiment='a full-range symmetric periodic excitation',
    amplitude_dependent=True,
    build=_build,
    model_type=Asymmetry,
    structure_field="asymmetry",
    linear=True,
    stage_order=2,
    inseparable_from=("sensor nonlinearity", "a static output map: actuator asymmetry and "
                      "sensor nonlinearity are not separable from (u, y)",
                      "an independent reference sensor"),
))
