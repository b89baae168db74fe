"""An asymmetric loop: a quadratic + cubic static output map."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ...stages import Asymmetry
from ..candidates import Candidate
from ..context import FitContext
from ..registry import DiagnosableEffect, StaticTerm, TermFit, TermRows, register
from ..structure import Fit


class MapCoefficients(NamedTuple):
    """The fitted output map: ``a = (a2, a3)`` in the normalised coordinate
    ``(x - center) / scale`` (output units)."""

    a: np.ndarray
    center: float
    scale: float


def _columns(on: bool, rows: TermRows) -> np.ndarray:
    """``q^2, q^3`` of the PI-stage output ``x``, ``q = (x - center) / scale``."""
    assert rows.x is not None
    q = (rows.x - rows.fit.center) / rows.fit.scale
    return np.column_stack((q**2, q**3))


def _coefficients(on: bool, w: np.ndarray, fit: TermFit) -> MapCoefficients:
    return MapCoefficients(w, fit.center, fit.scale)


TERM = StaticTerm(
    off=False,
    width=lambda on, n_records: 2 if on else 0,
    columns=_columns,
    coefficients=_coefficients,
    stage=lambda on, c, k, record: Asymmetry(c.a, c.center, c.scale),
    through_dynamics=True,
)


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Quadratic + cubic output map."""
    s = cur.structure
    if s.term("asymmetry"):
        return None
    fit = ctx.fit(s.with_term("asymmetry", True), cur)
    c = fit.terms["asymmetry"]
    return fit, {"a2": float(c.a[0]), "a3": float(c.a[1]),
                 "center": c.center, "scale": c.scale}, {}


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
    parameter_words=(
        ("a2", "output added at both ends of the loop (its bend)", "output"),
        ("a3", "output added at the upper end and taken at the lower (its stretch)", "output"),
        ("center", "centre of the bend", "output"),
        ("scale", "half-range (from the centre to either end)", "output"),
    ),
    experiment='a full-range symmetric periodic excitation',
    amplitude_dependent=True,
    build=_build,
    model_type=Asymmetry,
    structure_field="terms",
    term=TERM,
    linear=True,
    stage_order=2,
    inseparable_from=("sensor nonlinearity", "a static output map: actuator asymmetry and "
                      "sensor nonlinearity are not separable from (u, y)",
                      "an independent reference sensor"),
))
