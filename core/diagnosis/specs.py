"""One specification per effect: family, explanation, equation, what makes it testable.

The engine, the reports and the untestable rules read these; the candidate builders are in
:data:`core.diagnosis.candidates.BUILDERS` under the same names.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["DECIDING_EXPERIMENT", "EFFECTS", "FAMILY_PRIORITY", "UNTESTABLE_LOOKALIKES", "Effect",
           "time_effects"]


@dataclass(frozen=True)
class Effect:
    """What the diagnosis knows about one effect.

    Attributes
    ----------
    name : str
        Effect name (a ``core.effects`` type, ``--effects`` value).
    family : str
        Look-alike family (``"dynamics"``, ``"slow"``, ``"static"``, ``"static-offset"``,
        ``"memory"``): inside a family the winner must beat the runner-up.
    explanation : str
        The physics in words (SAY).
    equation : str
        What is added to the model (MODEL).
    experiment : str or None
        The recording that would make it testable when it is not.
    time_dependent : bool
        Needs a time axis (untestable on index-only recordings).
    between_recordings : bool
        Changes the loop from one excitation rate to the next: with several recordings at
        different rates it is judged by predicting each recording from the others
        (:func:`core.diagnosis.between.between_recordings`), not on rows of the recordings
        it was fitted to.
    amplitude_dependent : bool
        Changes the loop from one input amplitude to the next beyond what the PI's own
        memory does (a static output map, a loop-shape nonlinearity): with several
        recordings of one amplitude each, at different amplitudes, it is judged by
        predicting each recording from the others.
    """

    name: str
    family: str
    explanation: str
    equation: str
    experiment: str | None = None
    time_dependent: bool = False
    between_recordings: bool = False
    amplitude_dependent: bool = False


#: Every effect the diagnosis tests, in the order of the notes' catalogue.
EFFECTS: dict[str, Effect] = {
    "delay": Effect(
        "delay",
        "dynamics",
        explanation=(
            'The measured output lags the model by a constant transport delay (DAQ latency, '
            'zero-order hold, digital sensor filter). It acts on the whole output slope, '
            'reversible and hysteretic alike.'
        ),
        equation='y(t) = y_PI(t - tau_d)',
        experiment=None,
        time_dependent=True,
        between_recordings=True,
    ),
    "lag": Effect(
        "lag",
        "dynamics",
        explanation=(
            'The output follows the model through a first-order lag (amplifier output '
            'resistance times stack capacitance, or the sensor bandwidth): an error '
            'proportional to the output rate, with exponential transients after reversals.'
        ),
        equation='tau * dy/dt + y = y_PI',
        experiment=None,
        time_dependent=True,
        between_recordings=True,
    ),
    "resonance": Effect(
        "resonance",
        "dynamics",
        explanation=(
            'A lightly damped mechanical mode after the hysteresis (stack plus stage mass '
            'on the flexure stiffness): ringing after steps and sharp reversals.'
        ),
        equation="y'' + 2 zeta w_n y' + w_n^2 y = w_n^2 y_PI,  w_n = 2 pi f_n",
        experiment=None,
        time_dependent=True,
        between_recordings=True,
    ),
    "rate": Effect(
        "rate",
        "dynamics",
        explanation=(
            'The hysteresis itself depends on the input rate: the play thresholds widen '
            'with |du/dt| (rate-dependent PI), widening the loops at higher rates while the '
            'reversible part is unaffected.'
        ),
        equation='y = p0 u + sum_i p_i Play[r_i + beta |du/dt|](u)',
        experiment=(
            'full-stroke sines (or triangles) at >= 2 rates a decade apart, same amplitude'
        ),
        time_dependent=True,
        between_recordings=True,
    ),
    "creep": Effect(
        "creep",
        "slow",
        explanation=(
            'Logarithmic creep: after each input change the output keeps moving in the '
            'direction of that change, about linearly in log(time), modelled by a bank of '
            'slow lags.'
        ),
        equation="y = x + sum_j c_j (L_tau_j[x] - x),  tau_j L' + L = x",
        experiment=(
            'an up-then-down staircase with holds of 3-30 s (>= 2 decades of hold time)'
        ),
        time_dependent=True,
    ),
    "drift": Effect(
        "drift",
        "slow",
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
    ),
    "asymmetry": Effect(
        "asymmetry",
        "static",
        explanation=(
            'The loop is asymmetric/saturating: ascending and descending branches curve '
            'differently (field-dependent d33, saturation); a static output map that '
            'classical (odd-symmetric) PI cannot represent. Actuator and sensor '
            'nonlinearity cannot be separated from (u, y) alone.'
        ),
        equation='y = x + a2 ((x - c)/s)^2 + a3 ((x - c)/s)^3',
        experiment='a full-range symmetric periodic excitation',
        time_dependent=False,
        amplitude_dependent=True,
    ),
    "offset": Effect(
        "offset",
        "static-offset",
        explanation=(
            'The sensor zero differs between recordings (an offset per recording).'
        ),
        equation='y = x + c_k  (one offset per recording)',
        experiment=(
            'several recordings (an offset per recording), or an independent zero reference'
        ),
        time_dependent=False,
    ),
    "initial-memory": Effect(
        "initial-memory",
        "memory",
        explanation=(
            'The actuator did not start from the assumed memory state: its history before '
            'the record (a virtual prior excursion) sets the play states, and the error '
            'lives before the input has swept its full range (the wipe-out time).'
        ),
        equation='play states at t=0 = Play[r_i](virtual history U_1, U_2, ...)',
        experiment=(
            'data before the input first sweeps its full range (the wipe-out time)'
        ),
        time_dependent=False,
    ),
}


def time_effects() -> tuple[str, ...]:
    """Names of the effects that need a time axis."""
    return tuple(n for n, e in EFFECTS.items() if e.time_dependent)


DECIDING_EXPERIMENT: dict[frozenset[str], str] = {
    frozenset({"delay", "lag"}): "full-stroke sines at >= 3 frequencies a decade apart (a lag "
    "attenuates and its phase saturates, a delay's phase grows linearly with frequency)",
    frozenset({"delay", "rate"}): "a small-amplitude dither (peak-to-peak below 2 r_min): a delay "
    "still lags, rate-dependent hysteresis fades; or a DAQ loop-back latency measurement",
    frozenset({"lag", "rate"}): "a small-amplitude dither (peak-to-peak below 2 r_min) and sines "
    "at >= 3 frequencies: a lag acts on the reversible part too, rate-dependent hysteresis "
    "does not",
    frozenset({"resonance", "lag"}): "a step or a broadband multisine up to the suspected mode "
    "(a resonance rings and overshoots, a lag does not)",
    frozenset({"resonance", "delay"}): "a step or a broadband multisine up to the suspected mode",
    frozenset({"resonance", "rate"}): "a step or a broadband multisine: a mode rings at f_d "
    "whatever the hysteresis state",
    frozenset({"creep", "drift"}): "an up-then-down staircase with holds of 3-30 s (creep follows "
    "the sign of the last step, drift does not)",
}

#: Disambiguation order of the families (notes §4.3): cheapest and most common first.
FAMILY_PRIORITY: dict[str, int] = {
    "memory": 0, "dynamics": 1, "slow": 2, "static": 3, "static-offset": 3,
}

#: An untestable effect -> (accepted effects it would look like, why): an accepted look-alike
#: is reported ambiguous with it, with the experiment that makes it testable.
UNTESTABLE_LOOKALIKES: dict[str, tuple[frozenset[str], str]] = {
    "creep": (frozenset({"lag", "delay"}), "without holds, the fast end of a creep relaxation "
              "spectrum acts as a lag at the excitation frequency; creep itself was untestable"),
    "rate": (frozenset({"delay", "lag", "resonance"}), "at a single excitation rate, "
             "rate-dependent hysteresis widens the loop as a {best} does; rate itself was "
             "untestable"),
}
