"""A pure transport delay after the hysteresis (DAQ latency, zero-order hold, digital filters)."""

from __future__ import annotations

from ...stages import Delay
from ..candidates import Candidate, one_time_constant
from ..context import FitContext
from ..registry import DiagnosableEffect, OutputDynamics, register
from ..structure import Fit


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """A pure transport delay ``tau_d``."""
    return one_time_constant(ctx, cur, "delay", "delay_s")


register(DiagnosableEffect(
    "delay",
    family="dynamics",
    explanation=(
        'The measured output lags the model by a constant transport delay (DAQ latency, '
        'zero-order hold, digital sensor filter). It acts on the whole output slope, '
        'reversible and hysteretic alike.'
    ),
    equation='y(t) = y_PI(t - tau_d)',
    time_dependent=True,
    between_recordings=True,
    build=_build,
    model_type=Delay,
    structure_field="dynamics",
    stage_order=4,
    dynamics=OutputDynamics(("delay_s",), model=lambda v: Delay(v[0])),
    transport=True,
    deciding=(
        ("lag", "full-stroke sines at >= 3 frequencies a decade apart (a lag "
         "attenuates and its phase saturates, a delay's phase grows linearly with frequency)"),
        ("rate", "a small-amplitude dither (peak-to-peak below 2 r_min): a delay "
         "still lags, rate-dependent hysteresis fades; or a DAQ loop-back latency measurement"),
    ),
))
