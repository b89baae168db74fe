"""A first-order output lag (amplifier resistance times stack capacitance, sensor bandwidth)."""

from __future__ import annotations

import numpy as np

from ...stages import Lag
from ..candidates import Candidate, one_time_constant
from ..context import FitContext
from ..registry import DiagnosableEffect, OutputDynamics, register
from ..structure import Fit


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """A first-order output lag ``tau``."""
    return one_time_constant(ctx, cur, "lag", "tau_s")


#: Highest corner frequency ``1 / (2 pi tau)`` of a lag named in series with a mode, in units
#: of the mode's frequency: beyond two octaves above the mode, the mode has cut the output to
#: about 1/15 (``|H| = 1 / ((f / f_n)^2 - 1)``, 23.5 dB), and all the lag still adds below
#: it is a phase linear in frequency, which a little more damping of the mode
#: (``2 zeta / w_n`` of delay) or a delay gives as well: the lag's own signature, its
#: corner, lies where the output carries nothing.
LAG_CORNER_MAX_OVER_MODE = 4.0
#: Smallest lag named in series with a mode, in sample periods of the finest recording: a
#: discrete lag below half a sample period smooths each sample by less than the sampling
#: resolves.
LAG_MIN_SAMPLES = 0.5


def _corner_beyond_mode(v: tuple[float, ...], mode: tuple[float, ...], dt: float
                        ) -> str | None:
    """Why a lag ``v = (tau,)`` in series with a mode ``(f_n, zeta)`` does not show its own
    signature (its corner beyond :data:`LAG_CORNER_MAX_OVER_MODE` times the mode, or below
    :data:`LAG_MIN_SAMPLES` sample periods), or ``None``."""
    tau, f_n = v[0], mode[0]
    need = max(1.0 / (2 * np.pi * LAG_CORNER_MAX_OVER_MODE * f_n), LAG_MIN_SAMPLES * dt)
    if tau >= need:
        return None
    return (f"its time constant ({1e6 * tau:.3g} us) is below {1e6 * need:.3g} us (half a "
            f"sample period, or a corner frequency {LAG_CORNER_MAX_OVER_MODE:g} times the "
            f"mode's {f_n:.4g} Hz): it only adds a delay the mode's damping also gives")


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
                            combines_with=("resonance",),
                            lacks_signature_in_series=_corner_beyond_mode),
    transport=True,
    deciding=(
        ("rate", "a small-amplitude dither (peak-to-peak below 2 r_min) and sines "
         "at >= 3 frequencies: a lag acts on the reversible part too, rate-dependent hysteresis "
         "does not"),
    ),
))
