"""A first-order output lag (amplifier resistance times stack capacitance, sensor bandwidth)."""

from __future__ import annotations

from ...effects import Lag
from ..candidates import Candidate, one_time_constant
from ..context import FitContext
from ..registry import DiagnosableEffect, OutputDynamics, register
from ..structure import Fit


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """A first-order output lag ``tau``."""
    return one_time_constant(ctx, cur, "lag", "tau_s")


register(DiagnosableEffect(
    "lag",
    family="dynamics",
    explanation=(
        'The output follows the model through a first-order lag (amplifier output '
        'resistance times stack capacitance, or the sensor bandwidth): an error '
        'proportional to the output rate, with exponential transients after reversals.'
    ),
    equation='tau * dy/dt + y = y_PI',
    time_dependent=True,
    between_recordings=True,
    build=_build,
    model_type=Lag,
    structure_field="dynamics",
    stage_order=4,
    dynamics=OutputDynamics(("tau_s",), model=lambda v: Lag(v[0]),
                            transfer=lambda v: ([1.0], [v[0], 1.0]),
                            # an amplifier / sensor low-pass before a mechanical mode
                            combines_with=("resonance",)),
    transport=True,
))
