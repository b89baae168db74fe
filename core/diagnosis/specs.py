"""One specification per effect: family, explanation, equation, what makes it testable.

The engine, the reports and the untestable rules read these; the candidate builders are in
:data:`core.diagnosis.candidates.BUILDERS` under the same names.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["DECIDING_EXPERIMENT", "EFFECTS", "FAMILY_PRIORITY", "UNTESTABLE_LOOKALIKES",
           "UNTESTABLE_RULES", "Effect", "spec_untestable", "time_effects"]


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
    untestable : str or None
        Rule of :data:`UNTESTABLE_RULES` that says when the recordings cannot test it
        (``None``: the engine's own rules, or always testable).
    amplitude_dependent : bool
        Changes the loop from one input amplitude to the next beyond what the PI's own
        memory does (a static output map, a loop-shape nonlinearity): with several
        recordings of one amplitude each, at different amplitudes, it is judged by
        predicting each recording from the others.
    lookalikes : tuple of str
        Effects of another family that the recordings may not separate from this one (an
        offset per recording and a slow drift in absolute time, across recordings taken one
        after the other): when this effect is chosen, such a candidate that meets the
        effect-size rules and explains nearly as much is reported ambiguous with it, even if
        it failed only the significance rule.
    """

    name: str
    family: str
    explanation: str
    equation: str
    experiment: str | None = None
    time_dependent: bool = False
    between_recordings: bool = False
    untestable: str | None = None
    amplitude_dependent: bool = False
    lookalikes: tuple[str, ...] = ()


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
        lookalikes=("offset",),
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
            'The loop is asymmetric: ascending and descending branches curve differently '
            '(field-dependent d33, an even-order nonlinearity); a static output map that '
            'classical (odd-symmetric) PI cannot represent. Actuator and sensor '
            'nonlinearity cannot be separated from (u, y) alone. (A loop that flattens '
            'at both ends at every amplitude is saturation, a flat stretch is a dead-zone; '
            'the three are look-alikes, told apart by the better held-out model.)'
        ),
        equation='y = x + a2 ((x - c)/s)^2 + a3 ((x - c)/s)^3',
        experiment='a full-range symmetric periodic excitation',
        time_dependent=False,
        amplitude_dependent=True,
    ),
    "saturation": Effect(
        "saturation",
        "static",
        explanation=(
            'The loop saturates: towards the input extremes both branches flatten, at every '
            'amplitude (magnetic saturation, a stroke limit, a saturating drive). A PI is '
            'built from straight plays and obeys the Masing rules, so it cannot saturate '
            'loops of several amplitudes at once; the tanh-envelope GPI drives the plays '
            'through a saturating input map.'
        ),
        equation='y = p0 w + sum_i p_i Play[r_i](w),  w = tanh(a1 u + a2)  (gpi-tanh)',
        experiment=(
            'loops (or reversals) of several amplitudes, or a travel covering the input range '
            'back and forth'
        ),
        untestable="one-branch",
    ),
    "dead-zone": Effect(
        "dead-zone",
        "static",
        explanation=(
            'A threshold / dead band: over part of the input range (below a threshold, on one '
            'side, or around the centre) the output hardly responds, then follows the input '
            'again (a thresholded actuator, backlash-like play at the input, a one-sided '
            'drive). The dead-zone GPI drives the plays through a piecewise-linear input map '
            'whose flat segment is the dead band.'
        ),
        equation='y = p0 w + sum_i p_i Play[r_i](w),  w = gamma(u) (dead-zone '
                 'superposition, gpi-deadzone)',
        experiment=(
            'loops (or reversals) of several amplitudes, or a travel covering the input range '
            'back and forth'
        ),
        untestable="one-branch",
    ),
    "offset": Effect(
        "offset",
        "static-offset",
        explanation=(
            'The sensor zero differs between recordings (an offset per recording).'
        ),
        equation='y = x + c_k  (one offset per recording)',
        lookalikes=("drift",),
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


def _one_branch(ctx: Any) -> str | None:
    """Loop shapes need a loop: at least one travel up and one down, each over half of the
    input range, inside the training rows (on a single branch any monotone curve is a PI's
    first branch, so saturation or a dead band cannot be told from the PI itself)."""
    from ..fitting.thresholds import reversal_indices

    span = max((float(np.ptp(r.u[m])) for r, m in zip(ctx.records, ctx.train, strict=True)
                if m.any()), default=0.0)
    n = 0
    for r, m in zip(ctx.records, ctx.train, strict=True):
        rev = np.unique(np.r_[0, reversal_indices(r.u, 0.1 * span), r.n_samples - 1])
        for a, b in zip(rev[:-1], rev[1:], strict=True):
            if abs(r.u[b] - r.u[a]) >= 0.5 * span and m[a : b + 1].any():
                n += 1
    if n >= 2:
        return None
    return ("the training rows hold no loop (fewer than two travels over half of the input "
            "range, one up and one down): on a single branch any monotone curve is a PI "
            "branch, so the loop shape cannot be told from the PI itself")


#: Untestable rules by name: ``rule(ctx) -> reason or None`` (``ctx`` a
#: :class:`core.diagnosis.context.FitContext`).
UNTESTABLE_RULES: dict[str, Callable[[Any], str | None]] = {"one-branch": _one_branch}


def spec_untestable(ctx: Any, already: set[str] | frozenset[str] = frozenset()
                    ) -> list[dict[str, str]]:
    """``{"name", "reason", "experiment"}`` of every effect whose spec rule says the
    recordings of ``ctx`` cannot test it (effects in ``already`` are skipped)."""
    out = []
    for name, e in EFFECTS.items():
        if e.untestable is None or name in already:
            continue
        why = UNTESTABLE_RULES[e.untestable](ctx)
        if why:
            out.append({"name": name, "reason": why, "experiment": e.experiment or ""})
    return out


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
    frozenset({"saturation", "dead-zone"}): "loops of a larger amplitude (a saturation keeps "
    "flattening towards the extremes, a dead band has a fixed width after which the slope "
    "recovers)",
    frozenset({"saturation", "asymmetry"}): "symmetric loops of several amplitudes (saturation "
    "flattens both ends of every loop alike, an asymmetric map bends one side more)",
    frozenset({"dead-zone", "asymmetry"}): "loops of several amplitudes and offsets (a dead "
    "band stays at the same input level, an output map follows the output level)",
    frozenset({"offset", "drift"}): "a zero-input hold at the start and the end of every "
    "recording (an offset stays the same within a recording, a drift moves it)",
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
