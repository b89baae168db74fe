"""Loop-shape input maps of the diagnosis: saturation and dead zones before the play bank.

A PI model's loops are built from straight-line play operators: its branches are odd-symmetric
(Masing rules), so a loop that saturates or has a threshold / dead band is missed at every
amplitude at once (missing-physics notes E9, E10). The core's generalized PI models replace
the input of the play bank by a memoryless monotone map ``w = g(u)``:

* ``("tanh", a1, a2)``: ``w = tanh(a1 u + a2)``, the single-branch tanh envelope of
  :class:`core.gpi.TanhGPI` (saturation; ``a2`` shifts it, so one side may saturate first);
* ``("deadzone", thresholds, weights)``: the dead-zone superposition
  :class:`core.deadzone.DeadZoneMap` of :class:`core.gpi.DeadZoneGPI` (a threshold or dead
  band where a segment's slope is small; one-sided when only one side has one).

A shape is a tuple of such stages, applied in order (``()`` = classical PI). A stop-operator
base (:mod:`core.diagnosis.bases`) puts its own input map first, ``("gap", b, k, r, w)``: the
input behind a backlash gap of width ``b`` (:func:`core.diagnosis.bases.stop_input`); it is
part of the base, not a loop-shape effect (:func:`loop_shape` leaves it out). For fixed
parameters the model is still linear in the play weights (the plays run on ``w``), so the
diagnosis fits it with the same separable least squares as every other effect
(:mod:`core.diagnosis.structure`), and the found model is an ordinary member of the model
algebra: ``gpi-tanh`` / ``gpi-deadzone`` (a :class:`~core.base.Chain` of both when both were
found), which simulates, inverts and exports to JSON, MATLAB and C.

This module holds only the maps (no diagnosis state); the candidate builders that search their
parameters are in :mod:`core.diagnosis.candidates`.
"""

from __future__ import annotations

from collections.abc import Sequence
from types import SimpleNamespace
from typing import Any

import numpy as np

from .._typing import ArrayLike, Float1D
from ..base import Chain, Model
from ..deadzone import DeadZoneMap
from ..gpi import DeadZoneGPI, TanhEnvelope, TanhGPI
from ..pi import PIModel
from .bases import GAP, stop_gains, stop_input, stop_ratio
from .grid import baseline_thresholds

__all__ = ["DEAD_BAND_SLOPE", "GAP", "SHAPE_EFFECTS", "apply_shape", "dead_band_words",
           "dead_zone_stage", "describe_shape", "gap_stage_of", "hysteresis_model",
           "loop_shape", "output_gains", "shape_effects", "shape_thresholds", "signed_ratio",
           "stage_map", "tanh_stage"]

#: Shape stage kind -> effect name.
SHAPE_EFFECTS: dict[str, str] = {"tanh": "saturation", "deadzone": "dead-zone"}


def gap_stage_of(shape: tuple) -> tuple | None:
    """The stop-operator base's input map of ``shape`` (its first stage), or ``None``."""
    return shape[0] if shape and shape[0][0] == GAP else None


def signed_ratio(shape: tuple) -> float:
    """The slip force's ratio by direction of the stop base of ``shape``
    (:func:`core.diagnosis.bases.stop_ratio`; 1 without one or without a stop base)."""
    gap = gap_stage_of(shape)
    return 1.0 if gap is None else stop_ratio(gap)


def output_gains(shape: tuple, u: ArrayLike) -> Float1D | None:
    """The gain on the bank's output of each sample of ``u`` ``(N,)`` where the stop base of
    ``shape`` has a slip force by direction (:func:`core.diagnosis.bases.stop_gains`: 1 or
    the ratio, by the sign of the base's force); ``None`` otherwise (every row's gain 1)."""
    gap = gap_stage_of(shape)
    return None if gap is None else stop_gains(gap, np.asarray(u, dtype=np.float64))


def loop_shape(shape: tuple) -> tuple:
    """The loop-shape stages of ``shape`` (the stop base's input map left out)."""
    return tuple(st for st in shape if st[0] != GAP)


def tanh_stage(a1: float, a2: float) -> tuple:
    """The stage ``w = tanh(a1 u + a2)`` (``a1 > 0`` in 1/input units)."""
    return ("tanh", float(a1), float(a2))


def dead_zone_stage(gamma: DeadZoneMap) -> tuple:
    """The stage ``w = γ(u)`` of a dead-zone superposition."""
    return ("deadzone", tuple(float(v) for v in gamma.thresholds),
            tuple(float(v) for v in gamma.weights))


def stage_map(stage: tuple) -> TanhEnvelope | DeadZoneMap:
    """The memoryless core model of one shape stage."""
    if stage[0] == "tanh":
        a = np.array([1.0, stage[1], stage[2], 0.0])
        return TanhEnvelope(a, a.copy())
    if stage[0] == "deadzone":
        return DeadZoneMap(np.asarray(stage[1]), np.asarray(stage[2]))
    raise ValueError(f"unknown loop-shape stage {stage[0]!r}")


def _apply_stage(stage: tuple, u: np.ndarray) -> np.ndarray:
    if stage[0] == GAP:
        return stop_input(stage, u)
    if stage[0] == "tanh":  # single-branch envelope: memoryless, no direction bookkeeping
        return np.tanh(stage[1] * u + stage[2])
    return stage_map(stage)(u)


