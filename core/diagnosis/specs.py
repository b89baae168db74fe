"""What the diagnosis knows across effects: the experiments that separate two look-alikes,
the order the families are disambiguated in, and the rules read off the registry (which
effects need a time axis, which the recordings cannot test).

Each effect's own specification is its :class:`~core.diagnosis.registry.DiagnosableEffect`
in :data:`core.diagnosis.registry.EFFECTS`.
"""

from __future__ import annotations

from typing import Any

from .registry import EFFECTS

__all__ = ["DECIDING_EXPERIMENT", "FAMILY_PRIORITY", "spec_untestable", "time_effects"]


def spec_untestable(ctx: Any, already: set[str] | frozenset[str] = frozenset()
                    ) -> list[dict[str, str]]:
    """``{"name", "reason", "experiment"}`` of every effect whose own rule
    (:attr:`~core.diagnosis.registry.DiagnosableEffect.untestable`) says the recordings of
    ``ctx`` cannot test it (effects in ``already`` are skipped)."""
    out = []
    for name, e in EFFECTS.items():
        if e.untestable is None or name in already:
            continue
        why = e.untestable(ctx)
        if why:
            why, exp = why if isinstance(why, tuple) else (why, e.experiment or "")
            out.append({"name": name, "reason": why, "experiment": exp})
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