def apply_shape(shape: tuple, u: ArrayLike) -> Float1D:
    """The play-bank input ``w`` for input ``u`` (``u`` itself for ``shape == ()``)."""
    w = np.asarray(u, dtype=np.float64)
    for stage in shape:
        w = _apply_stage(stage, w)
    return w


def shape_effects(shape: tuple) -> list[str]:
    """Effect names of the stages of ``shape``, in order."""
    return [SHAPE_EFFECTS[st[0]] for st in loop_shape(shape)]


def hysteresis_model(shape: tuple, pi: Model) -> Model:
    """The hysteresis stage of a structure: ``pi`` driven through ``shape``.

    A single stage and a :class:`~core.pi.PIModel` give the registered cascade
    (``gpi-tanh`` / ``gpi-deadzone``); otherwise the maps are leading stages of a chain.
    """
    if not shape:
        return pi
    maps = [stage_map(st) for st in shape]
    last = maps[-1]
    if isinstance(pi, PIModel):
        tail: Model = (TanhGPI(pi, last) if isinstance(last, TanhEnvelope)
                       else DeadZoneGPI(pi, last))
        return tail if len(maps) == 1 else Chain.of(*maps[:-1], tail)
    return Chain.of(*maps, pi)


def shape_thresholds(
    shape: tuple, records: Sequence, masks: Sequence[np.ndarray], n: int
) -> Float1D:
    """``n`` play thresholds in the units of ``w``, by the baseline's rule
    (:func:`core.diagnosis.structure.baseline_thresholds` on the mapped inputs)."""
    mapped = [SimpleNamespace(u=apply_shape(shape, r.u)) for r in records]
    return baseline_thresholds(mapped, masks, n)


def describe_shape(stage: tuple, u_lo: float, u_hi: float) -> dict[str, Any]:
    """The physics of one fitted stage, in input units, for the report.

    ``saturation``: the input ``u_half`` at which the map has lost half of its slope on
    either side (``tanh`` slope ``1 - tanh² = 1/2``), and the centre ``u_c`` of the envelope.
    ``dead-zone``: the breakpoints and the relative slope of every segment (1 = the steepest).
    """
    if stage[0] == "tanh":
        a1, a2 = stage[1], stage[2]
        uc = -a2 / a1
        half = float(np.arctanh(np.sqrt(0.5))) / a1
        s_lo = float(1 - np.tanh(a1 * u_lo + a2) ** 2)
        s_hi = float(1 - np.tanh(a1 * u_hi + a2) ** 2)
        return {"center": float(uc), "half_slope_below": float(uc - half),
                "half_slope_above": float(uc + half), "slope_at_input_min": s_lo,
                "slope_at_input_max": s_hi,
                "saturation": f"the loop's slope falls to half below {uc - half:.4g} and above "
                f"{uc + half:.4g}; at the input extremes it is {100 * s_lo:.2g} % and "
                f"{100 * s_hi:.2g} % of the slope at the centre {uc:.4g}"}
    g = stage_map(stage)
    assert isinstance(g, DeadZoneMap)
    t = np.asarray(g.thresholds, dtype=np.float64)
    sl = np.asarray(g.slopes, dtype=np.float64)
    # merge segments of equal slope (0 is the map's anchor, not necessarily a breakpoint)
    keep = [j for j in range(t.size) if not np.isclose(sl[j], sl[j + 1], rtol=1e-9)]
    brk = t[keep]
    seg = np.concatenate(([sl[0]], sl[[j + 1 for j in keep]]))
    # segments that meet the input range [u_lo, u_hi]
    lo_e = np.concatenate(([-np.inf], brk))
    hi_e = np.concatenate((brk, [np.inf]))
    used = (hi_e > u_lo) & (lo_e < u_hi)
    seg = seg[used]
    brk = brk[(brk > u_lo) & (brk < u_hi)]
    rel = seg / seg.max()
    return {"breakpoints": [float(v) for v in brk],
            "relative_slopes": [float(v) for v in rel],
            "dead_band": dead_band_words(brk, rel, u_lo, u_hi)}


#: A segment whose slope is at most this share of the steepest one is called a dead band
#: (the upper bound of the ``dead-zone`` candidate's band slope).
DEAD_BAND_SLOPE = 0.5


def dead_band_words(breaks: np.ndarray, rel: np.ndarray, u_lo: float, u_hi: float) -> str:
    """Where the map is nearly flat, in words (input units); ``""`` when nowhere."""
    edges = np.concatenate(([u_lo], breaks, [u_hi]))
    out = []
    for j, r in enumerate(rel):
        a, b = edges[j], edges[j + 1]
        if r <= DEAD_BAND_SLOPE and b > a:
            side = ("below" if j == 0 else "above" if j == rel.size - 1 else "between")
            where = (f"below {b:.4g}" if side == "below" else f"above {a:.4g}"
                     if side == "above" else f"between {a:.4g} and {b:.4g}")
            out.append(f"dead band {where} (slope {100 * r:.0f} % of the steepest segment)")
    return "; ".join(out)
